"""The compiled replay's work bound (``mprt_replay_work_bound``, ``Compiled.work_bound``): each
stage's work over its processors, PE by PE as the DIS deals the trees, with nothing run.  It is
what the explorer's polish rules designs out with, so it must never exceed a run's cycles at any
level; here it is worked out again in numpy from the visits' costs, checked against runs at
levels 1 to 3 on the golden traces and random machines, and found exact where nothing waits."""
import random

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.fidelity import Compiled, at_level
from mprt.fidelity.compiled import _line
from mprt.machine import ConfigError, DeadlockError, builtin, load_config
from mprt.machine.config import SUBTASKS, LocalMemoryConfig
from mprt.trace import PRIMARY

from machines import random_costs, random_machine
from test_fidelity import FULL, GOLDEN, NAMES, head

CM = CostModel.default()


@pytest.fixture(scope="module")
def traces():
    return {n: mprt.load_trace(p) for n, p in zip(NAMES, GOLDEN)}


def least_misses(lines, start, sets: int, ways: int) -> np.ndarray:
    """Per key, the fewest misses a look-up takes in a cache of ``sets`` x ``ways`` whatever it
    held: in each set, its distinct lines there beyond the ways."""
    out = np.zeros(len(start) - 1, np.int64)
    for k in range(len(out)):
        _, per_set = np.unique(np.unique(lines[start[k]:start[k + 1]]) % sets, return_counts=True)
        out[k] = int(np.maximum(per_set - ways, 0).sum())
    return out


