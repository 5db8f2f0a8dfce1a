"""The compiled replay's ring (level 2) against the SimPy machine model: the same
SimResult to the cycle (link utilisation and FIFO figures included), the same event
log, the same DeadlockError (message and state) for FIFO and ring deadlocks."""
import random

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.fidelity import Compiled, at_level, engine_for, evaluate, replay, unsupported
from mprt.machine import DeadlockError, builtin, load_config, simulate
from mprt.machine.config import RingConfig

from machines import random_config, random_costs
from test_fidelity import FULL, GOLDEN, NAMES, fed, head, outcome, same
from test_fidelity_memory import check
from test_machine import PARENT, PARENT_COSTS, costs

CM = CostModel.default()
RING = RingConfig(flit_time=1, buffer_classes=3)


@pytest.fixture(scope="module")
def traces():
    return {n: mprt.load_trace(p) for n, p in zip(NAMES, GOLDEN)}


# ---- a hand-worked run --------------------------------------------------------------

def test_hand_worked_ring_run():
    # PARENT (test_machine) on model M's stages joined by the ring: 1 cycle per flit,
    # 3 flits per visit's packet, 2 per child, so a packet over h links takes h + 2
    # cycles (h + 1 for a child):
    # OS 0-10; OS->IC 10-13, IC 13-33; IC->SC 33-36, SC 36-66; children to OS: ray 1
    # 66-68 (OS 68-73), ray 2 injected when ray 1's tail has left, 68-70, into OS's
    # FIFO; 73: OS->SC (2 links) 73-77 (SC 77-81), OS takes ray 2 73-79; OS->IC 79-82,
    # IC 82-90; IC->OS (2 links) 90-94, OS 94-97.
    cfg = builtin("M").replace(ring=RING)
    c = costs([10, 20, 30, 5, 4, 6, 8, 3])
    c.flits = np.full(8, 3, np.int32)
    kw = dict(costs=c, packet_flits=lambda src, dst, kind: 2, record=True)
    a, b = simulate(PARENT, cfg, **kw), replay(PARENT, cfg, **kw)
    starts = [(t, name.split(".")[1], j) for t, what, name, k, j in b.log if what == "start"]
    assert starts == [(0, "OS", 0), (13, "IC", 1), (36, "SC", 2), (68, "OS", 3), (73, "OS", 5), (77, "SC", 4),
                      (82, "IC", 6), (94, "OS", 7)]
    assert b.cycles == 97
    # links OS->IC: 3 + 3 (the first link of OS->SC) + 3; IC->SC: 3 + 3 + 3; SC->OS: 2 + 2 + 3
    assert b.links == {"PE0": [9 / 97, 9 / 97, 7 / 97]}
    # OS's receive slots, reserved from a header's claim to its packet's delivery or use:
    # ray 1 67-68, ray 2 69-73 (filled at 70), the reflection's last packet 92-94
    assert b.fifos["PE0.OS.receive"] == {"capacity": None, "mean": 7 / 97, "max": 1, "packets": 1}
    assert b.fifos["PE0.OS.send"]["packets"] == 3
    assert same(a, b) and a.log == b.log


def test_one_flit_packets_and_slow_links():
    # packets of 0 or 1 flit are a header alone (no body); flit_time scales every transfer
    c = costs([10, 20, 30, 5, 4, 6, 8, 3])
    for flits, ft in ((0, 1), (1, 3), (5, 2)):
        c.flits = np.full(8, flits, np.int32)
        cfg = builtin("M").replace(ring=RingConfig(flit_time=ft, buffer_classes=2))
        assert check(PARENT, cfg, c).cycles > PARENT_COSTS.process.sum() - 30        # the ring only adds time


# ---- golden traces ----------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_golden_traces_equal_simpy_at_level_2(traces, name):
    t = traces[name]
    three = at_level(builtin("3mppe"), 2)
    two_pe = three.replace(pes=2, dis="interleaved", window=8)
    for cfg in (three, at_level(load_config(FULL), 2), two_pe, fed(name)[0].replace(ring=RING)):
        assert cfg.ring is not None and cfg.ic_memory is None
        vc = CM.visit_costs(t, cfg.processors())
        res = check(t, cfg, vc)
        assert not isinstance(res, DeadlockError) and all(0 < u < 1 for u in res.links["PE0"]), (name, cfg.name)


