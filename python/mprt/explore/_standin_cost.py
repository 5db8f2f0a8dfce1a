"""A stand-in for ``mprt.cost`` while the calibrated cost model is not in
the package: the same ``visit_costs`` interface, from fixed operation counts.

It is used only when ``mprt.cost`` cannot be imported, and says so
(``STANDIN = True`` in every result's ``costs`` field).  Each kernel is a
count of integer and floating-point operations and a dependence-chain
length; on a processor with ``int``/``fp``/``general`` units its cycles are
the largest of the per-kind issue bounds and the chain, so more units help
until the chain limits.  The counts are rough figures chosen so that a
sequential processor lands near the paper's per-unit averages (about 40
cycles per voxel, 25-80 per test, 100-150 per SC ray).
"""
from __future__ import annotations

import math

import numpy as np

STANDIN = True

# kernel: (integer ops, floating-point ops, dependence chain in operations)
KERNELS = {
    "os_setup": (14, 16, 12),
    "os_resume": (6, 0, 4),
    "os_step": (20, 10, 12),
    "ic_visit": (12, 0, 8),
    "ic_sphere": (3, 18, 9),
    "ic_polygon": (6, 20, 10),
    "ic_vertex": (3, 8, 4),
    "ic_cylinder": (6, 46, 20),
    "ic_cone": (6, 52, 22),
    "ic_hit": (6, 22, 12),
    "sc_shade": (20, 30, 20),
    "sc_light": (10, 24, 14),
    "sc_ray": (14, 30, 16),
    "packet_word": (1, 0, 1),
}
RAY_WORDS = {0: 10, 1: 10, 2: 10, 3: 9}      # data words of a ray packet by ray kind (header and tail added)
HIT_WORDS = 6                                # hit point and normal, IC -> SC


def kernel_cycles(kernel: str, units: dict) -> int:
    """Cycles of one kernel: the dependence chain, or the operations over the
    units that can run them (integer ops on int or general units, FP ops on
    fp or general units), whichever is larger."""
    ni, nf, chain = KERNELS[kernel]
    i, f, g = units.get("int", 0), units.get("fp", 0), units.get("general", 0)
    bounds = [chain, math.ceil((ni + nf) / (i + f + g))]
    if ni:
        bounds.append(math.ceil(ni / (i + g)))
    if nf:
        bounds.append(math.ceil(nf / (f + g)))
    return int(max(bounds))


class VisitCosts:
    def __init__(self, process, receive, send, flits):
        self.process, self.receive, self.send, self.flits = process, receive, send, flits


def visit_costs(trace, procs: dict) -> VisitCosts:
    """Cycles per visit; ``procs`` maps each stage name to a units dict."""
    from ..trace import HIT, IC, LATE_HIT, OS, RETURN, SC, TO_IC, TO_SC

    v = trace.visits
    stage = np.asarray(v["stage"])
    out = np.asarray(v["outcome"])
    steps = np.asarray(v["steps"], dtype=np.int64)
    tests = np.asarray(v["tests"], dtype=np.int64)
    verts = np.asarray(v["vertices"], dtype=np.int64)
    made = np.asarray(v["made"], dtype=np.int64)
    ray = np.asarray(v["ray"], dtype=np.int64)
    rays = trace.rays
    kind = np.asarray(rays["kind"])[ray - int(rays["id"][0])] if len(rays) else np.zeros(0, np.uint8)
    first = np.ones(len(v), dtype=bool)
    first[1:] = ray[1:] != ray[:-1]
    lights = trace.meta.get("lights", 1)
    n_lights = (len(lights) if isinstance(lights, (list, tuple)) else int(lights)) or 1
    cyc = {s: {k: kernel_cycles(k, procs[s]) for k in KERNELS} for s in ("OS", "IC", "SC")}
    process = np.zeros(len(v), dtype=np.int64)
    m = stage == OS
    c = cyc["OS"]
    process[m] = np.where(first[m], c["os_setup"], c["os_resume"]) + steps[m] * c["os_step"]
    m = stage == IC
    c = cyc["IC"]
    t = tests[m]
    process[m] = (c["ic_visit"] + t[:, 0] * c["ic_sphere"] + t[:, 1] * c["ic_polygon"] + verts[m] * c["ic_vertex"]
                  + t[:, 2] * c["ic_cylinder"] + t[:, 3] * c["ic_cone"] + (out[m] == HIT) * c["ic_hit"])
    m = stage == SC
    c = cyc["SC"]
    process[m] = c["sc_shade"] + np.where(kind[m] == 3, 0, n_lights * c["sc_light"]) + made[m] * c["sc_ray"]
    words = np.array([RAY_WORDS[k] for k in range(4)], dtype=np.int64)[kind] + 2
    flits = np.zeros(len(v), dtype=np.int64)
    sends = ((stage == OS) & np.isin(out, (TO_IC, TO_SC, LATE_HIT))) | ((stage == IC) & np.isin(out, (HIT, RETURN)))
    flits[sends] = words[sends] + ((stage == IC) & (out == HIT))[sends] * HIT_WORDS
    sc = stage == SC
    flits[sc] = made[sc] * 12
    send = np.zeros(len(v), dtype=np.int64)
    receive = np.zeros(len(v), dtype=np.int64)
    for s, code in (("OS", OS), ("IC", IC), ("SC", SC)):
        m = stage == code
        send[m] = flits[m] * cyc[s]["packet_word"]
        receive[m] = (words[m] + (code == SC) * HIT_WORDS) * cyc[s]["packet_word"]
    return VisitCosts(process, receive, send, flits.astype(np.int32))
