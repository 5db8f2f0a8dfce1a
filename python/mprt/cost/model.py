"""CostModel: a trace's visits in cycles on given processors.

The model holds the technology constants (a latency per operation class and
a per-visit overhead per stage), calibrated against the paper's averages
(``calibrate.py``); a ProcessorConfig holds the organisation (units, issue
width).  Every visit's work is a count of kernel runs (which kernels and how
many times, from the trace alone); its cycles are those counts times the
kernels' list-scheduled cycles on the stage's processor.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from functools import lru_cache
from typing import Mapping

import numpy as np

from .errors import CostModelError, int_table
from .kernels import HIT_KERNELS, KERNEL_STAGE, KERNELS, OP_CLASSES, TEST_KERNELS
from .packets import STAGES, packet_flits
from .schedule import ProcessorConfig, schedule_cycles
from ..atomic import open_replacing

DEFAULT_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "default_model.json")

# trace codes (format 2)
OS, IC, SC = 0, 1, 2
PRIMARY, REFLECT, REFRACT, SHADOW = 0, 1, 2, 3
TO_IC, LEFT, TO_SC, HIT, BLOCKED, RETURN, SHADED, LIT, LATE_HIT = range(9)

#: provisional constants (before calibration): a simple 1990s sequential processor
NOMINAL_LATENCY = {"int": 1, "fadd": 2, "fmul": 3, "fdiv": 12, "load": 2, "store": 1, "branch": 2}

#: kernels whose runs a visit of each stage counts ("visits": the stage's per-visit overhead)
STAGE_KERNELS = {
    "OS": ("os_setup", "os_step", "os_visit") + HIT_KERNELS,
    "IC": ("ic_visit",) + TEST_KERNELS + ("ic_vertex",) + HIT_KERNELS,
    "SC": ("sc_shade", "sc_light", "sc_keep", "sc_shadow", "sc_reflect", "sc_refract", "sc_lit", "sc_primary"),
}

# flits of every (src, dst, kind) packet; 0 where the flow does not exist
_FLITS = np.zeros((3, 3, 4), dtype=np.int64)
for _s in range(3):
    for _d in range(3):
        for _k in range(4):
            try:
                _FLITS[_s, _d, _k] = packet_flits(_s, _d, _k)
            except CostModelError:
                pass


@dataclass
class VisitCosts:
    """Cycles of every visit of a trace on the given processors (int64 arrays
    over trace.visits; flits int32), and what SC spends generating and sending
    one primary ray (the paper's SC makes the primary rays)."""

    process: np.ndarray
    receive: np.ndarray
    send: np.ndarray
    flits: np.ndarray
    inject_process: int
    inject_send: int
    inject_flits: int


def _check_procs(procs):
    if not isinstance(procs, Mapping):
        raise CostModelError(f"procs must map 'OS', 'IC', 'SC' to a ProcessorConfig, not {type(procs).__name__}")
    for s in procs:
        if s not in STAGES:
            raise CostModelError(f"procs[{s!r}]: unknown stage (OS, IC, SC)")
    for s in STAGES:
        if s not in procs:
            raise CostModelError(f"procs: no processor for stage {s!r}")
        if not isinstance(procs[s], ProcessorConfig):
            raise CostModelError(f"procs[{s!r}] must be a ProcessorConfig, not {type(procs[s]).__name__}")
    return procs


class CostModel:
    """Technology constants + kernel graphs -> cycles.

    latency: cycles per operation class (every class of kernels.OP_CLASSES);
    visit_overhead: cycles added to every visit of a stage ({'OS','IC','SC'});
    scale: per stage, the percentage applied to the list-scheduled cycles of
    the stage's kernels (not to packet send/receive): how much work the
    paper's program does per operation of our kernel graphs (100: the same);
    info: free-form record of where the constants came from."""

    def __init__(self, latency: Mapping[str, int], visit_overhead: Mapping[str, int] | None = None,
                 scale: Mapping[str, int] | None = None, info: dict | None = None, where: str = "CostModel"):
        self.latency = int_table(f"{where}.latency", latency, OP_CLASSES, 1, what="operation class")
        self.visit_overhead = int_table(f"{where}.visit_overhead", visit_overhead, STAGES, 0, default=0,
                                        what="stage")
        self.scale = int_table(f"{where}.scale", scale, STAGES, 1, 1000, default=100, what="stage")
        self.info = dict(info or {})

    def __repr__(self):
        return f"CostModel(latency={self.latency}, visit_overhead={self.visit_overhead}, scale={self.scale})"

    # -- construction -------------------------------------------------------------
    @classmethod
    def nominal(cls) -> "CostModel":
        """Uncalibrated constants: a plain sequential processor of the time."""
        return cls(NOMINAL_LATENCY, info={"source": "nominal (not calibrated)"})

    @classmethod
    def default(cls) -> "CostModel":
        """The calibrated model shipped with the package (default_model.json)."""
        return _load_default()

    @classmethod
    def load(cls, path) -> "CostModel":
        """A model written by save() (JSON, or TOML with the same tables)."""
        path = os.fspath(path)
        try:
            if path.endswith(".toml"):
                import tomllib
                with open(path, "rb") as f:
                    d = tomllib.load(f)
            else:
                with open(path) as f:
                    d = json.load(f)
        except (OSError, ValueError) as e:
            raise CostModelError(f"{path}: cannot read the cost model ({e})") from None
        except RecursionError:
            raise CostModelError(f"{path}: cannot read the cost model (nested too deeply)") from None
        if not isinstance(d, dict):
            raise CostModelError(f"{path}: expected a table at the top level")
        for k in d:
            if k not in ("latency", "visit_overhead", "scale", "info"):
                raise CostModelError(f"{path}: unknown field {k!r} (known: latency, visit_overhead, scale, info)")
        if "latency" not in d:
            raise CostModelError(f"{path}: field 'latency' is missing")
        return cls(d["latency"], d.get("visit_overhead"), d.get("scale"), d.get("info"), where=path)

    def save(self, path) -> None:
        with open_replacing(path) as f:
            json.dump({"latency": self.latency, "visit_overhead": self.visit_overhead, "scale": self.scale,
                       "info": self.info}, f,
                      indent=1, sort_keys=False)
            f.write("\n")

    @classmethod
    def calibrate(cls, sources=None, scenes=None, **kw):
        """Fit the constants to the paper's per-unit averages; returns
        (model, residuals).  sources: None (the shipped counts), a counts CSV,
        traces, scene names (traced at res x res, default 256) or count rows;
        scenes: fit on these only (residuals are reported for all).  See
        mprt.cost.calibrate."""
        from .calibrate import calibrate

        return calibrate(sources, scenes, **kw)

    # -- kernels ------------------------------------------------------------------
    def kernel_cycles(self, name: str, proc: ProcessorConfig) -> int:
        """Cycles of one run of kernel `name` on processor `proc` (list
        scheduled; the processor's latency overrides win over the model's)."""
        if name not in KERNELS:
            raise CostModelError(f"unknown kernel {name!r} (known: {', '.join(KERNELS)})")
        if not isinstance(proc, ProcessorConfig):
            raise CostModelError(f"kernel_cycles: proc must be a ProcessorConfig, not {type(proc).__name__}")
        c = _cycles(name, proc, tuple(self.latency.items()))
        stage = KERNEL_STAGE[name]
        return c if stage == "any" else scaled(c, self.scale[stage])

    def kernel_table(self, procs: Mapping[str, ProcessorConfig]) -> dict:
        """{kernel: cycles} with each kernel on its stage's processor
        (communication kernels on every stage: {kernel@stage: cycles})."""
        procs = _check_procs(procs)
        out = {}
        for name, st in KERNEL_STAGE.items():
            if st == "any":
                for s in STAGES:
                    out[f"{name}@{s}"] = self.kernel_cycles(name, procs[s])
            else:
                out[name] = self.kernel_cycles(name, procs[st])
        return out

    @staticmethod
    def packet_flits(src_stage, dst_stage, ray_kind) -> int:
        """Header + data + tail flits of one packet (see packets.py for the fields)."""
        return packet_flits(src_stage, dst_stage, ray_kind)

    # -- visits -------------------------------------------------------------------
    def visit_costs(self, trace, procs: Mapping[str, ProcessorConfig], chunk: int = 1 << 20) -> VisitCosts:
        """Cycles of every visit of `trace` with procs['OS'|'IC'|'SC'] running
        each stage's work (see the module and README for what is counted)."""
        procs = _check_procs(procs)
        cyc = {s: {k: self.kernel_cycles(k, procs[s]) for k in STAGE_KERNELS[s]} for s in STAGES}
        comm = {s: [self.kernel_cycles(k, procs[s]) for k in ("send_packet", "send_flit", "receive_packet",
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
                tot = np.full(int(m.sum()), self.visit_overhead[sname], np.int64)
                for k, c in counts[sname].items():
                    tot += c * cyc[sname][k]
                out.process[a:a + len(v)][m] = tot
                sp, sf, rp, rf = comm[sname]
                out.receive[a:a + len(v)][m] = rp + packets["in"][m] * rf
                out.send[a:a + len(v)][m] = packets["out_packets"][m] * sp + packets["out"][m] * sf
            out.flits[a:a + len(v)] = packets["out"]
        return out

    def counted(self, trace) -> "CostModel":
        """This model, pricing ``trace`` from its kernel runs counted once
        (``KernelCounts``): ``visit_costs`` on it is then a product per
        stage, the same arrays to the cycle; other traces are priced in full."""
        from .counts import CountedCostModel, KernelCounts

        return CountedCostModel(self, KernelCounts(trace))

    def kernel_counts(self, trace, chunk: int = 1 << 20) -> dict:
        """Runs of each kernel over the whole trace, by stage, with each
        stage's visits ('visits') and SC's primary-ray generations
        ('sc_primary'), and the paper's units: voxels traversed, tests and
        SC input rays.  (Independent of the constants.)"""
        return trace_kernel_counts(trace, chunk)


def trace_kernel_counts(trace, chunk: int = 1 << 20) -> dict:
    """See CostModel.kernel_counts."""
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


def scaled(cycles: int, percent: int) -> int:
    """cycles x percent / 100, rounded half up, at least 1 for a non-empty kernel."""
    return max((cycles * percent + 50) // 100, 1 if cycles else 0)


@lru_cache(maxsize=1 << 14)
def _cycles(name, proc, latency_items):
    return schedule_cycles(KERNELS[name], proc, dict(latency_items))


@lru_cache(maxsize=1)
def _load_default():
    if not os.path.exists(DEFAULT_FILE):
        raise CostModelError(f"{DEFAULT_FILE} is missing: regenerate it with 'python -m mprt.cost.calibrate --write'")
    return CostModel.load(DEFAULT_FILE)
