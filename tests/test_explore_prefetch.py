"""The search's evaluator traces the space's grids ahead on a thread while the global phase
replays on one core (``SceneEvaluator.prefetch``): the traces are those made on demand, each
grid is made once, a grid that cannot be made fails where it is asked for, the thread ends before
the workers fork, and the explorer's answer does not depend on it."""
import numpy as np
import pytest

import mprt
from mprt.errors import InvalidArgument
from mprt.explore import load_space
from mprt.explore.evaluate import SceneEvaluator
from mprt.explore.explorer import _prefetch_order, explore
from mprt.explore.parallel import Pool
from mprt.explore.space import default_space

from test_explore_level3 import SMALL


def test_prefetched_traces_are_those_made_on_demand():
    scene = mprt.Scene.spd("balls", 1)
    dims = [(6, 6, 6), (2, 2, 2), (9, 9, 9), (4, 4, 4)]
    a = SceneEvaluator(scene, 24, 24, level=1)
    a.prefetch(dims)
    got = [a.evaluator(d)[0].trace for d in reversed(dims)]     # waited for, or made here first
    a.stop_prefetch()
    assert a.traces_made == len(dims)                           # each once, whichever thread made it
    b = SceneEvaluator(scene, 24, 24, level=1)
    for d, t in zip(reversed(dims), got):
        u = b.evaluator(d)[0].trace
        assert np.array_equal(t.visits, u.visits) and np.array_equal(t.rays, u.rays)
    assert a._prefetch is None and not a._pending


def test_a_grid_the_prefetch_cannot_make_fails_where_it_is_asked_for():
    a = SceneEvaluator(mprt.Scene.spd("balls", 1), 16, 16)
    a.prefetch([(0, 4, 4), (3, 3, 3)])
    a.stop_prefetch()
    with pytest.raises(InvalidArgument, match="subdivision 0x4x4"):
        a.evaluator((0, 4, 4))
    assert not a._pending and (0, 4, 4) not in a._held
    assert a.evaluator((3, 3, 3))[0].visits > 0


def test_the_pool_ends_threads_before_it_forks():
    pool = Pool(mprt.Scene.spd("tetra", 1), 2)
    calls = []
    pool.before_fork = lambda: calls.append(1)
    try:
        pool._executor()
        assert calls == [1]
    finally:
        pool.close()


def test_the_order_begins_in_the_middle_of_the_space():
    scene = mprt.Scene.spd("balls", 1)
    order = _prefetch_order(scene, default_space())
    ns = [4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256]
    assert len(order) == len(ns) and order[0] == _prefetch_order(scene, default_space().with_subdivision((32,)))[0]
    assert order[-1] == _prefetch_order(scene, default_space().with_subdivision((256,)))[0]


def test_the_explorer_finds_with_a_prefetch_what_one_process_finds(monkeypatch):
    made = []
    orig = SceneEvaluator.prefetch

    def prefetch(self, dims):
        made.append(list(dims))
        orig(self, dims)
    monkeypatch.setattr(SceneEvaluator, "prefetch", prefetch)
    scene = mprt.Scene.spd("tetra", 1)
    sp = load_space(SMALL)
    got = [explore(scene, 16, 16, space=sp, budget=400, level=3, max_evals=16, workers=w) for w in (1, 2)]
    assert len(made) == 1 and len(made[0]) == 1            # the two-worker run's search, its one grid
    for key in ("best", "references", "history", "evaluations"):
        assert got[0][key] == got[1][key], key
