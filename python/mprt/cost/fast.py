"""A trace's visits priced in C, in one pass: ``mprt_cost_visits`` (``c/src/cost.c``).

What a visit costs is linear in its stage's kernel cycles: its kernel runs
(which kernels, how many times) and its packets (which come in, which go out,
their flits) depend on the trace alone (``model.py`` says what is counted;
``reference.py`` is the same arithmetic in numpy).  So the cost model reduces
a set of processors to a table of cycles (``CostModel.cost_table``) and C
prices every visit in one pass over the records where they lie (a
memory-mapped trace is read in place, not copied), writing the arrays of
``VisitCosts``; the same pass can give each visit's kernel runs and packets
instead (``KernelCounts``, ``kernel_counts``).  The results are those of the
numpy reference to the bit (the tests compare them on the golden traces and
random processors).
"""
from __future__ import annotations

import mmap
import os

import numpy as np

from .._lowlevel import RAY_DTYPE, VISIT_DTYPE, binding
from ..errors import InvalidArgument, TraceError
from .errors import CostModelError
from .model import _FLITS, KERNEL_COLUMNS, PRIMARY, SC, STAGE_KERNELS, STAGES, VisitCosts, counted_kernels

_LIB = binding("double")


def usable(trace) -> bool:
    """Whether the C pricing reads this trace's records (the C layout; a trace made or loaded
    by mprt always has it)."""
    return getattr(trace.rays, "dtype", None) == RAY_DTYPE and getattr(trace.visits, "dtype", None) == VISIT_DTYPE


def _lights(trace) -> int:
    lights = trace.meta.get("lights")
    if not isinstance(lights, int) or isinstance(lights, bool) or lights < 0 or lights >= 1 << 63:
        raise CostModelError(f"trace meta 'lights' = {lights!r}: expected the number of lights")
    return lights


class Records:
    """What the C pricing reads of a trace: its records (in place), each ray's children by
    kind (counted once, 32 bytes a ray), the primitives' kinds and the lights."""

    def __init__(self, trace):
        self.trace = trace
        self.lights = _lights(trace)
        self.rays = np.ascontiguousarray(trace.rays)
        self.visits = trace.visits
        self.prim_kind = np.ascontiguousarray(trace.prim_kind, dtype=np.int32)
        try:
            self.children = _LIB.cost_children(self.rays, fresh(4 * len(self.rays), np.int64).reshape(-1, 4))
        except InvalidArgument as e:
            raise TraceError(f"cannot cost this trace: {e}") from None

    def run(self, table: dict, a: int, b: int, **out) -> None:
        """Price visits [a, b) with ``table`` (``CostModel.cost_table``) into the arrays
        ``out`` names (process, receive, send, flits, runs, packets: see
        ``Binding.cost_visits``), each of b - a entries; ``threads`` (default: the
        machine's cores) share large ranges, with the same results."""
        out.setdefault("threads", os.cpu_count() or 1)
        v = self.visits
        prev = (int(v[a - 1]["ray"]), int(v[a - 1]["outcome"])) if a > 0 else (-1, 0)
        try:
            _LIB.cost_visits(dict(table, lights=self.lights), self.rays, self.children, self.prim_kind,
                             np.ascontiguousarray(v[a:b]), *prev, **out)
        except InvalidArgument as e:
            raise TraceError(f"cannot cost this trace: {_shifted(str(e), a)}") from None


class Priced:
    """A trace's visit costs on some processors left for C to compute as the compiled replay loads
    the visits (``mprt_replay_load_priced``: the same arithmetic, a few thousand visits at a
    time, no per-visit arrays): the table, what it reads (``Records``), SC's injection figures,
    and the visits' flits (for the ring): made as the replay loads when ``flits`` (``load_flits``),
    else when first asked for."""

    def __init__(self, model, trace, procs, flits: bool = False):
        self.records = Records(trace)
        self.table = dict(model.cost_table(procs), lights=self.records.lights)
        self.inject_process, self.inject_send, self.inject_flits = model.injection(procs)
        self._flits = None
        self._want = flits

    def load_flits(self) -> np.ndarray | None:
        """The array the loading fills with the visits' flits (None: not asked for, or made): int64,
        as the ring's replay takes them (``replay_set_flits``: no copy to widen them)."""
        if not self._want or self._flits is not None:
            return None
        self._flits = fresh(len(self.records.visits), np.int64)
        return self._flits

    @property
    def flits(self) -> np.ndarray:
        if self._flits is None:
            n = len(self.records.visits)
            flits = fresh(n, np.int32)
            self.records.run(self.table, 0, n, flits=flits)
            self._flits = flits
        return self._flits


