"""The compiled replay against the SimPy machine model (differential: the same
SimResult to the cycle, the same event log, the same errors and deadlocks),
level 0's exact and bounding cases, and the levels' engines."""
import glob
import os
import random
from types import SimpleNamespace

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.fidelity import Analytical, Compiled, at_level, engine_for, evaluate, native_level, replay, unsupported
from mprt.machine import ConfigError, DeadlockError, builtin, load_config, make_stage, simulate
from mprt.machine.config import FEEDS
from mprt.trace import TraceError

from machines import random_config, random_costs
from test_machine import PARENT, PARENT_COSTS, costs, hand_trace
from mprt.trace import IC, LEFT, OS, PRIMARY, RETURN, TO_IC

HERE = os.path.dirname(os.path.abspath(__file__))
GOLDEN = sorted(glob.glob(os.path.join(HERE, "data", "golden", "*.npz")))
NAMES = [os.path.basename(p)[:-4] for p in GOLDEN]
FULL = os.path.join(HERE, "data", "machine", "full.toml")
CM = CostModel.default()


@pytest.fixture(scope="module")
def traces():
    return {n: mprt.load_trace(p) for n, p in zip(NAMES, GOLDEN)}


def same(a, b):
    """Two SimResults equal in every figure (the run's wall time aside)."""
    da, db = a.to_dict(), b.to_dict()
    da.pop("wall_seconds")
    db.pop("wall_seconds")
    return da == db


def head(trace, ntrees):
    """The first ntrees primary rays' trees of a trace (a small trace of the same kind)."""
    rays, vis = trace.rays, trace.visits
    prim = np.flatnonzero(rays["kind"] == PRIMARY)
    if ntrees >= len(prim):
        return trace
    r1 = int(prim[ntrees])
    v1 = int(np.searchsorted(vis["ray"], r1))
    arrays = {k: getattr(trace, k) for k in ("voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material",
                                             "samples")}
    arrays["rays"], arrays["visits"] = rays[:r1].copy(), vis[:v1].copy()
    return mprt.Trace.from_arrays(dict(trace.meta), arrays)


def level1(cfg):
    return cfg.replace(ring=None, ic_memory=None, sc_memory=None, icgm=None, scgm=None)


def with_ic(cfg, **changes):
    st = list(cfg.stages)
    i = cfg.stage_of("IC")
    st[i] = st[i].__class__(**{**st[i].__dict__, **changes})
    return cfg.replace(stages=tuple(st))


def fed(name):
    """Per-copy feeds on a golden trace: the 3MPPE with IC x2 and model M with IC x3 and
    receive FIFOs of 2 and OS's send FIFO of 1 (so they fill; only IC's are finite, so it
    cannot deadlock), feed by the trace's name."""
    n = NAMES.index(name) % 2
    small = with_ic(builtin("M"), replicas=3, receive_fifo=2, feed=FEEDS[2 - n])
    st = list(small.stages)
    st[0] = make_stage(("OS",), send_fifo=1)
    return with_ic(level1(builtin("3mppe")), replicas=2, feed=FEEDS[1 + n]), small.replace(stages=tuple(st))


# ---- differential: golden traces ---------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_golden_traces_equal_simpy(traces, name):
    t = traces[name]
    for cfg in (builtin("S"), builtin("M"), level1(builtin("3mppe")), level1(load_config(FULL))) + fed(name):
        vc = CM.visit_costs(t, cfg.processors())
        a, b = simulate(t, cfg, costs=vc), replay(t, cfg, costs=vc)
        assert a.cycles == b.cycles, cfg.name
        assert same(a, b), cfg.name


# ---- differential: random configurations -------------------------------------------

def outcome(fn):
    try:
        return fn()
    except DeadlockError as e:
        return e


@pytest.mark.parametrize("seed,feeds", [(0, False), (1, False), (2, False), (11, True), (12, True), (13, True)])
def test_random_configurations_equal_simpy(traces, seed, feeds):
    # 100 configurations per seed: mappings, processors, replicas (with feeds: each stage's
    # feed shared, round-robin or shortest-queue), finite FIFOs, PEs, DIS policies, windows,
    # with and without SC making the primary rays; deadlocks included
    rng = random.Random(seed)
    names = sorted(traces)
    deadlocks = 0
    for i in range(100):
        t = head(traces[rng.choice(names)], rng.choice([5, 20, 60]))
        cfg = random_config(rng, feeds)
        vc = random_costs(t, cfg, rng)
        a = outcome(lambda: simulate(t, cfg, costs=vc))
        b = outcome(lambda: replay(t, cfg, costs=vc))
        if isinstance(a, DeadlockError) or isinstance(b, DeadlockError):
            deadlocks += 1
            assert type(a) is type(b), (i, cfg)
            assert str(a) == str(b) and a.state == b.state, (i, cfg)
            # the deadlock bound (per feed, config.stage_capacity) never rules out one that happens
            assert "the FIFOs can fill" in str(a), (i, cfg)
        else:
            assert a.cycles == b.cycles, (i, cfg)
            assert same(a, b), (i, cfg)
    assert deadlocks > 0      # the comparison covered deadlocks too


