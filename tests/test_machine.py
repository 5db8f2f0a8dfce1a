"""The SimPy machine model on tiny hand-built traces, with event logs worked
out by hand (see python/mprt/machine/README.md for the rules applied)."""
from types import SimpleNamespace

import os
import numpy as np
import pytest

import mprt
from mprt.machine import DeadlockError, builtin, make_stage, simulate
from mprt.trace import (HIT, IC, LATE_HIT, LEFT, LIT, OS, PRIMARY, REFLECT, RAY_DTYPE, RETURN, SC, SHADED, SHADOW,
                        TO_IC, TO_SC, VISIT_DTYPE)


def hand_trace(rays, visits):
    """rays: [(parent, kind)]; visits: [(ray, stage, outcome, made)] grouped by ray."""
    r = np.zeros(len(rays), dtype=RAY_DTYPE)
    r["id"] = np.arange(len(rays))
    r["parent"] = [p for p, _ in rays]
    r["kind"] = [k for _, k in rays]
    v = np.zeros(len(visits), dtype=VISIT_DTYPE)
    for i, (ray, st, out, made) in enumerate(visits):
        v[i]["ray"], v[i]["stage"], v[i]["outcome"], v[i]["made"] = ray, st, out, made
        v[i]["voxel_id"] = 0 if st == IC else -1
        v[i]["prim"] = 0 if (st == IC and out == HIT) or (st == SC and out == SHADED) else -1
    arrays = {"rays": r, "visits": v, "voxel_start": np.array([0, 1], np.uint32), "voxel_ids": np.array([0], np.int32),
              "prim_kind": np.zeros(1, np.int32), "prim_words": np.array([4], np.int32),
              "prim_material": np.zeros(1, np.int32), "samples": np.zeros((1, 1, 3))}
    meta = {"scene": "hand", "grid": [1, 1, 1], "width": 1, "height": 1, "rules": "paper", "threshold": 0.0,
            "lights": 1, "tiles": [0], "tiles_total": 1, "samples_w": 1, "samples_h": 1}
    return mprt.Trace.from_arrays(meta, arrays)


def costs(durations, receive=None, send=None, inject=(0, 0, 0)):
    """Stand-in for the cost model: per-visit process cycles (receive and send 0 unless given)."""
    n = len(durations)
    z = np.zeros(n, np.int64)
    return SimpleNamespace(process=np.asarray(durations, np.int64),
                           receive=z if receive is None else np.asarray(receive, np.int64),
                           send=z if send is None else np.asarray(send, np.int64), flits=np.zeros(n, np.int32),
                           inject_process=inject[0], inject_send=inject[1], inject_flits=inject[2])


def run(trace, cfg, c, **kw):
    return simulate(trace, cfg, costs=c, record=True, **kw)


def M(**kw):
    return builtin("M").replace(**kw)


def log_of(res):
    return [(t, what, name.split(".")[1], j) for t, what, name, k, j in res.log]


# ---- one ray ---------------------------------------------------------------------

def test_one_ray():
    # A primary that leaves the scene at once: one OS visit of 2 + 10 + 0 cycles.
    tr = hand_trace([(-1, PRIMARY)], [(0, OS, LEFT, 0)])
    c = costs([10], receive=[2])
    for model in ("S", "M"):
        res = run(tr, model, c)
        name = "OS+IC+SC" if model == "S" else "OS"
        assert log_of(res) == [(0, "start", name, 0), (12, "end", name, 0)]
        assert res.cycles == 12
        os_ = res.stages["OS"]
        assert (os_["processing"], os_["communication"], os_["rays_in"]) == (10, 2, 1)


