"""Level 3 in the compiled replay: the memories (caches, resident memory, ICGM and
SCGM with their ports) against the SimPy machine model, differential: the same
SimResult to the cycle (memory stalls per stage and processor, the ``memory``
section), the same event log, the same errors and deadlocks; on the ideal
network (with the ring: test_fidelity_full.py)."""
import os
import random

from pathlib import Path

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.fidelity import Compiled, engine_for, evaluate, replay, unsupported
from mprt.fidelity.memdata import MemoryData, ic_data
from mprt.machine import ConfigError, DeadlockError, builtin, load_config, simulate
from mprt.machine.config import CacheConfig, GlobalMemoryConfig, LocalMemoryConfig
from mprt.machine.memory import DataLayout, LocalMemory

from machines import logged_memories, random_config, random_costs, random_memories
from test_fidelity import FULL, GOLDEN, NAMES, head, outcome, same

CM = CostModel.default()


@pytest.fixture(scope="module")
def traces():
    return {n: mprt.load_trace(p) for n, p in zip(NAMES, GOLDEN)}


def small_memories(cfg, pes=2, contention=True):
    """Memories small enough that the golden scenes miss: IC 64 B resident + a 2-way
    256 B cache of 16 B lines, SC uncached with 32 B resident."""
    return cfg.replace(ring=None, pes=pes, ic_memory=LocalMemoryConfig(64, CacheConfig(256, 16, 2)),
                       sc_memory=LocalMemoryConfig(32, None), icgm=GlobalMemoryConfig(7, 3, contention),
                       scgm=GlobalMemoryConfig(5, 8, contention))


def check(t, cfg, vc=None, record=False):
    vc = vc if vc is not None else CM.visit_costs(t, cfg.processors())
    a = outcome(lambda: simulate(t, cfg, costs=vc, record=record))
    b = outcome(lambda: replay(t, cfg, costs=vc, record=record))
    assert type(a) is type(b), cfg
    if isinstance(a, DeadlockError):
        assert str(a) == str(b) and a.state == b.state, cfg
    else:
        assert a.cycles == b.cycles, cfg
        assert same(a, b), cfg
        if record:
            assert a.log == b.log
    return a


# ---- golden traces ------------------------------------------------------------------

@pytest.mark.parametrize("name", NAMES)
def test_golden_traces_equal_simpy_with_memories(traces, name):
    t = traces[name]
    three = builtin("3mppe").replace(ring=None)
    full = load_config(FULL).replace(ring=None)
    stalls = 0
    for pes in (1, 2):
        for cont in (True, False):
            for cfg in (three, full, small_memories(three)):
                cfg = cfg.replace(pes=pes, icgm=cfg.icgm.__class__(cfg.icgm.latency, cfg.icgm.bandwidth, cont),
                                  scgm=cfg.scgm.__class__(cfg.scgm.latency, cfg.scgm.bandwidth, cont))
                res = check(t, cfg)
                stalls += res.stages["IC"]["memory_stall"] + res.stages["SC"]["memory_stall"]
    assert stalls > 0          # the memories were exercised: lines missed and were read


# ---- random configurations ---------------------------------------------------------------

@pytest.mark.parametrize("seed", range(3))
def test_random_memory_configurations_equal_simpy(traces, seed):
    # 110 configurations per seed: random machines (machines.py: mappings, replicas and
    # feeds, FIFOs, PEs, DIS, windows) with random memories: resident 0 to 2^40 bytes, caches
    # of 1 to 64 sets (or 2^40 bytes) of 1 to 8 ways and 1 to 64-byte lines or none, latency,
    # bandwidth, shared or per-PE ports; deadlocks included
    rng = random.Random(300 + seed)
    names = sorted(traces)
    kinds = {"deadlock": 0, "stall": 0, "ic": 0, "sc": 0}
    for i in range(110):
        t = head(traces[rng.choice(names)], rng.choice([5, 20, 60]))
        cfg = random_memories(random_config(rng, feeds=rng.random() < 0.5), rng)
        res = check(t, cfg, random_costs(t, cfg, rng))
        if isinstance(res, DeadlockError):
            kinds["deadlock"] += 1
        else:
            kinds["stall"] += res.stages["IC"]["memory_stall"] + res.stages["SC"]["memory_stall"] > 0
            kinds["ic"] += "icgm" in res.memory
            kinds["sc"] += "scgm" in res.memory
    assert all(kinds.values()), kinds


