"""Testing a voxel's primitives several at a time changes nothing: the tests of c/src/ic_pack.h give
the same traces, images, hits and counters as the walk testing one primitive at a time.

Grids read three environment variables when they are made: MPRT_IC_PACK=0 (one at a time, as
before), MPRT_IC_BLOCKS=0 (triangles from IC's records, never from per-voxel blocks) and
MPRT_IC_SIMD=0 (the portable C99 copies instead of the AVX2 ones the processor may offer); by
default the AVX2 copies, or one at a time without AVX2.  Each comparison runs the same work on
grids made under each."""
import os

import numpy as np
import pytest

import mprt

from test_skip import grid_under as skip_grid_under

GOLDEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "golden")
GOLDEN_FILES = sorted(f for f in os.listdir(GOLDEN) if f.endswith(".npz"))
SCALAR, PORTABLE, DEFAULT = {"MPRT_IC_PACK": "0"}, {"MPRT_IC_SIMD": "0"}, {}
RECORDS = {"MPRT_IC_BLOCKS": "0"}  # the triangles from IC's records, never from per-voxel blocks
VARIABLES = ("MPRT_IC_PACK", "MPRT_IC_SIMD", "MPRT_IC_BLOCKS")


def grid_under(monkeypatch, env: dict, scene, n):
    """A grid made while the environment holds env (and none of the IC variables otherwise)."""
    return skip_grid_under(monkeypatch, env, scene, n, VARIABLES)


def triangles_only(scene):
    p = scene.primitives()["polygons"]
    tri = np.flatnonzero(np.diff(p["vstart"]) == 3)
    out = mprt.Scene()
    for t in p["vertices"][p["vstart"][tri][:, None] + np.arange(3)]:
        out.add_polygon(t)
    return out


@pytest.mark.parametrize("fname", GOLDEN_FILES)
def test_golden_trace_regenerates_one_at_a_time_and_portable(fname, monkeypatch):
    """Each committed golden trace regenerates bit-identically without packing and with the portable block test."""
    gold = mprt.load_trace(os.path.join(GOLDEN, fname))
    m = gold.meta
    name, size = m["scene"].split(":")
    scene = mprt.Scene.spd(name, int(size))
    for env in (SCALAR, PORTABLE, RECORDS):
        grid = grid_under(monkeypatch, env, scene, tuple(m["grid"]))
        _, t = grid.trace(m["width"], m["height"], rules=m["rules"], threshold=m["threshold"], tile=m["tile"])
        assert np.array_equal(t.rays, gold.rays) and np.array_equal(t.visits, gold.visits), env


@pytest.mark.parametrize("name,size,tris", [("tetra", 2, False), ("tetra", 2, True), ("mount", 2, False),
                                            ("mount", 2, True), ("mount", 1, True), ("tree", 2, False),
                                            ("balls", 1, False), ("rings", 1, False)])
def test_rays_hit_and_count_the_same(name, size, tris, monkeypatch):
    """intersect gives the same hits, distances (bits) and counters on eye rays and random rays, on cubic and
    uneven grids: the scene's triangles alone and with its spheres (mount) in the same voxels, and spheres,
    cones and cylinders (the ball filter) without triangles (tree, balls, rings)."""
    scene = mprt.Scene.spd(name, size)
    rng = np.random.default_rng(5)
    st = scene.grid(1).stats()
    lo, hi = np.array(st["lo"]), np.array(st["hi"])
    ro = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), size=(3000, 3))
    rd = rng.normal(size=(3000, 3))
    po, pd = scene.grid(1).camera_rays(48, 48)
    o, d = np.concatenate([ro, po]), np.concatenate([rd, pd])
    if tris:
        scene = triangles_only(scene)
    for n in ((7, 7, 7), (24, 24, 24), (40, 17, 29)):
        res = {label: grid_under(monkeypatch, env, scene, n).intersect(o, d, return_counters=True)
               for label, env in (("scalar", SCALAR), ("portable", PORTABLE), ("default", DEFAULT),
                                  ("records", RECORDS), ("portable records", dict(PORTABLE, **RECORDS)))}
        t0, p0, c0 = res["scalar"]
        for label in ("portable", "default", "records", "portable records"):
            t, p, c = res[label]
            assert np.array_equal(t.view(np.int64), t0.view(np.int64)) and np.array_equal(p, p0) and c == c0, (n, label)
        assert sum(c0["tests"].values()) > 1000 and (p0 >= 0).sum() > 500


@pytest.mark.parametrize("rules", ["paper", "spd"])
@pytest.mark.parametrize("name", ["mount", "balls"])
def test_renders_and_traces_are_the_same(name, rules, monkeypatch):
    """Renders (shadow rays stop at their first hit in list order) with and without the mailbox, on one and two
    threads, and whole traces, are identical: image bits and every counter."""
    scene = mprt.Scene.spd(name, 2 if name == "mount" else 1)
    out = {}
    for label, env in (("scalar", SCALAR), ("portable", PORTABLE), ("default", DEFAULT), ("records", RECORDS)):
        g = grid_under(monkeypatch, env, scene, (20, 20, 20))
        out[label] = ([g.render(40, 40, rules=rules, mailbox=mb, threads=th) for mb in (False, True) for th in (1, 2)],
                      g.trace(24, 24, rules=rules, tile=8)[1])
    renders0, trace0 = out["scalar"]
    for label in ("portable", "default", "records"):
        renders, trace = out[label]
        for (img, c), (img0, c0) in zip(renders, renders0):
            assert np.array_equal(img, img0) and c == c0, label
        assert np.array_equal(trace.rays, trace0.rays) and np.array_equal(trace.visits, trace0.visits), label
    assert renders0[0][1]["shadow_rays"] > 0