def test_one_ray_with_a_return():
    # OS 8 -> IC 25 (return) -> OS 7 -> IC 36 (hit) -> SC 53: one ray, so M and S
    # both take 8 + 25 + 7 + 36 + 53 = 129 cycles, the visits back to back.
    tr = hand_trace([(-1, PRIMARY)], [(0, OS, TO_IC, 0), (0, IC, RETURN, 0), (0, OS, TO_IC, 0), (0, IC, HIT, 0),
                                      (0, SC, SHADED, 0)])
    c = costs([5, 20, 4, 30, 50], receive=[1, 2, 1, 2, 3], send=[2, 3, 2, 4, 0])
    res = run(tr, "M", c)
    assert log_of(res) == [(0, "start", "OS", 0), (8, "end", "OS", 0), (8, "start", "IC", 1), (33, "end", "IC", 1),
                           (33, "start", "OS", 2), (40, "end", "OS", 2), (40, "start", "IC", 3),
                           (76, "end", "IC", 3), (76, "start", "SC", 4), (129, "end", "SC", 4)]
    assert res.cycles == 129 == run(tr, "S", c).cycles
    # M: OS busy 15, IC 61, SC 53; the rest of the 129 cycles is waiting
    assert [res.stages[t]["waiting"] for t in ("OS", "IC", "SC")] == [114, 68, 76]


# ---- a parent and its children ------------------------------------------------------

PARENT = hand_trace(
    [(-1, PRIMARY), (0, SHADOW), (0, REFLECT)],
    [(0, OS, TO_IC, 0), (0, IC, HIT, 0), (0, SC, SHADED, 2),       # visits 0-2: the primary, 10, 20, 30 cycles
     (1, OS, TO_SC, 0), (1, SC, LIT, 0),                           # visits 3-4: shadow ray, 5, 4
     (2, OS, TO_IC, 0), (2, IC, RETURN, 0), (2, OS, LEFT, 0)])     # visits 5-7: reflection, 6, 8, 3
PARENT_COSTS = costs([10, 20, 30, 5, 4, 6, 8, 3])


def test_parent_and_children_model_m():
    # 0-10 OS, 10-30 IC, 30-60 SC; at 60 SC sends ray 1 then ray 2 to OS (id order):
    # ray 1 starts on the idle OS, ray 2 waits in OS's receive FIFO.  65: OS ends
    # ray 1 (to the idle SC: 65-69) and takes ray 2 (65-71); 71-79 IC; 79-82 OS.
    res = run(PARENT, "M", PARENT_COSTS)
    assert log_of(res) == [
        (0, "start", "OS", 0), (10, "end", "OS", 0), (10, "start", "IC", 1), (30, "end", "IC", 1),
        (30, "start", "SC", 2), (60, "end", "SC", 2), (60, "start", "OS", 3), (65, "end", "OS", 3),
        (65, "start", "SC", 4), (65, "start", "OS", 5), (69, "end", "SC", 4), (71, "end", "OS", 5),
        (71, "start", "IC", 6), (79, "end", "IC", 6), (79, "start", "OS", 7), (82, "end", "OS", 7)]
    assert res.cycles == 82
    assert res.fifos["PE0.OS.receive"]["max"] == 1


def test_parent_and_children_model_s():
    # One processor: every packet to itself goes to its local queue, served
    # first come first served: after the SC visit (30-60) the queue is
    # [ray 1, ray 2]; ray 1's OS visit queues its SC visit behind ray 2.
    res = run(PARENT, "S", PARENT_COSTS)
    order = [j for _, what, _, j in log_of(res) if what == "start"]
    assert order == [0, 1, 2, 3, 5, 4, 6, 7]
    assert res.cycles == 86 == sum([10, 20, 30, 5, 4, 6, 8, 3])


