"""The cost model's per-visit arithmetic in numpy: the reference.

``CostModel.visit_costs`` prices visits in C (``fast.py``, ``c/src/cost.c``);
this is the same arithmetic written over numpy arrays a chunk of visits at a
time, kept as the readable statement of what a visit counts and as the
reference the C pricing is tested against, to the cycle
(``CostModel.reference_visit_costs``, ``kernel_counts`` here).
"""
from __future__ import annotations

import numpy as np

from .errors import CostModelError
from .kernels import HIT_KERNELS, TEST_KERNELS
from .model import (_FLITS, HIT, IC, LATE_HIT, LIT, OS, PRIMARY, REFLECT, REFRACT, RETURN, SC, SHADED, SHADOW,
                    STAGE_KERNELS, STAGES, TO_IC, TO_SC, VisitCosts)


def visit_costs(model, trace, procs, chunk: int = 1 << 20) -> VisitCosts:
    """``model.visit_costs(trace, procs)`` in numpy, a chunk of visits at a time (procs checked)."""
    cyc = {s: {k: model.kernel_cycles(k, procs[s]) for k in STAGE_KERNELS[s]} for s in STAGES}
    comm = {s: [model.kernel_cycles(k, procs[s]) for k in ("send_packet", "send_flit", "receive_packet",
                                                          "receive_flit")] for s in STAGES}
    n = len(trace.visits)
    out = VisitCosts(np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int32),
                     cyc["SC"]["sc_primary"],
                     comm["SC"][0] + int(_FLITS[SC, OS, PRIMARY]) * comm["SC"][1], int(_FLITS[SC, OS, PRIMARY]))
    for a, v, counts, packets in visit_chunks(trace, chunk):
        st = v["stage"]
        for s, sname in enumerate(STAGES):
            m = st == s
            if not m.any():
                continue
            tot = np.full(int(m.sum()), model.visit_overhead[sname], np.int64)
            for k, c in counts[sname].items():
                tot += c * cyc[sname][k]
            out.process[a:a + len(v)][m] = tot
            sp, sf, rp, rf = comm[sname]
            out.receive[a:a + len(v)][m] = rp + packets["in"][m] * rf
            out.send[a:a + len(v)][m] = packets["out_packets"][m] * sp + packets["out"][m] * sf
        out.flits[a:a + len(v)] = packets["out"]
    return out


def kernel_counts(trace, chunk: int = 1 << 20) -> dict:
    """``CostModel.kernel_counts`` in numpy."""
    tot = {s: dict.fromkeys(("visits",) + STAGE_KERNELS[s], 0) for s in STAGES}
    units = {"voxels": 0, "tests": 0, "sc_input": 0}
    for _, v, counts, _ in visit_chunks(trace, chunk):
        st = v["stage"]
        for s, sname in enumerate(STAGES):
            tot[sname]["visits"] += int(np.sum(st == s))
            for k, c in counts[sname].items():
                tot[sname][k] += int(c.sum())
        units["voxels"] += int(v["steps"].sum(dtype=np.int64))
        units["tests"] += int(v["tests"].sum(dtype=np.int64))
        units["sc_input"] += int(np.sum(st == SC))
    tot["SC"]["sc_primary"] = int(np.sum(np.asarray(trace.rays["kind"]) == PRIMARY))
    return {"stages": tot, "units": units}


def visit_chunks(trace, chunk: int = 1 << 20):
    """(offset, visits, kernel runs, packets) of each chunk of a trace's visits
    (``_TraceContext.visit_counts``)."""
    ctx = _TraceContext(trace)
    visits = trace.visits
    for a in range(0, len(visits), chunk):
        v = np.asarray(visits[a:a + chunk])
        counts, packets = ctx.visit_counts(v, a)
        yield a, v, counts, packets