@pytest.mark.parametrize("ways", [1, 2, 3, 4, 8])
def test_caches_of_each_way_count_equal_simpy(traces, ways):
    # the C look-up has its own code for 2 and 4 ways (the 3MPPE's), a loop for the others,
    # and skips a look-up of the same key as the cache's last one (its misses known from the
    # first such repeat): each way count with caches that miss and caches that hold the scene,
    # hits and misses counted
    t = traces["balls-g9"]
    base = builtin("3mppe").replace(ring=None, pes=2)
    seen = {"hit": 0, "miss": 0}
    for sets in (2, 16, 256):
        cfg = base.replace(ic_memory=LocalMemoryConfig(0, CacheConfig(sets * ways * 16, 16, ways)),
                           sc_memory=LocalMemoryConfig(0, CacheConfig(sets * ways * 16, 16, ways)))
        res = check(t, cfg)
        for tag in ("ic", "sc"):
            m = res.memory[f"{tag}_cache"]
            seen["hit"] += m["hits"] > 0
            seen["miss"] += m["hits"] < m["accesses"]
    assert seen["hit"] and seen["miss"], seen


@pytest.mark.parametrize("seed", range(4))
def test_event_logs_equal_simpy_with_memories(traces, seed):
    rng = random.Random(400 + seed)
    t = head(traces["gears-g9"], 15)
    check(t, logged_memories(random_config(rng, seed >= 2), rng), record=True)


# ---- one load, many memories --------------------------------------------------------------

def test_repeats_known_from_one_run_serve_the_next_of_the_same_cache_shape(traces):
    # a repeat's misses depend on the key and the cache's shape alone, so the C replay keeps
    # them from run to run while the shape stays: caches far smaller than a voxel's data (every
    # repeat misses), the same shape again after another and under other global memories
    t = traces["balls-g9"]
    base = builtin("3mppe").replace(ring=None, pes=2)
    vc = CM.visit_costs(t, base.processors())
    c = Compiled(t, vc)

    def mem(size, ways, lat, contention):
        gm = GlobalMemoryConfig(lat, 8, contention)
        return base.replace(ic_memory=LocalMemoryConfig(0, CacheConfig(size, 16, ways)),
                            sc_memory=LocalMemoryConfig(0, CacheConfig(size, 16, ways)), icgm=gm, scgm=gm)
    cfgs = [mem(64, 2, 20, True), mem(256, 4, 20, True), mem(64, 2, 3, False), mem(64, 2, 20, True),
            mem(32, 1, 0, True), mem(64, 2, 20, True)]
    got = []
    for cfg in cfgs:
        a = simulate(t, cfg, costs=vc)
        b = c.result(cfg)
        assert same(a, b), cfg
        assert a.memory["ic_cache"]["hits"] < a.memory["ic_cache"]["accesses"]
        got.append(b.cycles)
    assert got[0] == got[3] == got[5] and len(set(got)) >= 4

def test_one_load_runs_many_memory_configurations(traces):
    t = traces["rings-g9"]
    base = small_memories(builtin("3mppe"))
    vc = CM.visit_costs(t, base.processors())
    c = Compiled(t, vc)
    cfgs = [base.replace(ic_memory=LocalMemoryConfig(r, CacheConfig(s, 16, w)))
            for r in (0, 512) for s, w in ((256, 2), (1024, 4), (96, 3))]
    cfgs += [base.replace(pes=1, icgm=GlobalMemoryConfig(50, 1, False)), builtin("3mppe").replace(ring=None),
             base.replace(ic_memory=None, sc_memory=None, icgm=None, scgm=None)]
    for cfg in cfgs:                       # memory data swapped in and out of the one replay
        a = simulate(t, cfg, costs=vc)
        assert same(a, c.result(cfg)), cfg
        assert c.cycles(cfg) == a.cycles
    assert len({c.cycles(cfg) for cfg in cfgs}) > 5


def test_lines_per_key_as_the_simpy_model_reads_them(traces):
    # the vectorised per-voxel data equals LocalMemory's own, key by key
    t = traces["tree-g9"]
    layout = DataLayout(t)
    for resident, line in ((0, 32), (100, 8), (400, 1), (1 << 20, 64)):
        rm = layout.ic_resident(resident)
        d = ic_data(layout, rm.items, line)
        lm = LocalMemory("ic", layout, rm, None, None, 0)
        lm.line = line
        for v in range(len(layout.voxel_start) - 1):
            nres, nitems, lines = lm._ranges(v)
            a, b = d["line_start"][v], d["line_start"][v + 1]
            assert (nres, nitems, lines) == (d["resident"][v], d["items"][v], tuple(d["lines"][a:b].tolist()))


