"""Sampled replay (tile samples, subsets, the estimate and its interval) and the
ladder's measure/choose."""
import math
import os

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.errors import InvalidArgument
from mprt.fidelity import Analytical, Sampling, Table, evaluate, measure, replay, sample_trace
from mprt.fidelity import sampled as S
from mprt.machine import builtin
from mprt.trace import PRIMARY

HERE = os.path.dirname(os.path.abspath(__file__))
CM = CostModel.default()


@pytest.fixture(scope="module")
def frame():
    """A whole frame of 48 x 48 samples in 8 x 8 tiles (36 tiles)."""
    _, t = mprt.Scene.spd("balls", 1).grid(6).trace(48, 48, tile=8)
    return t


def test_sample_specifications():
    assert Sampling.parse("random:5:7") == Sampling("random", 5, 7)
    assert Sampling.parse("stratified:16:0") == Sampling("stratified", 16, 0)
    assert Sampling.parse("regular:4") == Sampling("regular", 4, None)
    assert str(Sampling.parse("stratified:16:0")) == "stratified:16:0"
    for bad in ("random:5", "stratified:0:1", "regular:x", "every:4", "random:-1:2"):
        with pytest.raises(InvalidArgument, match="sample must be"):
            Sampling.parse(bad)


def test_blocks_cover_the_tiling_once():
    for tx, ty, k in ((32, 32, 16), (6, 6, 4), (7, 5, 3), (3, 3, 16)):
        bl = S.blocks(tx, ty, k)
        flat = sorted(t for b in bl for t in b)
        assert flat == list(range(tx * ty))
        # serpentine: consecutive blocks are neighbours (their first tiles at most a block apart)
        bx, by = S.block_shape(tx, ty, k)
        for a, b in zip(bl, bl[1:]):
            ya, xa, yb, xb = a[0] // tx, a[0] % tx, b[0] // tx, b[0] % tx
            assert abs(ya - yb) <= by and abs(xa - xb) <= bx


def test_stratified_takes_one_tile_per_block_and_weights_sum_to_the_frame():
    sel, w, order = S.choose(Sampling("stratified", 16, 3), 32, 32)
    assert len(sel) == 64 and w.sum() == 1024 and np.all(np.diff(sel) > 0)
    bl = S.blocks(32, 32, 16)
    assert sorted(order.tolist()) == list(range(64))
    for t, o in zip(sel, order):
        assert t in bl[o]
    again = S.choose(Sampling("stratified", 16, 3), 32, 32)[0]
    assert np.array_equal(sel, again)                                   # seeded
    assert not np.array_equal(sel, S.choose(Sampling("stratified", 16, 4), 32, 32)[0])
    reg = S.choose(Sampling("regular", 16, None), 32, 32)[0]
    assert np.array_equal(reg, S.choose(Sampling("regular", 16, None), 32, 32)[0])
    sel, w, order = S.choose(Sampling("random", 10, 1), 6, 6)
    assert len(set(sel.tolist())) == 10 and order is None and math.isclose(w.sum(), 36)


def test_subset_keeps_each_tree_as_it_was(frame):
    kind = frame.rays["kind"]
    ntrees = int((kind == PRIMARY).sum())
    keep = np.zeros(ntrees, bool)
    keep[::3] = True
    sub = S.subset(frame, keep)
    assert int((sub.rays["kind"] == PRIMARY).sum()) == keep.sum()
    sub.check()                                       # a valid trace: ids, parents, visits in order
    # the third tree of the subset is the frame's seventh, visit for visit
    prim = np.flatnonzero(kind == PRIMARY)
    sprim = np.flatnonzero(sub.rays["kind"] == PRIMARY)
    a = frame.visits[(frame.visits["ray"] >= prim[6]) & (frame.visits["ray"] < prim[7])]
    b = sub.visits[(sub.visits["ray"] >= sprim[2]) & (sub.visits["ray"] < sprim[3])]
    for f in ("stage", "outcome", "steps", "tests", "prim", "made"):
        assert np.array_equal(a[f], b[f])
    assert np.array_equal(S.subset(frame, np.ones(ntrees, bool)).visits, frame.visits)