class _TraceContext:
    """Per-ray facts a visit's counts need: ray kinds, children by kind,
    primitive kinds, the light count."""

    def __init__(self, trace):
        rays = trace.rays
        self.ray_kind = np.asarray(rays["kind"]).astype(np.int64)
        parent = np.asarray(rays["parent"])
        nr = len(rays)
        kids = parent >= 0
        self.children = np.zeros((4, nr), np.int64)
        for k in range(4):
            m = kids & (self.ray_kind == k)
            self.children[k] = np.bincount(parent[m], minlength=nr)
        # flits of each ray's children's packets SC -> OS
        self.child_flits = (self.children * _FLITS[SC, OS][:, None]).sum(axis=0)
        self.prim_kind = np.asarray(trace.prim_kind).astype(np.int64)
        lights = trace.meta.get("lights")
        if not isinstance(lights, int) or isinstance(lights, bool) or lights < 0:
            raise CostModelError(f"trace meta 'lights' = {lights!r}: expected the number of lights")
        self.lights = lights
        self.visits = trace.visits

    def visit_counts(self, v, offset):
        """Kernel runs per visit of a chunk (dict stage -> kernel -> int64
        array over the stage's visits in the chunk) and packet sizes of all
        visits (flits in, flits out, packets out)."""
        rid = v["ray"].astype(np.int64)
        st, out = v["stage"], v["outcome"]
        kind = self.ray_kind[rid]
        # a ray's first visit (visits are grouped by ray): first OS set-up, packet from SC
        prev = np.empty_like(rid)
        prev[1:] = rid[:-1]
        prev[0] = int(self.visits[offset - 1]["ray"]) if offset else -1
        first = rid != prev
        prim = v["prim"].astype(np.int64)
        pk = np.where(prim >= 0, self.prim_kind[np.maximum(prim, 0)], -1)
        counts = {}
        m = st == OS
        counts["OS"] = {"os_setup": first[m].astype(np.int64), "os_step": v["steps"][m].astype(np.int64),
                        "os_visit": np.ones(int(m.sum()), np.int64)}
        for k, name in enumerate(HIT_KERNELS):
            counts["OS"][name] = ((out[m] == LATE_HIT) & (pk[m] == k)).astype(np.int64)
        m = st == IC
        counts["IC"] = {"ic_visit": np.ones(int(m.sum()), np.int64), "ic_vertex": v["vertices"][m].astype(np.int64)}
        tests = v["tests"][m].astype(np.int64)
        for k, name in enumerate(TEST_KERNELS):
            counts["IC"][name] = tests[:, k]
        for k, name in enumerate(HIT_KERNELS):
            counts["IC"][name] = ((out[m] == HIT) & (pk[m] == k)).astype(np.int64)
        m = st == SC
        shaded = (out[m] == SHADED).astype(np.int64)
        r = rid[m]
        counts["SC"] = {
            "sc_shade": shaded,
            "sc_light": shaded * self.lights,
            "sc_keep": shaded * (v["made"][m].astype(np.int64) + v["suppressed"][m]),
            "sc_shadow": self.children[SHADOW][r] * shaded,
            "sc_reflect": self.children[REFLECT][r] * shaded,
            "sc_refract": self.children[REFRACT][r] * shaded,
            "sc_lit": (out[m] == LIT).astype(np.int64),
        }
        # packets: the one that brought the ray to this visit, the ones it sends
        src = np.where(first, SC, np.where(st == OS, IC, np.where(st == IC, OS, 0)))
        src = np.where((st == SC) & (out == LIT), OS, src)
        # an SC visit for a shaded ray follows IC's hit or OS's late hit
        if (st == SC).any():
            prev_out = np.empty_like(out)
            prev_out[1:] = out[:-1]
            prev_out[0] = self.visits[offset - 1]["outcome"] if offset else 0
            src = np.where((st == SC) & (out == SHADED), np.where(prev_out == LATE_HIT, OS, IC), src)
        flits_in = _FLITS[src, st, kind]
        dst = np.full(len(v), -1, np.int64)
        dst[(st == OS) & (out == TO_IC)] = IC
        dst[(st == OS) & ((out == TO_SC) | (out == LATE_HIT))] = SC
        dst[(st == IC) & (out == HIT)] = SC
        dst[(st == IC) & (out == RETURN)] = OS
        single = dst >= 0
        flits_out = np.where(single, _FLITS[st, np.maximum(dst, 0), kind], 0)
        sc_shaded = (st == SC) & (out == SHADED)
        flits_out = np.where(sc_shaded, self.child_flits[rid], flits_out)
        n_out = np.where(single, 1, np.where(sc_shaded, v["made"].astype(np.int64), 0))
        return counts, {"in": flits_in, "out": flits_out, "out_packets": n_out}