# ---- levels, engines, errors --------------------------------------------------------------

def test_auto_takes_the_compiled_engine_for_memories_on_the_ideal_network(traces):
    t = traces["balls-g9"]
    cfg = builtin("3mppe").replace(ring=None)
    assert unsupported(cfg) is None
    assert engine_for(cfg, 3) == "compiled" and engine_for(builtin("3mppe"), 3) == "compiled"
    e = evaluate(t, cfg)
    assert e.level == 3 and e.engine == "compiled"
    assert same(e.result, evaluate(t, cfg, engine="simpy").result)


def test_bad_memory_configurations_fail_alike(traces):
    t = head(traces["balls-g4"], 5)
    with pytest.raises(ConfigError, match=r"ic_memory.cache.size: at most 2\^40 bytes"):
        builtin("3mppe").replace(ic_memory=LocalMemoryConfig(0, CacheConfig(1 << 60, 32, 4)))
    with pytest.raises(ConfigError, match="icgm: ic_memory is modelled"):
        builtin("M").replace(ic_memory=LocalMemoryConfig(0, None))
    # the largest cache allowed replays without allocating it (sets beyond the data never fill)
    big = builtin("3mppe").replace(ring=None, ic_memory=LocalMemoryConfig(0, CacheConfig(1 << 40, 1, 1)))
    assert same(simulate(t, big), replay(t, big))


def test_memory_data_is_checked_by_the_c_replay(traces):
    from mprt._lowlevel import binding
    from mprt.errors import InvalidArgument, MprtError
    from mprt.fidelity.compiled import c_config

    lib = binding()
    t = head(traces["balls-g4"], 5)
    vc = CM.visit_costs(t, builtin("M").processors())
    c = Compiled(t, vc)
    md = MemoryData(t)
    ic, _ = md.get("ic", 0, 32)
    keys = md.replay_keys
    with pytest.raises(InvalidArgument, match="memory keys: .* given, the trace has"):
        lib.replay_set_memory(c.h, keys[:-1], ic, None)
    bad = dict(ic, lines=-ic["lines"] - 1)
    with pytest.raises(InvalidArgument, match="memory data IC: line 0 is -"):
        lib.replay_set_memory(c.h, keys, bad, None)
    short = dict(ic, items=ic["items"][:1], resident=ic["resident"][:1], line_start=ic["line_start"][:2])
    with pytest.raises(InvalidArgument, match="memory keys: visit .* reads IC key"):
        lib.replay_set_memory(c.h, keys, short, None)
    # a modelled memory without data (a failed call keeps none) is refused, not run
    lib.replay_set_config(c.h, c_config(builtin("3mppe").replace(ring=None), 0))
    with pytest.raises(MprtError, match="the IC memory is modelled but has no data"):
        lib.replay_run(c.h)
    # the line size the data was numbered in must be the configuration's
    lib.replay_set_memory(c.h, keys, ic, md.get("sc", 0, 32)[0])
    with pytest.raises(InvalidArgument, match="cache_line.0.: 16 bytes, but the IC memory data has lines of 32"):
        lib.replay_set_config(c.h, c_config(small_memories(builtin("3mppe")), 0))
        lib.replay_run(c.h)
    # latencies that could overflow the cycle count are refused before the run (by the C
    # replay itself: a machine configuration bounds the latency at 2^20, config.LIMITS)
    huge = dict(c_config(builtin("3mppe").replace(ring=None), 0), gm_latency=[1 << 61, 10])
    with pytest.raises(InvalidArgument, match=r"gm_latency.0.: .* could exceed 2\^62 cycles"):
        lib.replay_set_config(c.h, huge)
        lib.replay_run(c.h)
    # a configuration the C replay refuses by itself
    bad = dict(c_config(builtin("3mppe").replace(ring=None), 0), cache_size=[1 << 60, 0])
    with pytest.raises(InvalidArgument, match=r"cache_size\[0\]: must be 0 .no cache. to 2\^40 bytes"):
        lib.replay_set_config(c.h, bad)