@pytest.mark.parametrize("seed", range(8))
def test_event_logs_equal_simpy(traces, seed):
    rng = random.Random(100 + seed)
    t = head(traces["rings-g9"], 15)
    cfg = random_config(rng, seed >= 4)
    vc = CM.visit_costs(t, cfg.processors())
    a = outcome(lambda: simulate(t, cfg, costs=vc, record=True))
    b = outcome(lambda: replay(t, cfg, costs=vc, record=True))
    if not isinstance(a, DeadlockError):
        assert a.log == b.log


def test_hand_built_trace_log_as_worked_out_in_the_machine_tests():
    # test_machine.test_parent_and_children_model_m works this log out by hand
    res = replay(PARENT, "M", costs=PARENT_COSTS, record=True)
    starts = [(t, name.split(".")[1], j) for t, what, name, k, j in res.log if what == "start"]
    assert starts == [(0, "OS", 0), (10, "IC", 1), (30, "SC", 2), (60, "OS", 3), (65, "SC", 4), (65, "OS", 5),
                      (71, "IC", 6), (79, "OS", 7)]
    assert res.cycles == 82


def test_deadlock_reported_as_simpy_reports_it():
    # test_machine.test_finite_fifos_deadlock_is_reported_with_state's machine: 8 rays fill
    # OS's and IC's FIFOs at window 8, not at 7
    tr = hand_trace([(-1, PRIMARY)] * 8,
                    [v for r in range(8) for v in ((r, OS, TO_IC, 0), (r, IC, RETURN, 0), (r, OS, LEFT, 0))])
    cfg = builtin("M").replace(stages=(make_stage(("OS",), send_fifo=1, receive_fifo=3),
                                       make_stage(("IC",), send_fifo=1, receive_fifo=1), make_stage(("SC",))),
                               window=8)
    c = costs([1, 1, 1] * 8)
    with pytest.raises(DeadlockError) as a:
        simulate(tr, cfg, costs=c)
    with pytest.raises(DeadlockError) as b:
        replay(tr, cfg, costs=c)
    assert str(a.value) == str(b.value) and a.value.state == b.value.state
    assert "a window below 8 rules this out" in str(b.value)
    assert replay(tr, cfg.replace(window=7), costs=c).cycles == 16


# ---- errors ----------------------------------------------------------------------------

def test_malformed_traces_fail_as_in_simpy():
    good = hand_trace([(-1, PRIMARY), (-1, PRIMARY)], [(0, OS, LEFT, 0), (1, OS, LEFT, 0)])
    c = costs([3, 4])
    swapped = hand_trace([(-1, PRIMARY), (-1, PRIMARY)], [(1, OS, LEFT, 0), (0, OS, LEFT, 0)])
    for bad in (swapped,):
        with pytest.raises(TraceError) as a:
            simulate(bad, "M", costs=c)
        with pytest.raises(TraceError) as b:
            replay(bad, "M", costs=c)
        assert str(a.value) == str(b.value)
    with pytest.raises(ValueError, match="at least 1 cycle"):
        replay(good, "M", costs=costs([3, 0]))
    with pytest.raises(ValueError, match=r"costs.process has shape \(1,\)"):
        replay(good, "M", costs=costs([3]))
    # (more PEs than primary rays was refused here: now the PEs that get none idle, test below);
    # a trace without primary rays is refused by both, with the same message
    empty = head(good, 0)
    with pytest.raises(ConfigError) as a:
        simulate(empty, "M")
    with pytest.raises(ConfigError) as b:
        replay(empty, "M")
    assert str(a.value) == str(b.value) == "the trace has no primary rays: nothing to replay"


def test_pes_without_a_primary_ray_idle_as_in_simpy():
    # more PEs than primary rays, every DIS, the ideal network, the ring and the memories, with
    # an event log: the same result to the figure, the spare PEs idle
    from test_fidelity_memory import check

    t = mprt.load_trace(GOLDEN[0])
    for trees in (1, 2, 3):
        small = head(t, trees)
        for name in ("M", "3mppe"):
            for dis in ("blocks", "interleaved", "dynamic"):
                cfg = builtin(name).replace(pes=trees + 2, dis=dis)
                res = check(small, cfg, record=True)
                assert [p["primaries"] for p in res.pes].count(0) >= 2
                assert all(p["rays"] == 0 and p["end"] == 0 for p in res.pes if p["primaries"] == 0)