def test_simultaneous_completions_follow_rank_order():
    # Two primaries, A (rays 0) and B (ray 1, child C = ray 2).
    # A: OS 10, IC 10 (return), OS 1 (left).  B: OS 5 (late hit), SC 5 (makes C).
    # C: OS 2 (to SC), SC 2 (lit).
    # 0-10 OS A; 10-15 OS B; 15-20 SC B; 10-20 IC A.  At 20 IC (rank 2) and SC
    # (rank 3) both end and both send to the idle OS: IC's packet comes first, so
    # OS runs A 20-21, then C 21-23, SC C 23-25: 25 cycles (SC first would give 24).
    tr = hand_trace([(-1, PRIMARY), (-1, PRIMARY), (1, SHADOW)],
                    [(0, OS, TO_IC, 0), (0, IC, RETURN, 0), (0, OS, LEFT, 0),
                     (1, OS, LATE_HIT, 0), (1, SC, SHADED, 1),
                     (2, OS, TO_SC, 0), (2, SC, LIT, 0)])
    res = run(tr, "M", costs([10, 10, 1, 5, 5, 2, 2]))
    starts = [(t, name, j) for t, what, name, j in log_of(res) if what == "start"]
    # (at 10 OS's end first hands A to the idle IC, then OS takes B)
    assert starts == [(0, "OS", 0), (10, "IC", 1), (10, "OS", 3), (15, "SC", 4), (20, "OS", 2), (21, "OS", 5),
                      (23, "SC", 6)]
    assert res.cycles == 25


def test_blocked_sender_resumes_when_a_slot_frees():
    # Four primaries A-D, each OS 2 (to IC), IC 10 (return), OS 1 (left); IC's
    # receive FIFO holds 1 packet, OS's send FIFO 1.
    # 0-2 A, 2-4 B, 4-6 C, 6-8 D on OS.  A goes straight to IC (2-12), B into IC's
    # receive FIFO, C into OS's send FIFO; at 8 D finds it full: OS blocks.
    # 12: IC ends A (A's return to OS's receive FIFO, OS is blocked) and takes B;
    # C moves into IC's FIFO, D into OS's send FIFO: OS resumes at 12 and runs A
    # 12-13.  IC: B 12-22, C 22-32, D 32-42; OS: B 22-23, C 32-33, D 42-43.
    tr = hand_trace([(-1, PRIMARY)] * 4,
                    [v for r in range(4) for v in ((r, OS, TO_IC, 0), (r, IC, RETURN, 0), (r, OS, LEFT, 0))])
    cfg = builtin("M").replace(stages=(make_stage(("OS",), send_fifo=1), make_stage(("IC",), receive_fifo=1), make_stage(("SC",))))
    res = run(tr, cfg, costs([2, 10, 1] * 4))
    starts = [(t, name, j) for t, what, name, j in log_of(res) if what == "start"]
    # (in the log, an ending stage's output starts its receiver before the stage
    # takes its own next packet; OS's resumption at 12 comes after IC's end)
    assert starts == [(0, "OS", 0), (2, "IC", 1), (2, "OS", 3), (4, "OS", 6), (6, "OS", 9), (12, "IC", 4),
                      (12, "OS", 2), (22, "OS", 5), (22, "IC", 7), (32, "OS", 8), (32, "IC", 10), (42, "OS", 11)]
    assert res.cycles == 43
    os_node = res.nodes["OS"]
    assert (os_node["busy"], os_node["blocked"], os_node["waiting"]) == (12, 4, 31)


def test_primary_rays_made_by_sc():
    # With a cost for making a primary ray (3 + 1 cycles, on SC), the DIS hands the
    # work to SC, which sends the ray to OS: SC 0-4, OS 4-16.
    tr = hand_trace([(-1, PRIMARY)], [(0, OS, LEFT, 0)])
    res = run(tr, "M", costs([10], receive=[2], inject=(3, 1, 12)))
    assert log_of(res) == [(0, "start", "SC", -1), (4, "end", "SC", -1), (4, "start", "OS", 0), (16, "end", "OS", 0)]
    assert res.stages["SC"]["processing"] == 3 and res.stages["SC"]["communication"] == 1
    assert res.stages["SC"]["rays_in"] == 0 and res.stages["SC"]["primaries_made"] == 1