# ---- the resident set (both engines) ---------------------------------------------------------

def reference_resident(layout, size, tag):
    """The resident set item by item, as the model defines it: items in decreasing order of
    references (ties: lists before shapes, lower id first), each taken if it still fits."""
    if tag == "ic":
        lens = np.diff(layout.voxel_start)
        cands = [(int(r), 0, i, 8 * int(n)) for i, (r, n) in enumerate(zip(layout.voxel_refs, lens)) if r > 0 and n > 0]
        cands += [(int(r), 1, i, int(b)) for i, (r, b) in enumerate(zip(layout.prim_refs, layout.shape_bytes)) if r > 0]
    else:
        cands = [(int(r), 0, i, 32) for i, r in enumerate(layout.material_refs) if r > 0]
    cands.sort(key=lambda c: (-c[0], c[1], c[2]))
    used, chosen = 0, set()
    for _, kind, i, nbytes in cands:
        if used + nbytes <= size:
            chosen.add((kind, i))
            used += nbytes
    return chosen, used


@pytest.mark.parametrize("name", ["tree-g9", "rings-g4", "gears-g9"])
def test_resident_set_is_the_greedy_choice_by_references(traces, name):
    layout = DataLayout(traces[name])
    for size in (0, 8, 100, 333, 1000, 4096, 20000, 1 << 40):
        rm = layout.ic_resident(size)
        chosen, used = reference_resident(layout, size, "ic")
        got = {(0, int(i)) for i in np.flatnonzero(rm.items["list"])} | \
              {(1, int(i)) for i in np.flatnonzero(rm.items["shape"])}
        assert got == chosen and rm.used == used <= size, size
        rm = layout.sc_resident(size)
        chosen, used = reference_resident(layout, size, "sc")
        assert {(0, int(i)) for i in np.flatnonzero(rm.items["material"])} == chosen and rm.used == used


def test_greedy_takes_each_item_that_still_fits():
    from mprt.machine.memory import _greedy

    rng = np.random.default_rng(5)
    for _ in range(300):
        n = int(rng.integers(0, 200))
        nbytes = rng.integers(0, rng.choice([4, 50, 1000]), n)
        size = int(rng.integers(0, max(1, int(nbytes.sum()) + 5)))
        want, rem = [], size
        for b in nbytes.tolist():
            want.append(b <= rem)
            rem -= b if b <= rem else 0
        assert _greedy(nbytes, size).tolist() == want
    # a long tail of near misses, one per round (the one-by-one fallback after 64 rounds)
    nbytes = np.array([x for k in range(100) for x in (1, 100 - k)])
    want, rem = [], 100
    for b in nbytes.tolist():
        want.append(b <= rem)
        rem -= b if b <= rem else 0
    assert _greedy(nbytes, 100).tolist() == want and sum(want) == 100


def test_simulate_command_at_level_3_on_the_compiled_engine(tmp_path):
    import json

    from mprt.fidelity.cli import main

    cfg = tmp_path / "noring.toml"
    cfg.write_text('base = "3mppe"\nname = "noring"\nring = "none"\n[ic_memory]\nresident = 256\n'
                   'cache = { size = 512, line = 16, ways = 2 }\n')
    out = {}
    for engine in ("compiled", "simpy"):
        path = tmp_path / f"{engine}.json"
        assert main(["simulate", GOLDEN[NAMES.index("balls-g9")], "--config", str(cfg), "--engine", engine,
                     "--json", str(path)]) == 0
        out[engine] = json.loads(path.read_text())
    a, b = out["compiled"], out["simpy"]
    assert (a["level"], a["engine"], b["engine"]) == (3, "compiled", "simpy")
    assert a["cycles"] == b["cycles"] and a["memory"] == b["memory"] and a["stages"] == b["stages"]
    assert a["memory"]["icgm"]["accesses"] > 0