def test_the_compiled_engine_accepts_every_machine_the_simpy_model_models():
    full = load_config(FULL)
    for cfg in [builtin(n) for n in ("M", "S", "3mppe")] + [full]:
        assert unsupported(cfg) is None, cfg.name
        for level in (1, 2, 3):
            assert engine_for(cfg, level) == "compiled"


def test_one_load_runs_many_configurations(traces):
    t = traces["tetra-g9"]
    vc = CM.visit_costs(t, builtin("M").processors())
    c = Compiled(t, vc)
    cfgs = [builtin("M").replace(window=w, pes=p) for w in (1, 8, 256) for p in (1, 2)]
    assert [c.cycles(cfg) for cfg in cfgs] == [simulate(t, cfg, costs=vc).cycles for cfg in cfgs]


# ---- level 0 ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_level0_is_exact_for_model_s_and_bounds_the_others(traces, name):
    t = traces[name]
    for cfg in (builtin("S"), builtin("M"), builtin("M").replace(window=4, pes=2, dis="blocks"),
                level1(builtin("3mppe"))):
        vc = CM.visit_costs(t, cfg.processors())
        a = Analytical(t, vc)
        r1 = replay(t, cfg, costs=vc)
        est = a.estimate(cfg)
        # no stage can finish before its load, no tree before its critical path
        assert est.lower_bound <= r1.cycles, cfg.name
        r0 = a.result(cfg)
        assert r0.cycles == est.cycles and r0.level == 0
        for s in ("OS", "IC", "SC"):     # the work itself is the trace's, whatever the level
            assert r0.stages[s]["processing"] == r1.stages[s]["processing"]
            assert r0.stages[s]["communication"] == r1.stages[s]["communication"]
        if cfg.name == "S":              # one processor never waits: its time is its work
            assert est.cycles == r1.cycles == est.lower_bound


def test_level0_critical_path_of_a_hand_built_tree():
    # PARENT: primary 10 + 20 + 30, then its children: shadow 5 + 4, reflection 6 + 8 + 3;
    # the critical path is 60 + 17 = 77, the work 86 (model S's time)
    a = Analytical(PARENT, PARENT_COSTS)
    assert a.critical.tolist() == [77]
    assert a.estimate(builtin("S")).cycles == 86
    assert a.estimate(builtin("M")).lower_bound == 77


# ---- levels and engines ---------------------------------------------------------------------

def test_levels_take_out_ring_and_memories():
    full = builtin("3mppe")
    assert native_level(full) == 3 and native_level(builtin("M")) == 1
    assert at_level(full, 1).ring is None and at_level(full, 1).ic_memory is None
    assert at_level(full, 2).ring == full.ring and at_level(full, 2).ic_memory is None
    assert at_level(full, 3) == full
    assert [engine_for(full, lv) for lv in (1, 2, 3)] == ["compiled"] * 3
    assert engine_for(full, 3, "simpy") == "simpy" and engine_for(full, 0) == "analytical"
    assert engine_for(builtin("M"), 3) == "compiled"        # nothing above level 1 to model
    with pytest.raises(ConfigError, match="level 0 is analytical"):
        engine_for(full, 0, "simpy")


def test_evaluate_levels_on_both_engines_agree(traces):
    t = traces["balls-g9"]
    full = builtin("3mppe")
    one = evaluate(t, full, 1)
    assert one.engine == "compiled"
    assert one.cycles == evaluate(t, full, 1, engine="simpy").cycles == simulate(t, at_level(full, 1)).cycles
    three = evaluate(t, full)
    assert three.level == 3 and three.engine == "compiled" and three.cycles == simulate(t, full).cycles
    # M has no ring nor memories: levels 1 to 3 are the same machine
    assert len({evaluate(t, "M", lv).cycles for lv in (1, 2, 3)}) == 1


def test_zero_cost_making_sends_primaries_to_os(traces):
    # with no cost for making a primary ray, the DIS hands it to OS directly (both engines)
    t = head(traces["gears-g4"], 30)
    vc = CM.visit_costs(t, builtin("M").processors())
    free = SimpleNamespace(process=vc.process, receive=vc.receive, send=vc.send, flits=vc.flits)
    a, b = simulate(t, "M", costs=free), replay(t, "M", costs=free)
    assert same(a, b) and b.stages["SC"]["primaries_made"] == 0


def test_long_visits_take_the_wide_records(traces):
    # visits of 2^24 cycles or more do not fit the replay's 8-byte records; the 16-byte ones
    # must give the same machine
    t = head(traces["balls-g9"], 20)
    vc = CM.visit_costs(t, builtin("M").processors())
    long = SimpleNamespace(process=vc.process * 100_000, receive=vc.receive, send=vc.send, flits=vc.flits,
                           inject_process=vc.inject_process, inject_send=vc.inject_send)
    assert long.process.max() >= 1 << 24
    assert same(simulate(t, "M", costs=long), replay(t, "M", costs=long))