def test_window_limits_live_rays():
    # Ten primaries that each leave at once, window 3: at 0 the DIS admits three
    # (one runs, two wait); at each end the retirement admits the next before OS
    # takes its next ray, so 3 wait for a moment, never more.
    tr = hand_trace([(-1, PRIMARY)] * 10, [(r, OS, LEFT, 0) for r in range(10)])
    res = run(tr, M(window=3), costs([5] * 10))
    assert res.fifos["PE0.OS.receive"]["max"] == 3
    assert res.pes[0]["max_live_rays"] == 3
    assert res.cycles == 50


@pytest.mark.parametrize("policy,expected", [("blocks", [0, 0, 0, 1, 1, 1]), ("interleaved", [0, 1, 0, 1, 0, 1])])
def test_static_dis_policies(policy, expected):
    tr = hand_trace([(-1, PRIMARY)] * 6, [(r, OS, LEFT, 0) for r in range(6)])
    res = run(tr, M(pes=2, dis=policy), costs([5] * 6))
    pe_of = {j: int(name[2]) for t, what, name, k, j in res.log if what == "start"}
    assert [pe_of[j] for j in range(6)] == expected
    assert res.cycles == 15


def test_dynamic_dis_feeds_the_faster_pe():
    # Primaries of 100 and 1 cycles alternately, window 1 per PE: PE0 gets the
    # slow first one, PE1 then draws every other primary while PE0 is busy.
    tr = hand_trace([(-1, PRIMARY)] * 6, [(r, OS, LEFT, 0) for r in range(6)])
    res = run(tr, M(pes=2, dis="dynamic", window=1), costs([100, 1, 1, 1, 1, 1]))
    assert [p["primaries"] for p in res.pes] == [1, 5]
    assert res.cycles == 100


def test_more_pes_than_primary_rays_leave_the_others_idle():
    tr = hand_trace([(-1, PRIMARY)], [(0, OS, LEFT, 0)])
    for dis in ("blocks", "interleaved", "dynamic"):
        res = simulate(tr, M(pes=3, dis=dis), costs=costs([5]))
        assert res.cycles == 5 and [p["primaries"] for p in res.pes] in ([1, 0, 0], [0, 0, 1], [0, 1, 0])
        assert sum(p["end"] for p in res.pes) == 5 and sum(p["rays"] for p in res.pes) == 1


def test_zero_length_visit_is_refused():
    tr = hand_trace([(-1, PRIMARY)], [(0, OS, LEFT, 0)])
    with pytest.raises(ValueError, match="at least 1 cycle"):
        simulate(tr, "M", costs=costs([0]))


def test_finite_fifos_deadlock_is_reported_with_state():
    # Eight primaries, each OS -> IC -> OS (1 cycle each).  OS: receive FIFO 3,
    # send FIFO 1; IC: 1 and 1.  With window 8 all eight are admitted; OS and IC
    # fill up: OS holds 1 + 1 in its send FIFO + 3 in its receive FIFO, IC 1 + 1 + 1,
    # each waiting for the other's receive FIFO.  With window 7 (fewer rays than
    # the 3 + 1 + 1 + 1 + 1 + 1 = 8 needed to fill both) it cannot happen.
    tr = hand_trace([(-1, PRIMARY)] * 8,
                    [v for r in range(8) for v in ((r, OS, TO_IC, 0), (r, IC, RETURN, 0), (r, OS, LEFT, 0))])
    cfg = builtin("M").replace(stages=(make_stage(("OS",), send_fifo=1, receive_fifo=3),
                                       make_stage(("IC",), send_fifo=1, receive_fifo=1), make_stage(("SC",))),
                               window=8)
    assert cfg.cycle_capacity == 8
    with pytest.raises(DeadlockError) as e:
        simulate(tr, cfg, costs=costs([1, 1, 1] * 8))
    msg = str(e.value)
    assert msg.startswith("deadlock: the machine stopped with 8 of 8 rays still in it")
    assert "PE0.OS: blocked (send FIFO full) with 1 packet(s) to send; receive FIFO 3+0 reserved of 3" in msg
    assert "a window below 8 rules this out" in msg
    st = e.value.state["pes"]["PE0"]["stages"]
    assert st["PE0.IC"]["receive_fifo"]["occupancy"] == 1 and st["PE0.IC"]["send_fifo"]["occupancy"] == 1
    res = simulate(tr, cfg.replace(window=7), costs=costs([1, 1, 1] * 8))
    # OS has 16 cycles of work and, with rays always waiting for it, never idles
    assert res.deadlock_bound["fifos_cannot_deadlock"] and res.cycles == 16