@pytest.mark.parametrize("contention", [False, True])
def test_global_memory_read_lines_is_n_reads(contention):
    """read_lines (a visit's misses in one step) leaves the same time and figures as one read a
    line, issued each when the last one's data is back, on ports already busy or free."""
    from mprt.machine.memory import GlobalMemory
    rng = np.random.default_rng(5)
    for _ in range(200):
        cfg = GlobalMemoryConfig(int(rng.choice([0, 1, 7, 40])), int(rng.choice([1, 3, 8, 64])), contention)
        a, b = GlobalMemory("ICGM", cfg, 3), GlobalMemory("ICGM", cfg, 3)
        for _ in range(int(rng.integers(1, 6))):
            t, pe, n = int(rng.integers(0, 300)), int(rng.integers(0, 3)), int(rng.integers(0, 9))
            nbytes = int(rng.choice([1, 16, 32, 100]))
            done = t
            for _ in range(n):
                done = a.read(done, nbytes, pe)
            assert b.read_lines(t, nbytes, pe, n) == done
            assert (a.port_free, a.accesses, a.busy, a.queued) == (b.port_free, b.accesses, b.busy, b.queued)


# ---- long look-ups: the caches' summaries (c/src/replay_summary.c) -------------------------

@pytest.fixture(scope="module")
def coarse():
    """balls of 820 spheres on a 2x2x2 grid: voxel lists of thousands of lines, through caches of a
    few to thousands."""
    return mprt.Scene.spd("balls", size=3).grid(2).trace(10, 10)[1]


@pytest.mark.parametrize("ways", [1, 2, 4, 8, 16, 32])
def test_long_look_ups_by_summary_equal_simpy_and_line_by_line(coarse, ways, monkeypatch):
    """A key read through a cache by its summary (its look-up in an empty cache, the first
    lines of each set, the set after it) gives what SimPy's line-by-line LRU gives, and what
    the compiled replay gives looking every line up (MPRT_CACHE_SUMMARY=0): caches of 1 to 32
    ways (over 16: never summarised), from a few sets to more sets than the data has lines,
    with and without resident memory, one PE or two sharing a port."""
    hits = misses = 0
    for sets, resident, pes, contention in ((2, 0, 2, True), (8, 64, 1, True), (1, 0, 2, False), (64, 256, 2, True),
                                            (4096, 0, 1, True)):
        cfg = builtin("3mppe").replace(ring=None, pes=pes,
                                       ic_memory=LocalMemoryConfig(resident, CacheConfig(sets * ways * 16, 16, ways)),
                                       sc_memory=LocalMemoryConfig(0, CacheConfig(16 * ways, 16, ways)),
                                       icgm=GlobalMemoryConfig(7, 3, contention), scgm=GlobalMemoryConfig(5, 8, contention))
        a = check(coarse, cfg)
        monkeypatch.setenv("MPRT_CACHE_SUMMARY", "0")
        b = replay(coarse, cfg)
        monkeypatch.delenv("MPRT_CACHE_SUMMARY")
        assert a.cycles == b.cycles and same(a, b), (ways, sets, resident, pes)
        hits += a.memory["ic_cache"]["hits"]
        misses += a.memory["ic_cache"]["accesses"] - a.memory["ic_cache"]["hits"]
    assert hits > 0 and misses > 0          # the caches were exercised both ways


def test_a_small_trace_on_a_fine_grid_has_data_for_its_voxels_alone():
    """Where the trace visits fewer than half the grid's voxels, the IC data holds those alone
    (keys renumbered among them, the lines the same) and replays as SimPy does; the reads the
    memory estimate counts are those of all the voxels' data."""
    t = mprt.Scene.spd("balls", size=1).grid(24).trace(8, 8)[1]
    md = MemoryData(t)
    nvox = len(t.voxel_start) - 1
    used = np.flatnonzero(md.layout.voxel_refs > 0)
    rk, keys = md.replay_keys, md.keys
    assert 0 < len(used) < nvox // 2 and np.array_equal(md._used, used)
    assert np.array_equal(used[rk[keys >= 0]], keys[keys >= 0]) and np.array_equal(rk[keys < 0], keys[keys < 0])
    for resident, line in ((0, 32), (256, 16)):
        layout = md.layout
        rm = layout.ic_resident(resident)
        whole = ic_data(layout, rm.items, line)
        mine = md.get("ic", resident, line)[0]
        for k, v in enumerate(used[:50]):
            a, b = whole["line_start"][v], whole["line_start"][v + 1]
            c, d = mine["line_start"][k], mine["line_start"][k + 1]
            assert whole["lines"][a:b].tolist() == mine["lines"][c:d].tolist()
            assert (whole["items"][v], whole["resident"][v]) == (mine["items"][k], mine["resident"][k])
        assert md.reads("ic", np.diff(mine["line_start"])) == int(np.dot(np.diff(whole["line_start"]),
                                                                           layout.voxel_refs))
    cfg = small_memories(builtin("3mppe"))
    assert check(t, cfg).memory["ic_cache"]["accesses"] > 0


