"""Empty-space skipping changes no count: the 3DDDA's jumps over empty voxels
give the same traces, hits and counters as the voxel-by-voxel walk.

Grids read three environment variables when they are made: MPRT_SKIP=1 (jump
from large blocks of empty voxels, away from the ray's origin), MPRT_JUMP_MIN=2
(jump from every block the grid knows, the smallest included, wherever the walk
is) and MPRT_NO_SKIP=1 (the plain walk, whatever the others say).  By default
the walk is plain: at the grids studies/03_bench measured, jumps cost renders
more than the voxels they pass.  Each comparison runs the same work under
these, on grids of their own."""
import os

import numpy as np
import pytest

import mprt

GOLDEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "golden")
GOLDEN_FILES = sorted(f for f in os.listdir(GOLDEN) if f.endswith(".npz"))
SCENE_SIZES = {"balls": 1, "gears": 1, "mount": 2, "rings": 1, "tetra": 2, "tree": 4}
PLAIN, EVERYWHERE, SKIP, DEFAULT = {"MPRT_NO_SKIP": "1"}, {"MPRT_JUMP_MIN": "2"}, {"MPRT_SKIP": "1"}, {}
VARIABLES = ("MPRT_NO_SKIP", "MPRT_JUMP_MIN", "MPRT_SKIP")


def grid_under(monkeypatch, env: dict, scene, n, variables=VARIABLES):
    """A grid made while the environment holds env (and none of the variables otherwise)."""
    with monkeypatch.context() as m:
        for k in variables:
            m.delenv(k, raising=False)
        for k, v in env.items():
            m.setenv(k, v)
        return scene.grid(n)


def random_rays(scene, n, seed):
    """n rays with origins in the scene's box grown by a fifth and uniform directions."""
    rng = np.random.default_rng(seed)
    st = scene.grid(1).stats()
    lo, hi = np.array(st["lo"]), np.array(st["hi"])
    pad = 0.2 * (hi - lo)
    o = rng.uniform(lo - pad, hi + pad, size=(n, 3))
    d = rng.normal(size=(n, 3))
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("fname", GOLDEN_FILES)
def test_golden_trace_regenerates_with_skipping_off_and_everywhere(fname, monkeypatch):
    """Each committed golden trace regenerates bit-identically with the plain walk and with jumps wherever possible."""
    gold = mprt.load_trace(os.path.join(GOLDEN, fname))
    m = gold.meta
    name, size = m["scene"].split(":")
    scene = mprt.Scene.spd(name, int(size))
    for env in (PLAIN, EVERYWHERE):
        grid = grid_under(monkeypatch, env, scene, tuple(m["grid"]))
        _, t = grid.trace(m["width"], m["height"], rules=m["rules"], threshold=m["threshold"], tile=m["tile"])
        assert np.array_equal(t.rays, gold.rays) and np.array_equal(t.visits, gold.visits), env
        del grid


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_random_and_eye_rays_hit_and_count_the_same_with_jumps(name, monkeypatch):
    """intersect gives the same hits, distances and counters (voxels entered included) on a cubic and an uneven grid."""
    scene = mprt.Scene.spd(name, SCENE_SIZES[name])
    ro, rd = random_rays(scene, 4000, seed=11)
    po, pd = scene.grid(1).camera_rays(40, 40)
    o, d = np.concatenate([ro, po]), np.concatenate([rd, pd])
    for n in ((48, 48, 48), (96, 40, 48)):
        results = {}
        for label, env in (("plain", PLAIN), ("everywhere", EVERYWHERE), ("skip", SKIP), ("default", DEFAULT)):
            grid = grid_under(monkeypatch, env, scene, n)
            results[label] = grid.intersect(o, d, return_counters=True), grid.stats()["jump_voxels"]
            del grid
        (tp, pp, cp), jumps_plain = results["plain"]
        assert jumps_plain == 0
        for label in ("everywhere", "skip", "default"):
            (t, p, c), _ = results[label]
            assert np.array_equal(t, tp) and np.array_equal(p, pp) and c == cp, (n, label)
        # the comparison means something: the jumping grid has blocks to jump, and rays enter empty voxels
        assert results["everywhere"][1] > 0
        assert cp["voxels_traversed"] > cp["ic_visits"]


@pytest.mark.parametrize("rules", ["paper", "spd"])
@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_traces_are_the_same_with_jumps(name, rules, monkeypatch):
    """A whole trace (every ray tree, every stage visit) is identical with the plain walk and with jumps."""
    scene = mprt.Scene.spd(name, SCENE_SIZES[name])
    traces = []
    for env in (PLAIN, EVERYWHERE):
        grid = grid_under(monkeypatch, env, scene, (40, 40, 40))
        traces.append(grid.trace(20, 20, rules=rules, tile=8)[1])
        del grid
    a, b = traces
    assert np.array_equal(a.rays, b.rays) and np.array_equal(a.visits, b.visits)


def test_a_bad_jump_threshold_is_an_error_naming_the_variable(monkeypatch):
    """MPRT_JUMP_MIN outside 2..255 (or not a number) fails the grid with a message naming it."""
    scene = mprt.Scene.spd("balls", 1)
    for bad in ("1", "256", "ten"):
        with pytest.raises(mprt.InvalidArgument, match="MPRT_JUMP_MIN"):
            grid_under(monkeypatch, {"MPRT_JUMP_MIN": bad}, scene, 8)


def test_the_walk_is_plain_unless_jumps_are_asked_for(monkeypatch):
    """By default a grid marks no voxel to jump from; MPRT_SKIP=1 and MPRT_JUMP_MIN mark some, and
    MPRT_NO_SKIP=1 wins over both; MPRT_SKIP=0 or empty is off."""
    scene = mprt.Scene.spd("tetra", 2)

    def jumps(env):
        return grid_under(monkeypatch, env, scene, (48, 48, 48)).stats()["jump_voxels"]

    assert jumps(DEFAULT) == 0 and jumps({"MPRT_SKIP": "0"}) == 0 and jumps({"MPRT_SKIP": ""}) == 0
    assert jumps(SKIP) > 0 and jumps(EVERYWHERE) >= jumps(SKIP)
    assert jumps(dict(SKIP, **PLAIN)) == 0 and jumps(dict(EVERYWHERE, **PLAIN)) == 0