def test_replicated_stage_shares_its_receive_fifo():
    # Two primaries, each OS 1 (to IC), IC 10 (return), OS 1 (left); two IC processors.
    # OS: A 0-1, B 1-2; IC0 takes A at 1 (1-11), IC1 takes B at 2 (2-12); OS: A 11-12;
    # at 12 OS (rank 1) ends A before IC1 (rank 3) ends B, so B runs on OS 12-13.
    # With one IC processor B waits for it: IC B 11-21, OS B 21-22.
    tr = hand_trace([(-1, PRIMARY)] * 2,
                    [v for r in range(2) for v in ((r, OS, TO_IC, 0), (r, IC, RETURN, 0), (r, OS, LEFT, 0))])
    two = builtin("M").replace(stages=(make_stage(("OS",)), make_stage(("IC",), replicas=2), make_stage(("SC",))))
    res = run(tr, two, costs([1, 10, 1] * 2))
    assert [(t, what, name, k, j) for t, what, name, k, j in res.log if what == "start"] == [
        (0, "start", "PE0.OS", 0, 0), (1, "start", "PE0.IC", 0, 1), (1, "start", "PE0.OS", 0, 3),
        (2, "start", "PE0.IC", 1, 4), (11, "start", "PE0.OS", 0, 2), (12, "start", "PE0.OS", 0, 5)]
    assert res.cycles == 13
    assert [(p["stage"], p["replica"], p["busy"]) for p in res.processors if p["stage"] == "IC"] == \
        [("IC", 0, 10), ("IC", 1, 10)]
    assert res.nodes["IC"]["waiting"] == 2 * 13 - 20
    assert run(tr, "M", costs([1, 10, 1] * 2)).cycles == 22


def test_merged_stages_use_the_local_queue():
    # OS and IC on one processor, SC on another: PARENT's OS->IC and IC->OS
    # handoffs stay local.  0-10 OS, 10-30 IC (local), 30-60 SC; at 60 rays 1 and 2
    # go to the OS+IC processor: ray 1 60-65, then (local queue first) ... ray 1's
    # SC visit on SC 65-69, ray 2's OS 65-71, its IC 71-79 (local), OS 79-82.
    cfg = builtin("M").replace(stages=(make_stage(("OS", "IC")), make_stage(("SC",))))
    res = run(PARENT, cfg, PARENT_COSTS)
    assert [(t, name, j) for t, what, name, j in log_of(res) if what == "start"] == [
        (0, "OS+IC", 0), (10, "OS+IC", 1), (30, "SC", 2), (60, "OS+IC", 3), (65, "SC", 4), (65, "OS+IC", 5),
        (71, "OS+IC", 6), (79, "OS+IC", 7)]
    assert res.cycles == 82
    assert res.fifos["PE0.OS+IC.receive"]["max"] == 1 and res.fifos["PE0.SC.receive"]["packets"] == 0


def test_cache_is_lru_per_set():
    from mprt.machine import Cache, CacheConfig

    c = Cache(CacheConfig(size=128, line=32, ways=2))      # 2 sets of 2 ways
    # lines 0, 2, 4 map to set 0; 1 to set 1.  0 m, 2 m, 0 h, 4 m (evicts 2), 1 m, 2 m (evicts 0), 4 h, 0 m
    got = [c.access(x) for x in (0, 2, 0, 4, 1, 2, 4, 0)]
    assert got == [False, False, True, False, False, False, True, False]
    assert (c.accesses, c.hits) == (8, 2)


