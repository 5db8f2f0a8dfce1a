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
from ..util.atomic import open_replacing

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

#: the communication kernels, in mprt_cost_table's order
COMM_KERNELS = ("send_packet", "send_flit", "receive_packet", "receive_flit")
#: columns of a visit's kernel runs in mprt_cost_visits (MPRT_COST_KERNELS)
KERNEL_COLUMNS = 10

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
        each stage's work (see the module and README for what is counted),
        priced in C in one pass (``fast.py``); ``reference_visit_costs`` is the
        same arithmetic in numpy.  (``chunk``: visits per call, for the numpy
        form and for a trace whose records are not in the C layout.)"""
        from .fast import visit_costs

        return visit_costs(self, trace, _check_procs(procs), chunk)

    def reference_visit_costs(self, trace, procs: Mapping[str, ProcessorConfig], chunk: int = 1 << 20) -> VisitCosts:
        """``visit_costs`` computed with numpy, chunk by chunk (``reference.py``): the
        reference the C pricing is tested against."""
        from .reference import visit_costs

        return visit_costs(self, trace, _check_procs(procs), chunk)

    def cost_table(self, procs: Mapping[str, ProcessorConfig]) -> dict:
        """``mprt_cost_table``'s fields (but the trace's lights) for these processors: each
        stage's counted kernels' cycles (``counted_kernels``), per-visit overhead,
        packet send and receive costs, and every packet's flits."""
        procs = _check_procs(procs)
        kernel, comm = [], {k: [] for k in COMM_KERNELS}
        for s in STAGES:
            row = [self.kernel_cycles(k, procs[s]) for k in counted_kernels(s)]
            kernel.append(row + [0] * (KERNEL_COLUMNS - len(row)))
            for k in COMM_KERNELS:
                comm[k].append(self.kernel_cycles(k, procs[s]))
        return {"kernel": kernel, "overhead": [self.visit_overhead[s] for s in STAGES], **comm,
                "flits": _FLITS.tolist()}

    def injection(self, procs: Mapping[str, ProcessorConfig]) -> tuple:
        """(inject_process, inject_send, inject_flits): what SC spends making and sending one
        primary ray."""
        sc = _check_procs(procs)["SC"]
        f = int(_FLITS[SC, OS, PRIMARY])
        return (self.kernel_cycles("sc_primary", sc),
                self.kernel_cycles("send_packet", sc) + f * self.kernel_cycles("send_flit", sc), f)

    def counted(self, trace) -> "CostModel":
        """This model, pricing ``trace`` from its kernel runs counted once
        (``KernelCounts``): ``visit_costs`` on it is then a product per
        stage, the same arrays to the cycle; other traces are priced in full."""
        from .counts import CountedCostModel

        return CountedCostModel(self, trace=trace)      # (counted when first asked to price it)

    def kernel_counts(self, trace, chunk: int = 1 << 20) -> dict:
        """Runs of each kernel over the whole trace, by stage, with each
        stage's visits ('visits') and SC's primary-ray generations
        ('sc_primary'), and the paper's units: voxels traversed, tests and
        SC input rays.  (Independent of the constants.)"""
        return trace_kernel_counts(trace, chunk)


def trace_kernel_counts(trace, chunk: int = 1 << 20) -> dict:
    """See CostModel.kernel_counts (counted in C, ``fast.py``)."""
    from .fast import kernel_counts

    return kernel_counts(trace, chunk)


def counted_kernels(stage: str) -> tuple:
    """The kernels counted per visit of a stage, in the columns of ``mprt_cost_visits``'s
    runs (SC's making of primary rays is per ray, not per visit)."""
    return tuple(k for k in STAGE_KERNELS[stage] if k != "sc_primary")


def scaled(cycles: int, percent: int) -> int:
    """cycles x percent / 100, rounded half up, at least 1 for a non-empty kernel."""
    return max((cycles * percent + 50) // 100, 1 if cycles else 0)


@lru_cache(maxsize=1 << 14)
def _cycles(name, proc, latency_items):
    return schedule_cycles(KERNELS[name], proc, dict(latency_items))


@lru_cache(maxsize=1)
def _load_default():
    if not os.path.exists(DEFAULT_FILE):
        raise CostModelError(f"{DEFAULT_FILE} is missing: regenerate it with 'python -m mprt.cli.calibrate --write'")
    return CostModel.load(DEFAULT_FILE)