def test_ring_deadlock_without_the_structured_pool(traces):
    # README, Deadlock: on balls-g9 with unbounded FIFOs one buffer class deadlocks on the
    # ring, three complete; both engines report the same machine
    t = traces["balls-g9"]
    vc = CM.visit_costs(t, builtin("M").processors())
    one = check(t, builtin("M").replace(ring=RingConfig(1, 1)), vc)
    assert isinstance(one, DeadlockError)
    assert "headers can wait on each other" in str(one) and one.state["pes"]["PE0"]["network"]["waiting"]
    assert check(t, builtin("M").replace(ring=RingConfig(1, 3)), vc).cycles > 0


def test_many_pes_equal_simpy(traces):
    # more than 8 processors: the processors' events in a heap, and many packets' events in
    # the ring's list at once
    t = head(traces["rings-g9"], 300)
    for pes, dis, window, ring in ((16, "dynamic", 4, RingConfig(1, 3)), (40, "blocks", 8, RingConfig(2, 2))):
        cfg = at_level(builtin("3mppe"), 2).replace(pes=pes, dis=dis, window=window, ring=ring)
        assert len(check(t, cfg).links) == pes


# ---- random configurations ------------------------------------------------------------------

@pytest.mark.parametrize("seed", [21, 22, 23, 24])
def test_random_ring_configurations_equal_simpy(traces, seed):
    # 100 configurations per seed: 2 or 3 stages in any mapping, processors, replicas and
    # feeds, finite FIFOs, PEs, DIS policies, windows, flit times, 1 to K buffer classes;
    # the cost model's packet sizes or random ones of 0 to 6 flits; with and without SC
    # making the primary rays; FIFO and ring deadlocks included
    rng = random.Random(seed)
    names = sorted(traces)
    deadlocks = ring_waits = 0
    for i in range(100):
        t = head(traces[rng.choice(names)], rng.choice([5, 20, 60]))
        cfg = random_config(rng, ring=True)
        res = check(t, cfg, random_costs(t, cfg, rng, 1000 * seed + i))
        if isinstance(res, DeadlockError):
            deadlocks += 1
            ring_waits += any(pe["network"]["waiting"] for pe in res.state["pes"].values())
    assert deadlocks > 0 and ring_waits > 0      # the comparison covered deadlocks, some with packets on the ring


@pytest.mark.parametrize("seed", range(6))
def test_ring_event_logs_equal_simpy(traces, seed):
    rng = random.Random(200 + seed)
    t = head(traces["gears-g9"], 15)
    check(t, random_config(rng, ring=True), record=True)


# ---- engines, errors --------------------------------------------------------------------------

def test_level_2_runs_compiled(traces):
    full = builtin("3mppe")
    assert unsupported(at_level(full, 2)) is None and unsupported(full) is None
    assert engine_for(full, 2) == "compiled" and engine_for(full, 3) == "compiled"
    t = head(traces["mount-g9"], 40)
    e = evaluate(t, full, 2)
    assert e.engine == "compiled" and e.cycles == evaluate(t, full, 2, engine="simpy").cycles


def test_one_load_runs_ring_and_ideal_configurations(traces):
    t = head(traces["tree-g9"], 30)
    vc = CM.visit_costs(t, builtin("M").processors())
    c = Compiled(t, vc)
    cfgs = [builtin("M").replace(ring=r, window=w) for r in (None, RingConfig(1, 3), RingConfig(2, 1)) for w in (2, 64)]

    def cycles(fn):
        r = outcome(fn)
        return "deadlock" if isinstance(r, DeadlockError) else getattr(r, "cycles", r)
    assert [cycles(lambda: c.cycles(cfg)) for cfg in cfgs] == [cycles(lambda: simulate(t, cfg, costs=vc))
                                                               for cfg in cfgs]


def test_bad_packet_sizes_are_refused(traces):
    t = head(traces["balls-g4"], 5)
    vc = CM.visit_costs(t, builtin("M").processors())
    vc.flits = vc.flits.astype(np.int64)
    vc.flits[3] = -1
    with pytest.raises(ValueError, match=r"flits\[3\]: visit 3's packet must be 0..65535 flits, not -1"):
        replay(t, builtin("M").replace(ring=RING), costs=vc)
    nf = costs([1] * len(t.visits))
    del nf.flits
    with pytest.raises(ValueError, match="the ring needs each visit's packet size"):
        replay(t, builtin("M").replace(ring=RING), costs=nf)