def test_global_memory_port_is_shared_with_contention():
    from mprt.machine import GlobalMemory, GlobalMemoryConfig

    # a 32-byte line at 8 bytes/cycle occupies the port 4 cycles, then 20 cycles of latency
    shared = GlobalMemory("icgm", GlobalMemoryConfig(latency=20, bandwidth=8, contention=True), pes=2)
    assert shared.read(0, 32, 0) == 24 and shared.read(0, 32, 1) == 28     # PE1 waits 4 cycles for the port
    own = GlobalMemory("icgm", GlobalMemoryConfig(latency=20, bandwidth=8, contention=False), pes=2)
    assert own.read(0, 32, 0) == 24 and own.read(0, 32, 1) == 24
    assert (shared.queued, own.queued) == (4, 0)


def test_per_copy_feed_can_be_slower_than_shared():
    # Three primaries, each OS 1 (to IC), IC (return), OS 1 (left); IC 10, 1, 1 for A, B, C;
    # two IC copies.  Shared: IC0 A 1-11, IC1 B 2-3; C arrives at 3 (OS, rank 1, before
    # IC1's end) into the FIFO, IC1 takes it 3-4 after sending B to OS (3-4); OS C 4-5,
    # A 11-12: 12 cycles.  Round-robin: C is the third packet, copy 0's, which waits for A:
    # IC0 C 11-12, OS A 11-12, C 12-13: 13.  Shortest queue: at 3 both copies hold one
    # (IC1's end at 3 has not run yet), a tie to copy 0: 13 as well.
    tr = hand_trace([(-1, PRIMARY)] * 3,
                    [v for r in range(3) for v in ((r, OS, TO_IC, 0), (r, IC, RETURN, 0), (r, OS, LEFT, 0))])
    c = costs([1, 10, 1, 1, 1, 1, 1, 1, 1])
    got = {}
    for feed in ("shared", "round-robin", "shortest-queue"):
        cfg = M(stages=(make_stage(("OS",)), make_stage(("IC",), replicas=2, feed=feed), make_stage(("SC",))))
        res = run(tr, cfg, c)
        got[feed] = res.cycles
        ic = [(k, j) for t, what, name, k, j in res.log if what == "start" and name == "PE0.IC"]
        assert ic == ([(0, 1), (1, 4), (1, 7)] if feed == "shared" else [(0, 1), (1, 4), (0, 7)])
    assert got == {"shared": 12, "round-robin": 13, "shortest-queue": 13}


@pytest.mark.parametrize("feed", ["round-robin", "shortest-queue"])
def test_one_copy_feeds_equal_shared_and_copies_lose_no_visit(feed):
    # With one copy every feed is the shared FIFO (same figures); with copies every visit
    # still runs exactly once and no processor is busier than the run is long.
    tr = mprt.load_trace(os.path.join(os.path.dirname(__file__), "data", "golden", "rings-g9.npz"))
    base = builtin("3mppe").replace(ring=None, ic_memory=None, sc_memory=None, icgm=None, scgm=None, window=8)
    one = base.replace(stages=tuple(s.__class__(**{**s.__dict__, "feed": feed}) for s in base.stages))
    a, b = simulate(tr, base), simulate(tr, one)
    assert a.cycles == b.cycles and a.fifos == b.fifos and a.processors == b.processors
    i = base.stage_of("IC")
    st = list(base.stages)
    st[i] = make_stage(("IC",), "paper", replicas=3, send_fifo=8, receive_fifo=4, feed=feed)
    for ring in (None, builtin("3mppe").ring):     # the ideal network and the ring
        res = simulate(tr, base.replace(stages=tuple(st), ring=ring), record=True)
        started = sorted(j for t, what, name, k, j in res.log if what == "start" and j >= 0)
        assert started == list(range(len(tr.visits)))
        assert all(p["busy"] + p["blocked"] <= res.cycles for p in res.processors)
        assert sum(p["visits"] for p in res.processors if p["stage"] == "IC") == res.stages["IC"]["rays_in"]
