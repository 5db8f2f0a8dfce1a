"""The C objects behind the Python ones are freed in an order C can live with, however Python
collects them.  These fail as use-after-free under `make asan-py` (ASan), which runs them."""
import gc

import mprt


def test_a_grid_whose_scene_has_no_other_reference_goes_first():
    """A Grid's destruction reads its scene: a Scene held only by its Grid (made inline) is
    freed after the grid, when the grid goes by reference counting or by the collector."""
    _, trace = mprt.Scene.spd("balls", size=1).grid(2).trace(4, 4)      # scene and grid go here
    assert len(trace.visits) > 0
    g = mprt.Scene.spd("tetra", size=1).grid(3)
    g.cycle = g                          # a cycle: the collector frees grid and scene together
    assert g.scene.info()["prims"] > 0 and g.render(4, 4)[0].shape[:2] == (4, 4)
    del g
    gc.collect()
    s = mprt.Scene.spd("gears", size=1)
    grids = [s.grid(n) for n in (1, 2, 3)]
    del s                                # the scene now held by its grids alone
    assert [gr.render(2, 2)[0].shape[:2] for gr in grids] == [(2, 2)] * 3
    del grids
    gc.collect()
