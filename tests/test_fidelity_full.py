"""The whole machine in the compiled replay: level 3 WITH the ring (links, flit buffers,
wormhole paths and the caches, resident memories, ICGM/SCGM with their ports at once)
against the SimPy machine model, differential: the same SimResult to the cycle (every
figure: memory stalls, the ``memory`` section, link utilisation, FIFOs), the same event
log, the same DeadlockError (message and state) for FIFO and ring deadlocks."""
import random

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.fidelity import Compiled, engine_for, evaluate, native_level, unsupported
from mprt.machine import ConfigError, DeadlockError, builtin, load_config
from mprt.machine.config import CacheConfig, LocalMemoryConfig, RingConfig

from machines import logged_memories, random_config, random_costs, random_machine
from test_fidelity import FULL, GOLDEN, NAMES, head
from test_fidelity_memory import check, small_memories

CM = CostModel.default()


@pytest.fixture(scope="module")
def traces():
    return {n: mprt.load_trace(p) for n, p in zip(NAMES, GOLDEN)}


def stalls(res):
    return sum(s["memory_stall"] for s in res.stages.values())


# ---- golden traces ------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_golden_traces_equal_simpy_with_ring_and_memories(traces, name):
    # the 3MPPE and full.toml as written (ring and memories), 1 and 2 PEs; on the small
    # traces also memories small enough to miss, on per-PE ports, behind a slow ring
    t = traces[name]
    cfgs = [c.replace(pes=p) for c in (builtin("3mppe"), load_config(FULL)) for p in (1, 2)]
    total = 0
    for cfg in cfgs:
        assert native_level(cfg) == 3 and cfg.ring is not None
        res = check(t, cfg)
        assert not isinstance(res, DeadlockError), (name, cfg.name)
        assert all(0 < u < 1 for u in res.links["PE0"]) and "icgm" in res.memory
        total += stalls(res)
    # (their memories rarely miss on these small scenes:) memories that miss, on per-PE
    # ports, behind a slow ring
    small = small_memories(builtin("3mppe"), 2, False).replace(ring=RingConfig(2, 2), dis="blocks")
    res = check(t, small)
    assert not isinstance(res, DeadlockError) and stalls(res) > 0


# ---- random configurations ---------------------------------------------------------------

@pytest.mark.parametrize("seed", range(4))
def test_random_ring_and_memory_configurations_equal_simpy(traces, seed):
    # 80 configurations per seed (320): random ring machines with random memories
    # (resident 0 to 2^40 bytes, caches of 1 to 64 sets or 2^40 bytes, 1 to 8 ways, 1 to
    # 64-byte lines or none, latency, bandwidth, shared or per-PE ports); the cost model's
    # packet sizes or random ones; with and without SC making primaries; deadlocks included
    rng = random.Random(500 + seed)
    names = sorted(traces)
    seen = {"deadlock": 0, "ring_wait": 0, "stall": 0, "ic": 0, "sc": 0}
    for i in range(80):
        t = head(traces[rng.choice(names)], rng.choice([5, 20, 40]))
        cfg = random_machine(rng)
        vc = random_costs(t, cfg, rng, 1000 * seed + i)
        res = check(t, cfg, vc)
        if isinstance(res, DeadlockError):
            seen["deadlock"] += 1
            seen["ring_wait"] += any(pe["network"]["waiting"] for pe in res.state["pes"].values())
        else:
            seen["stall"] += stalls(res) > 0
            seen["ic"] += "icgm" in res.memory
            seen["sc"] += "scgm" in res.memory
    assert all(seen.values()), seen       # deadlocks (some on the ring), stalls, both memories


@pytest.mark.parametrize("seed", range(3))
def test_event_logs_equal_simpy_with_ring_and_memories(traces, seed):
    rng = random.Random(600 + seed)
    t = head(traces["gears-g9"], 15)
    check(t, logged_memories(random_config(rng, ring=True), rng), record=True)


def test_ring_deadlock_with_memories(traces):
    # the ring deadlock of model M with one buffer class on balls-g9 (machine README,
    # Deadlock) with memories that stall: the same DeadlockError; three classes complete
    t = traces["balls-g9"]
    m = small_memories(builtin("M"), pes=1)
    one = check(t, m.replace(ring=RingConfig(1, 1)))
    assert isinstance(one, DeadlockError) and one.state["pes"]["PE0"]["network"]["waiting"]
    three = check(t, m.replace(ring=RingConfig(1, 3)))
    assert not isinstance(three, DeadlockError) and stalls(three) > 0


# ---- engines, bounds -----------------------------------------------------------------------

def test_auto_takes_the_compiled_replay_at_levels_2_and_3(traces):
    t = traces["tetra-g4"]
    cfg = builtin("3mppe")
    assert unsupported(cfg) is None and unsupported(load_config(FULL)) is None
    assert [engine_for(cfg, level) for level in (1, 2, 3)] == ["compiled"] * 3
    a = evaluate(t, cfg, level=3)
    b = evaluate(t, cfg, level=3, engine="simpy")
    assert a.engine == "compiled" and b.engine == "simpy" and a.cycles == b.cycles
    assert a.result.memory == b.result.memory and a.result.links == b.result.links


class _FarData:
    """Memory data whose key 0 reads lines 0 and 2^27 (so a large cache needs 2^27 + 1 sets)."""

    def __init__(self, trace):
        self.keys = self.replay_keys = np.where(trace.visits["stage"] == mprt.trace.IC, 0, -1).astype(np.int32)

    def get(self, tag, resident, line):
        d = {"line": line, "items": np.array([2], np.int32), "resident": np.array([0], np.int32),
             "line_start": np.array([0, 2], np.int64), "lines": np.array([0, 1 << 27], np.int64)}
        return d, type("Resident", (), {"used": 0})()


def test_caches_of_more_than_2_28_entries_are_refused_before_the_run(traces):
    t = head(traces["tetra-g4"], 4)
    big = LocalMemoryConfig(0, CacheConfig(1 << 40, 32, 1))
    cfg = builtin("3mppe").replace(pes=2, ic_memory=big, sc_memory=None, scgm=None)
    c = Compiled(t, CM.visit_costs(t, cfg.processors()), memory=_FarData(t))
    with pytest.raises(ConfigError, match=r"^cache_size\[0\]: the IC caches would hold 2 PEs x 134217729 entries "
                                          r"per PE \(sets x ways the data can fill\), more than 2\^28 in all$"):
        c.result(cfg)
    # the same 2^40-byte cache on the trace's own data is small (the lines it can fill) and runs
    assert check(t, cfg).cycles > 0