def stalls(t, cfg, memory, caches: bool = True) -> np.ndarray:
    """Per visit, the least stall cycles level 3 gives it, a transfer and the latency each read
    (memdata's lines): a memory modelled without a cache reads every line of the visit's key,
    one with a cache at least ``least_misses`` (``caches`` false: those add none)."""
    out = np.zeros(len(t.visits), np.int64)
    keys = np.asarray(memory.replay_keys, np.int64)
    for tag, mc, gm in (("ic", cfg.ic_memory, cfg.icgm), ("sc", cfg.sc_memory, cfg.scgm)):
        if mc is None or (mc.cache is not None and not caches):
            continue
        data, _ = memory.get(tag, mc.resident, _line(mc))
        start = np.asarray(data["line_start"], np.int64)
        reads = start[1:] - start[:-1]
        if mc.cache is not None:
            c = mc.cache
            reads = least_misses(np.asarray(data["lines"], np.int64), start, c.size // (c.line * c.ways), c.ways)
        mine = keys >= 0 if tag == "ic" else keys <= -2
        k = np.where(keys >= 0, keys, -2 - keys)[mine]
        out[mine] += reads[k] * (-(-_line(mc) // gm.bandwidth) + gm.latency)
    return out


def ring_times(t, cfg, vc) -> np.ndarray:
    """Per visit, the least flit times the packet that starts it takes on the ring (none on
    the ideal network): its header's hops from the stage before to the visit's, then its
    other flits; a ray SC made (a primary too, where SC makes them) comes from SC's stage."""
    out = np.zeros(len(t.visits), np.int64)
    if cfg.ring is None:
        return out
    K, ft = len(cfg.stages), cfg.ring.flit_time
    node = np.array([cfg.stage_of(s) for s in SUBTASKS])[np.asarray(t.visits["stage"], np.int64)]
    ray = np.asarray(t.visits["ray"], np.int64)
    kind = np.asarray(t.rays["kind"], np.int64)
    fl = np.asarray(vc.flits, np.int64)
    kids = np.array([CM.packet_flits("SC", "OS", k) for k in range(4)], np.int64)
    first = np.r_[True, ray[1:] != ray[:-1]]
    src = np.where(first, cfg.stage_of("SC"), np.r_[0, node[:-1]])
    size = np.where(first, np.where(kind[ray] == PRIMARY, int(getattr(vc, "inject_flits", 0)), kids[kind[ray]]),
                    np.r_[0, fl[:-1]])
    lat = ((node - src) % K + np.maximum(size - 1, 0)) * ft
    made = int(vc.inject_process) + int(vc.inject_send) > 0
    return np.where((src == node) | (first & (kind[ray] == PRIMARY) & (not made)), 0, lat)


def critical_paths(t, dur) -> np.ndarray:
    """Per tree, the longest chain of visits' cycles: a ray starts when its parent's visits
    (the last made it) are done, and lasts its own visits' cycles."""
    rays = t.rays
    per_ray = np.zeros(len(rays), np.int64)
    np.add.at(per_ray, np.asarray(t.visits["ray"], np.int64), dur)
    fin = np.zeros(len(rays), np.int64)
    out = []
    for i, (kind, parent) in enumerate(zip(np.asarray(rays["kind"]).tolist(), np.asarray(rays["parent"]).tolist())):
        if kind == PRIMARY:
            out.append(0)
            fin[i] = per_ray[i]
        else:
            fin[i] = fin[parent] + per_ray[i]
        out[-1] = max(out[-1], int(fin[i]))
    return np.array(out, np.int64)


def stage_work(t, cfg, vc, memory=None, window: bool = True, ring: bool = True, caches: bool = True) -> int:
    """The bound from its definition, in numpy: per PE (its trees as the DIS deals them; the
    dynamic DIS: all trees over all PEs) and stage, the visits' process, receive and send
    cycles of the stage's subtasks (with ``memory``, a MemoryData, at level 3 the reads
    ``stalls`` gives), and on the stage running SC the making of the PE's primary rays, over
    the stage's processors, rounded up; and per PE its trees' lifetimes (the making of the
    primary and the critical path, with its packets' least times on the ring and those reads,
    or its work on a stage over the stage's replicas, whichever is longer) over the window (the dynamic DIS: over window x PEs); the largest of them (``window``
    false: the stages' terms alone; ``ring`` false: the chains without the ring's times;
    ``caches`` false: no reads of a memory with a cache)."""
    rays, vis = t.rays, t.visits
    prim = np.flatnonzero(np.asarray(rays["kind"]) == PRIMARY)
    n = len(prim)
    tree = (np.searchsorted(prim, np.arange(len(rays)), "right") - 1)[np.asarray(vis["ray"], np.int64)]
    dur = (np.asarray(vc.process, np.int64) + np.asarray(vc.receive, np.int64) + np.asarray(vc.send, np.int64))
    if memory is not None:
        dur = dur + stalls(t, cfg, memory, caches)
    cp = critical_paths(t, dur + ring_times(t, cfg, vc)) if ring else critical_paths(t, dur)
    work = np.zeros((n, 3), np.int64)
    np.add.at(work, (tree, np.asarray(vis["stage"], np.int64)), dur)
    gen = int(vc.inject_process) + int(vc.inject_send)
    P = cfg.pes
    if cfg.dis == "blocks":
        groups, share = [np.arange(p * n // P, (p + 1) * n // P) for p in range(P)], 1
    elif cfg.dis == "interleaved":
        groups, share = [np.arange(p, n, P) for p in range(P)], 1
    else:
        groups, share = [np.arange(n)], P
    # a tree lives at least its chain, and its work on each stage over the stage's replicas
    lives = cp + gen
    for st in cfg.stages:
        tw = sum(work[:, SUBTASKS.index(s)] for s in st.subtasks) + (gen if "SC" in st.subtasks else 0)
        lives = np.maximum(lives, -(-tw // st.replicas))
    best = 0
    for g in groups:
        if window:
            best = max(best, -(-int(lives[g].sum()) // (cfg.window * share)))
        for st in cfg.stages:
            w = sum(int(work[g, SUBTASKS.index(s)].sum()) for s in st.subtasks)
            w += gen * len(g) if "SC" in st.subtasks else 0
            best = max(best, -(-w // (st.replicas * share)))
    return best


def cycles(c, cfg):
    try:
        return c.result(cfg).cycles
    except DeadlockError:
        return None


@pytest.mark.parametrize("seed", range(3))
def test_the_bound_is_the_stages_work_and_never_above_a_run(traces, seed):
    # random ring machines with random memories (stages in any mapping, replicas, feeds, PEs,
    # the three DIS policies, with and without SC making primaries), each at levels 1, 2, 3
    rng = random.Random(900 + seed)
    names = sorted(traces)
    seen = {"runs": 0, "tight": 0, "below": 0, "uncached": 0, "cached": 0, "window": 0, "ring": 0, "dis": set()}
    for i in range(40):
        t = head(traces[rng.choice(names)], rng.choice([5, 20, 60]))
        cfg = random_machine(rng)
        vc = random_costs(t, cfg, rng, 1000 * seed + i)
        c = Compiled(t, vc)
        for lv in (1, 2, 3):
            cl = at_level(cfg, lv)
            want = stage_work(t, cl, vc, c.memory if lv == 3 else None)
            assert c.work_bound(cl) == want, (cl, lv)
            got = cycles(c, cl)
            if got is None:
                continue
            assert want <= got, (cl, lv)
            seen["runs"] += 1
            seen["tight"] += want == got
            seen["below"] += want < got
            seen["dis"].add(cl.dis)
            seen["uncached"] += lv == 3 and want > stage_work(t, cl, vc)
            seen["cached"] += lv == 3 and want > stage_work(t, cl, vc, c.memory, caches=False)
            seen["window"] += want > stage_work(t, cl, vc, c.memory if lv == 3 else None, window=False)
            seen["ring"] += want > stage_work(t, cl, vc, c.memory if lv == 3 else None, ring=False)
    assert seen["runs"] > 60 and seen["below"] and seen["dis"] == {"blocks", "interleaved", "dynamic"}, seen
    assert seen["uncached"], seen       # memories without a cache raised some bounds
    assert seen["cached"], seen         # and so did misses no state of a cache spares
    assert seen["window"] and seen["ring"], seen    # so did the trees' chains, and the ring's times in them


@pytest.mark.parametrize("name", NAMES)
def test_the_bound_on_the_golden_traces(traces, name):
    # model S never waits: its time is its one processor's work, so the bound is its cycles, as
    # it is with memories without a cache on per-PE ports (every line a miss, none queued); the
    # 3MPPE and full.toml as written (ring, memories), 1 and 2 PEs, stay above it
    t = traces[name]
    s = builtin("S")
    vc = CM.visit_costs(t, s.processors())
    c = Compiled(t, vc)
    assert c.work_bound(s) == c.result(s).cycles == stage_work(t, s, vc)
    three = builtin("3mppe")
    bare = s.replace(ic_memory=LocalMemoryConfig(0, None), sc_memory=LocalMemoryConfig(0, None),
                     icgm=three.icgm, scgm=three.scgm)
    assert c.work_bound(bare) == c.result(bare).cycles == stage_work(t, bare, vc, c.memory) > c.work_bound(s)
    for cfg in (builtin("3mppe"), load_config(FULL)):
        for pes in (1, 2):
            cfg = cfg.replace(pes=pes)
            vc = CM.visit_costs(t, cfg.processors())
            c = Compiled(t, vc)
            b = c.work_bound(cfg)
            assert b == stage_work(t, cfg, vc, c.memory)
            assert 0 < b <= c.result(cfg).cycles <= c.result(at_level(cfg, 1)).cycles * 10


def test_the_bound_refuses_what_the_run_refuses(traces):
    # SC making each primary ray in 2^61 cycles: more than 2^62 in all, refused by both
    t = head(traces[NAMES[0]], 3)
    cfg = builtin("3mppe").replace(pes=2, source="bound.toml")
    vc = CM.visit_costs(t, cfg.processors())
    vc.inject_process = 1 << 61
    c = Compiled(t, vc)
    with pytest.raises(ConfigError) as bound_err:
        c.work_bound(cfg)
    with pytest.raises(ConfigError) as run_err:
        c.result(cfg)
    assert str(bound_err.value) == str(run_err.value)
    assert "bound.toml: " in str(bound_err.value) and "gen_cycles" in str(bound_err.value)


def test_the_bound_holds_with_more_pes_than_primary_rays(traces):
    # (refused by both before): the spare PEs idle, and the bound is still one
    t = head(traces[NAMES[0]], 3)
    cfg = builtin("3mppe").replace(pes=5)
    c = Compiled(t, CM.visit_costs(t, cfg.processors()))
    assert 0 < c.work_bound(cfg) <= c.result(cfg).cycles