def test_sampling_every_tile_gives_the_replay_itself(frame):
    st = sample_trace(frame, "stratified:1:0")
    assert st.fraction == 1.0 and len(st.tiles) == 36
    vc = CM.visit_costs(st.trace, builtin("M").processors())
    e = evaluate(st.trace, "M", costs=vc)
    sc = S.estimate(st, e, Analytical(st.trace, vc), builtin("M"))
    assert sc.cycles == e.cycles == replay(frame, "M").cycles
    assert sc.interval == (e.cycles, e.cycles)


def test_sampled_estimate_scales_by_the_tiles_sizes(frame):
    st = sample_trace(frame, "stratified:4:2")
    assert len(st.tiles) == 9 and st.weights.sum() == 36
    vc = CM.visit_costs(st.trace, builtin("M").processors())
    an = Analytical(st.trace, vc)
    e = evaluate(st.trace, "M", costs=vc)
    tiles, sizes = an.tile_times(builtin("M"), S.tree_tiles(st.trace, st.tile))
    assert np.array_equal(tiles, st.tiles)
    sc = S.estimate(st, e, an, builtin("M"))
    # the ratio estimator: the sample's time x (frame's size / sample's size)
    expected = e.cycles * float((st.weights * sizes).sum()) / float(sizes.sum())
    assert abs(sc.cycles - expected) <= 1
    assert sc.interval[0] < sc.cycles < sc.interval[1]
    assert sc.fraction == pytest.approx(9 / 36)


def test_sampling_needs_a_whole_frame(frame):
    st = sample_trace(frame, "random:4:1")
    with pytest.raises(InvalidArgument, match="holds 4 of 36 tiles"):
        sample_trace(st.trace.__class__.from_arrays({**st.trace.meta, "tiles": st.tiles.tolist()},
                                                    st.trace.arrays()), "random:2:1")


# ---- measure and choose ----------------------------------------------------------------------

def test_measure_reports_each_levels_error_against_the_next(frame):
    table = measure(frame, ["M", "3mppe"], sample=None)
    assert [r.level for r in table.rows] == [0, 1, 2, 3]
    c = table.cycles
    # M is the same machine at levels 1 to 3 (no ring, no memories)
    assert c["M", 1] == c["M", 2] == c["M", 3]
    # the rows' errors are the cycles' relative differences
    e1 = [abs(c[n, 1] - c[n, 2]) / c[n, 2] for n in ("M", "3mppe")]
    assert table.rows[1].error_worst == pytest.approx(max(e1))
    e0 = [abs(c[n, 0] - c[n, 3]) / c[n, 3] for n in ("M", "3mppe")]
    assert table.rows[0].error_top_worst == pytest.approx(max(e0))
    assert table.rows[3].error_worst == 0.0 and table.sampled == 1.0
    assert "level" in table.text() and table.to_dict()["rows"][0]["level"] == 0


def test_choose_takes_the_cheapest_adequate_level():
    from mprt.fidelity import Row

    rows = [Row(0, 1e-4, 0.04, 0.08, 0.05, 0.09), Row(1, 1e-3, 0.01, 0.02, 0.01, 0.02),
            Row(2, 0.5, 0.0, 0.0, 0.0, 0.0)]
    t = Table(rows, {}, 1.0, None)
    assert t.choose(0.10) == 0 and t.choose(0.05) == 1 and t.choose(0.02) == 1 and t.choose(0.001) == 2
    # a faster level that is adequate wins even if it is higher
    rows[1].seconds = 1e-5
    assert t.choose(0.10) == 1


def test_measure_on_a_scene_traces_only_the_sample():
    table = measure("tetra", ["M"], levels=(0, 1), sample="stratified:4:0", width=32, height=32, grid=4, tile=8)
    assert table.sampled == pytest.approx(4 / 16)
    assert table.rows[1].error_worst == 0.0


def test_a_samples_costs_are_the_frames_sliced(frame):
    # a visit's costs depend on its own ray and children only: the sample's are the frame's
    st = sample_trace(frame, "random:7:3")
    procs = builtin("3mppe").processors()
    whole, own = CM.visit_costs(frame, procs), CM.visit_costs(st.trace, procs)
    for k in ("process", "receive", "send", "flits"):
        assert np.array_equal(getattr(whole, k)[st.visits], getattr(own, k))