def _shifted(msg: str, a: int) -> str:
    """A C message naming 'visit j' of a chunk, with j made the trace's visit number."""
    if a and msg.startswith("visit "):
        head, _, rest = msg[6:].partition(":")
        if head.isdigit():
            return f"visit {int(head) + a}:{rest}"
    return msg


def fresh(n: int, dtype) -> np.ndarray:
    """An uninitialised array of n entries in an anonymous mapping of its own, in 4 KiB pages.
    (numpy asks for transparent huge pages for large arrays; on the virtual machines measured
    here their first touch cost 2 to 4 times more CPU: 0.6 s against 1.3 to 2.4 s for the
    536 MB of a 19-million-visit trace's costs.)"""
    dtype = np.dtype(dtype)
    return np.frombuffer(mmap.mmap(-1, max(n * dtype.itemsize, 1)), dtype=dtype, count=n)


def visit_costs(model, trace, procs, chunk: int = 1 << 20) -> VisitCosts:
    """``model.visit_costs(trace, procs)`` (procs checked): every visit in one C call."""
    if not usable(trace):
        from .reference import visit_costs as reference

        return reference(model, trace, procs, chunk)
    rec = Records(trace)
    n = len(trace.visits)
    out = VisitCosts(fresh(n, np.int64), fresh(n, np.int64), fresh(n, np.int64), fresh(n, np.int32),
                     *model.injection(procs))
    rec.run(model.cost_table(procs), 0, n, process=out.process, receive=out.receive, send=out.send,
            flits=out.flits)
    return out


def count_chunks(trace, chunk: int = 1 << 20):
    """(offset, visits, kernel runs int32[len, KERNEL_COLUMNS], packets int32[len, 3] (flits in,
    packets out, flits out), flits out int32[len]) for each chunk of a trace's visits, from C
    (the kernel cycles do not matter here)."""
    rec = Records(trace)
    zero = {"kernel": [[0] * KERNEL_COLUMNS] * 3, "overhead": [0] * 3, "flits": _FLITS.tolist()}
    for a in range(0, len(trace.visits), max(1, int(chunk))):
        b = min(a + max(1, int(chunk)), len(trace.visits))
        runs = np.empty((b - a, KERNEL_COLUMNS), np.int32)
        packets = np.empty((b - a, 3), np.int32)
        flits = np.empty(b - a, np.int32)
        rec.run(zero, a, b, runs=runs, packets=packets, flits=flits)
        yield a, np.asarray(trace.visits[a:b]), runs, packets, flits


def kernel_counts(trace, chunk: int = 1 << 20) -> dict:
    """``CostModel.kernel_counts``: runs of each kernel by stage, visits, SC's primary rays and
    the paper's units, counted in C (the numpy form: ``reference.kernel_counts``)."""
    if not usable(trace) or _lights(trace) >= 1 << 31:     # (runs are int32: lights must fit)
        from .reference import kernel_counts as reference

        return reference(trace, chunk)
    tot = {s: dict.fromkeys(("visits",) + STAGE_KERNELS[s], 0) for s in STAGES}
    units = {"voxels": 0, "tests": 0, "sc_input": 0}
    for _, v, runs, _, _ in count_chunks(trace, chunk):
        st = v["stage"]
        for s, name in enumerate(STAGES):
            m = st == s
            tot[name]["visits"] += int(np.count_nonzero(m))
            sums = runs[m].sum(axis=0, dtype=np.int64)
            for i, k in enumerate(counted_kernels(name)):
                tot[name][k] += int(sums[i])
        units["voxels"] += int(v["steps"].sum(dtype=np.int64))
        units["tests"] += int(v["tests"].sum(dtype=np.int64))
        units["sc_input"] += int(np.count_nonzero(st == SC))
    tot["SC"]["sc_primary"] = int(np.count_nonzero(np.asarray(trace.rays["kind"]) == PRIMARY))
    return {"stages": tot, "units": units}
