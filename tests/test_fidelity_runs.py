"""Sampled replay by runs of trees (``runs:K:SEED``) scaled by the whole frame's level 0,
and the compiled replay's busy record that times them."""
import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.errors import InvalidArgument
from mprt.fidelity import Analytical, Compiled, Sampling, sample_trace
from mprt.fidelity import sampled as S
from mprt.machine import builtin
from mprt.trace import PRIMARY

CM = CostModel.default()


@pytest.fixture(scope="module")
def frame():
    """A whole frame of 96 x 96 samples (9216 trees)."""
    _, t = mprt.Scene.spd("balls", 1).grid(6).trace(96, 96)
    return t


def _sliced(vc, keep):
    from types import SimpleNamespace

    return SimpleNamespace(process=vc.process[keep], receive=vc.receive[keep], send=vc.send[keep],
                           inject_process=vc.inject_process, inject_send=vc.inject_send)


def test_runs_specification():
    assert Sampling.parse("runs:16:3") == Sampling("runs", 16, 3, S.RUN_TREES)
    assert Sampling.parse("runs:16:3:200") == Sampling("runs", 16, 3, 200)
    assert str(Sampling.parse("runs:16:3")) == "runs:16:3"
    assert str(Sampling.parse("runs:16:3:200")) == "runs:16:3:200"
    for bad in ("runs:16", "runs:0:1", "runs:4:1:0", "runs:4:x"):
        with pytest.raises(InvalidArgument, match="runs:K:SEED"):
            Sampling.parse(bad)


@pytest.mark.parametrize("k", [1, 4, 16, 1000])
def test_runs_hold_at_most_a_kth_of_the_visits(k):
    v = np.random.default_rng(k).integers(1, 60, 20000)
    a, b = S.choose_runs(Sampling("runs", k, 5, 300), v)
    cum = np.concatenate([[0], np.cumsum(v)])
    assert len(a) >= 2 and np.all(b > a) and np.all(a[1:] >= b[:-1])      # disjoint, in order, not empty
    work = (cum[b] - cum[a]).sum() / cum[-1]
    # each run holds at most a k-th of its stretch (at least one tree): so at most 1/k overall,
    # up to one tree per run
    assert work <= 1 / k + len(a) * v.max() / cum[-1]
    if k == 1:
        assert work == 1.0
    else:
        assert work > 0.5 / k


def test_runs_of_every_tree_give_the_replay_itself(frame):
    cfg = builtin("M")
    vc = CM.visit_costs(frame, cfg.processors())
    st = sample_trace(frame, "runs:1:0:500")
    assert st.fraction == 1 and st.visits.all()
    comp = Compiled(st.trace, _sliced(vc, st.visits))
    cycles = comp.cycles(cfg)
    sc = S.estimate_runs(st, cycles, Analytical(st.trace, _sliced(vc, st.visits)), Analytical(frame, vc), cfg,
                         comp.admissions())
    assert sc.cycles == Compiled(frame, vc).cycles(cfg) and sc.interval == (sc.cycles, sc.cycles)


def test_runs_keep_the_frames_order_and_trees(frame):
    st = sample_trace(frame, "runs:4:2:300")
    kind = np.asarray(frame.rays["kind"])
    tree = np.cumsum(kind == PRIMARY) - 1
    kept = np.unique(tree[np.asarray(frame.visits["ray"])[st.visits]])
    assert np.array_equal(np.diff(st.run_of) >= 0, np.ones(len(st.run_of) - 1, bool))   # runs in frame order
    ends = [(a, b) for a, b in st.trace.meta["sampled"]["runs"]]
    assert np.array_equal(kept, np.concatenate([np.arange(a, b) for a, b in ends]))


def test_runs_need_the_frame_and_the_admissions(frame):
    cfg = builtin("M")
    st = sample_trace(frame, "runs:4:1:300")
    with pytest.raises(InvalidArgument, match="frame"):
        S.estimate(st, None, None, cfg)


def test_runs_estimate_is_close_and_covered(frame):
    """On a small frame (about 30 runs of 300 trees at 1/4) the estimate is within a few
    percent of the whole replay and the 95% interval covers it for most seeds."""
    cfg = builtin("M")
    vc = CM.visit_costs(frame, cfg.processors())
    truth = Compiled(frame, vc).cycles(cfg)
    whole = Analytical(frame, vc)
    errs, covered = [], []
    for seed in range(5):
        st = sample_trace(frame, f"runs:4:{seed}:100")
        svc = _sliced(vc, st.visits)
        comp = Compiled(st.trace, svc)
        cycles = comp.cycles(cfg)
        sc = S.estimate_runs(st, cycles, Analytical(st.trace, svc), whole, cfg, comp.admissions())
        errs.append(sc.cycles / truth - 1)
        covered.append(sc.interval[0] <= truth <= sc.interval[1])
        assert st.visits.mean() <= 0.3
    assert max(abs(e) for e in errs) < 0.05
    assert sum(covered) >= 4


def test_busy_record_matches_the_event_log():
    """Each stage's busy cycles at each admission, against the same run's event log
    (busy = the visits' cycles run by then, a visit under way counted up to then)."""
    tr = mprt.load_trace("tests/data/golden/balls-g4.npz")
    cfg = builtin("3mppe").replace(ring=None, ic_memory=None, sc_memory=None, icgm=None, scgm=None, pes=2)
    vc = CM.visit_costs(tr, cfg.processors())
    comp = Compiled(tr, vc)
    cycles, admitted, busy = comp.probe(cfg)
    res = comp.result(cfg, record=True)
    assert res.cycles == cycles
    starts = {}
    spans = []
    names = [s.name for s in cfg.stages]
    for t, what, stage, replica, visit in res.log:
        key = (stage, replica)
        if what == "start":
            starts[key] = t
        else:
            spans.append((names.index(stage.split(".")[-1]) if "." in stage else names.index(stage), starts.pop(key), t))
    spans = np.array(spans)
    for tree in np.linspace(0, len(admitted) - 1, 25).astype(int):
        at = admitted[tree]
        for s in range(len(names)):
            sp = spans[spans[:, 0] == s]
            expect = np.clip(np.minimum(sp[:, 2], at) - sp[:, 1], 0, None).sum()
            assert busy[tree, s] == expect, (tree, s)
