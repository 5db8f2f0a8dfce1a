"""Grid.intersect's rays walked four at a time (c/src/packet.c, MPRT_PACKETS=1) change nothing: the
same hits, distances (bits) and counters as one ray at a time, ray by ray.

The environment is read at each call: MPRT_PACKETS=1 turns the lanes on (off by default: they
measured no faster, studies/03_bench/README.md), MPRT_PACKET_SIMD=0 asks for the portable loop
instead of the AVX2 one the processor may offer."""
import numpy as np
import pytest

import listing_cases as L
import mprt

MODES = {"one": {}, "lanes": {"MPRT_PACKETS": "1"}, "portable lanes": {"MPRT_PACKETS": "1", "MPRT_PACKET_SIMD": "0"}}
SIZES = {"balls": 1, "gears": 1, "mount": 2, "rings": 1, "tetra": 2, "tree": 2}


def intersect(monkeypatch, mode, grid, o, d):
    with monkeypatch.context() as m:
        for k in ("MPRT_PACKETS", "MPRT_PACKET_SIMD"):
            m.delenv(k, raising=False)
        for k, v in MODES[mode].items():
            m.setenv(k, v)
        return grid.intersect(o, d, return_counters=True)


def same_everywhere(monkeypatch, grid, o, d, what):
    t0, p0, c0 = intersect(monkeypatch, "one", grid, o, d)
    for mode in ("lanes", "portable lanes"):
        t, p, c = intersect(monkeypatch, mode, grid, o, d)
        assert np.array_equal(t.view(np.int64), t0.view(np.int64)), (what, mode, int(np.sum(t != t0)))
        assert np.array_equal(p, p0) and c == c0, (what, mode)
    return t0, p0, c0


@pytest.mark.parametrize("name", sorted(SIZES))
def test_eye_rays_of_every_spd_scene_hit_and_count_as_one_at_a_time(name, monkeypatch):
    """Each SPD scene's eye rays (paper and spd rules) and random rays, on its default grid, a coarse
    cubic one and an uneven one: the same t (bits), primitives and counters in lanes as alone."""
    scene = mprt.Scene.spd(name, SIZES[name])
    rng = np.random.default_rng(3)
    st = scene.grid(1).stats()
    lo, hi = np.array(st["lo"]), np.array(st["hi"])
    ro = rng.uniform(lo - 0.3 * (hi - lo), hi + 0.3 * (hi - lo), size=(1500, 3))
    rd = rng.normal(size=(1500, 3))
    for n in (None, 5, (23, 9, 14)):
        grid = scene.grid(n)
        for rules in ("paper", "spd"):
            o, d = grid.camera_rays(40, 40, rules=rules)
            t, p, c = same_everywhere(monkeypatch, grid, o, d, (n, rules))
            assert (p >= 0).sum() > 100 and c["os_visits"] > len(o)
        same_everywhere(monkeypatch, grid, ro, rd, (n, "random"))


def test_counts_are_each_rays_own(monkeypatch):
    """The counters of every batch of 2 or 3 consecutive eye rays (the lanes hold rays from all over
    the batch) equal those of the same rays one at a time: each test and step is counted for its ray."""
    scene = mprt.Scene.spd("tetra", 2)
    grid = scene.grid(12)
    o, d = grid.camera_rays(24, 24)
    k = 0
    while k < len(o):
        m = 2 + k % 2
        a = {mode: intersect(monkeypatch, mode, grid, o[k:k + m], d[k:k + m]) for mode in ("one", "lanes")}
        assert a["one"][2] == a["lanes"][2] and np.array_equal(a["one"][1], a["lanes"][1]), k
        k += m


@pytest.mark.parametrize("n", L.GRIDS, ids=str)
@pytest.mark.parametrize("name", L.CASES)
def test_rays_through_voxel_corners_edges_and_faces(name, n, monkeypatch):
    """Rays exactly through voxel corners, edges, faces and tangent points, along voxel planes and
    voxel edges (tests/listing_cases.py): the same in lanes as alone."""
    s, pts = L.scene(name)
    o, d = L.rays(pts)
    t, _, _ = same_everywhere(monkeypatch, s.grid(n), o, d, (name, n))
    assert np.isfinite(t).sum() > 200


@pytest.mark.parametrize("n", (8, 16, (8, 16, 32)), ids=str)
def test_tetra_vertices_and_edges_on_voxel_planes(n, monkeypatch):
    s, o, d = L.tetra_rays()
    same_everywhere(monkeypatch, s.grid(n), o, d, n)


@pytest.mark.parametrize("env", [{"MPRT_SKIP": "1"}, {"MPRT_JUMP_MIN": "2"}])
def test_walks_that_jump_empty_blocks(env, monkeypatch):
    """On grids made to jump over empty blocks (the lanes hand such voxels to the jump) the same."""
    scene = mprt.Scene.spd("tree", 2)
    with monkeypatch.context() as m:
        for k, v in env.items():
            m.setenv(k, v)
        grid = scene.grid((96, 96, 20))
    o, d = grid.camera_rays(48, 48)
    _, p, c = same_everywhere(monkeypatch, grid, o, d, env)
    assert (p >= 0).sum() > 100


def test_axis_parallel_rays_and_origins_inside(monkeypatch):
    """Directions with zero components (no crossings on those axes) and origins inside the grid."""
    scene = mprt.Scene.spd("gears", 1)
    st = scene.grid(1).stats()
    lo, hi = np.array(st["lo"]), np.array(st["hi"])
    rng = np.random.default_rng(8)
    o = rng.uniform(lo, hi, size=(2000, 3))
    d = rng.normal(size=(2000, 3))
    d[rng.random((2000, 3)) < 0.4] = 0
    d[np.all(d == 0, axis=1), 2] = -1
    same_everywhere(monkeypatch, scene.grid(11), o, d, "axis-parallel")


def test_a_bad_ray_fails_as_one_at_a_time(monkeypatch):
    """A batch holding a NaN direction fails with the same message, lanes on or off."""
    scene = mprt.Scene.spd("tetra", 1)
    grid = scene.grid(4)
    o, d = grid.camera_rays(8, 8)
    d = d.copy()
    d[37, 1] = np.nan
    msgs = []
    for mode in ("one", "lanes"):
        with pytest.raises(mprt.MprtError) as e:
            intersect(monkeypatch, mode, scene.grid(4), o, d)
        msgs.append(str(e.value))
    assert msgs[0] == msgs[1] and "ray 37" in msgs[0]