def test_primitive_references_count_the_visited_voxels_listing_them():
    """The layout goes through the visited voxels only; each primitive's references are still
    the sum, over every voxel listing it, of that voxel's references (counted here voxel by
    voxel over the whole grid), whether the layout counts the visits or is given C's counts."""
    t = mprt.Scene.spd("balls", size=2).grid(24).trace(6, 6)[1]
    own, md = DataLayout(t), MemoryData(t)
    vs, ids, refs = t.voxel_start, t.voxel_ids, own.voxel_refs
    expect = np.zeros(len(t.prim_words), np.int64)
    for v in range(len(vs) - 1):
        for p in ids[vs[v]:vs[v + 1]].tolist():
            expect[p] += refs[v]
    assert np.array_equal(md.layout.voxel_refs, refs)
    assert np.array_equal(own.used, [v for v in range(len(vs) - 1) if refs[v] > 0])
    listed = np.zeros(len(expect), bool)
    listed[ids] = True
    assert (expect > 0).any() and ((expect == 0) & listed).any()     # some listed only where no ray went
    for layout in (own, md.layout):
        assert np.array_equal(layout.prim_refs, expect) and layout.prim_refs.dtype == np.int64


@pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="resident memory read from /proc")
def test_a_fine_grids_counts_take_the_pages_written_alone():
    """Per-voxel arrays of a fine grid that a small trace writes at few places (``sparse_zeros``)
    take memory where written: 256 writes 512 KiB apart in 128 MiB of counts (whole 2 MiB huge
    pages, NumPy's choice for a large array, would take all of it), private to the process as any
    memory is (a forked worker's writes stay its own); the keys and counts of a
    small trace on a fine grid are those of a count in NumPy."""
    from mprt.pages import sparse_zeros

    def resident():
        return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    before = resident()
    a = sparse_zeros(1 << 24, np.int64)
    a[::1 << 16] = 1
    grew = resident() - before
    assert a.dtype == np.int64 and a.shape == (1 << 24,) and a.sum() == 256 and a[1] == 0
    assert grew < 32 << 20, grew
    assert sparse_zeros(5, np.int32).tolist() == [0] * 5
    pid = os.fork()                 # private memory: what a forked worker writes stays its own
    if pid == 0:
        a[1] = 5
        os._exit(0)
    os.waitpid(pid, 0)
    assert a[1] == 0
    t = mprt.Scene.spd("balls", size=2).grid(160).trace(6, 6)[1]
    md = MemoryData(t)
    nvox = len(t.voxel_start) - 1
    v = t.visits
    ic = v["stage"] == 1
    assert nvox * 8 >= 4 << 20 and np.array_equal(md.layout.voxel_refs, np.bincount(v["voxel_id"][ic],
                                                                                    minlength=nvox))
    assert np.array_equal(md.keys[ic], v["voxel_id"][ic])


def test_one_replay_switching_data_gives_what_fresh_ones_give(coarse):
    """The C replay keeps its data arrays, tags, sets and summaries from one data and run to the
    next: one Compiled going through resident sizes, line sizes and cache shapes back and forth
    gives each configuration's result as a Compiled made for it alone."""
    base = builtin("3mppe").replace(ring=None, pes=2)
    cfgs = [base.replace(ic_memory=LocalMemoryConfig(res, CacheConfig(size, line, ways)),
                         sc_memory=LocalMemoryConfig(res // 4, None), icgm=GlobalMemoryConfig(7, 3, True),
                         scgm=GlobalMemoryConfig(5, 8, True))
            for res, size, line, ways in ((0, 512, 16, 4), (4096, 512, 16, 4), (0, 2048, 32, 2), (65536, 256, 16, 1),
                                          (4096, 512, 16, 4), (0, 512, 16, 4))]
    vc = CM.visit_costs(coarse, base.processors())
    one = Compiled(coarse, vc)
    got = [one.result(c) for c in cfgs]
    for c, g in zip(cfgs, got):
        assert same(g, Compiled(coarse, vc).result(c)), c
    assert got[0].cycles == got[5].cycles and got[1].cycles == got[4].cycles and got[0].cycles != got[1].cycles
