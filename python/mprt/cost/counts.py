"""A trace's kernel runs per visit, kept so that any processor configuration
is priced by one product instead of a pass over the trace.

A visit's cycles are its kernel runs times the kernels' cycles on its stage's
processor, plus the stage's per-visit overhead, and its packets' sizes times
the send and receive kernels' cycles (``model.py``).  The runs and packet
sizes depend on the trace alone, so ``KernelCounts(trace)`` counts them once
(about 50 bytes a visit) and ``price(model, procs)`` gives exactly what
``model.visit_costs(trace, procs)`` gives, for any model and processors.
A design search that tries hundreds of processor configurations on one trace
prices each in milliseconds; ``CostModel.counted(trace)`` wraps this as a cost
model (for ``mprt.fidelity.Evaluator`` and the machine model).
"""
from __future__ import annotations

import numpy as np

from ..errors import TraceError
from .fast import count_chunks, usable
from .model import _FLITS, OS, PRIMARY, SC, CostModel, VisitCosts, _check_procs, counted_kernels
from .packets import STAGES

_COMM = ("send_packet", "send_flit", "receive_packet", "receive_flit")


class KernelCounts:
    """Per stage: which visits run it (``rows``), their kernel runs (int32,
    one column per kernel in ``kernels``) and packets (flits in, packets out,
    flits out); for every visit the flits it sends."""

    def __init__(self, trace, chunk: int = 1 << 20):
        self.trace = trace
        self.visits = n = len(trace.visits)
        if not usable(trace):
            raise TraceError("KernelCounts: the trace's records are not in the C layout (RAY_DTYPE, VISIT_DTYPE)")
        parts = {s: ([], [], []) for s in STAGES}       # rows, runs, packets per chunk
        self.flits = np.zeros(n, np.int32)
        for a, v, runs, packets, flits in count_chunks(trace, chunk):
            st = v["stage"]
            for s, name in enumerate(STAGES):
                m = st == s
                rows, rs, pk = parts[name]
                rows.append(a + np.flatnonzero(m))
                rs.append(runs[m, :len(self.kernels(name))])
                pk.append(packets[m])
            self.flits[a:a + len(v)] = flits
        self.rows, self.runs, self.packets = {}, {}, {}
        for name, (rows, rs, pk) in parts.items():
            self.rows[name] = np.concatenate(rows) if rows else np.zeros(0, np.int64)
            self.runs[name] = (np.concatenate(rs) if rs else np.zeros((0, len(self.kernels(name))), np.int32))
            self.packets[name] = np.concatenate(pk) if pk else np.zeros((0, 3), np.int32)
        self.primaries = int(np.sum(np.asarray(trace.rays["kind"]) == PRIMARY))

    @staticmethod
    def kernels(stage: str) -> tuple:
        """The kernels counted per visit of a stage (SC's making of primary rays is per ray, not per visit)."""
        return counted_kernels(stage)

    @property
    def nbytes(self) -> int:
        return int(self.flits.nbytes + sum(a.nbytes for d in (self.rows, self.runs, self.packets)
                                           for a in d.values()))

    def price(self, model: CostModel, procs) -> VisitCosts:
        """``model.visit_costs(trace, procs)``, from the counts: the same arrays, to the cycle."""
        procs = _check_procs(procs)
        n = self.visits
        sc = procs["SC"]
        out = VisitCosts(np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64), self.flits.copy(),
                         model.kernel_cycles("sc_primary", sc),
                         model.kernel_cycles("send_packet", sc) + int(_FLITS[SC, OS, PRIMARY])
                         * model.kernel_cycles("send_flit", sc), int(_FLITS[SC, OS, PRIMARY]))
        for name in STAGES:
            rows = self.rows[name]
            if not len(rows):
                continue
            p = procs[name]
            cyc = np.array([model.kernel_cycles(k, p) for k in self.kernels(name)], np.int64)
            sp, sf, rp, rf = (model.kernel_cycles(k, p) for k in _COMM)
            pk = self.packets[name].astype(np.int64)
            out.process[rows] = self.runs[name] @ cyc + model.visit_overhead[name]
            out.receive[rows] = rp + pk[:, 0] * rf
            out.send[rows] = pk[:, 1] * sp + pk[:, 2] * sf
        return out


class CountedCostModel(CostModel):
    """A cost model (the same constants as ``model``) that prices one trace
    from its kernel counts; any other trace it prices in full."""

    def __init__(self, model: CostModel, counts: KernelCounts):
        super().__init__(model.latency, model.visit_overhead, model.scale, model.info)
        self.counts = counts

    def visit_costs(self, trace, procs, chunk: int = 1 << 20) -> VisitCosts:
        if trace is self.counts.trace:
            return self.counts.price(self, procs)
        return super().visit_costs(trace, procs, chunk)
