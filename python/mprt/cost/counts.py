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
model (for ``mprt.fidelity.Evaluator`` and the machine model), which counts the
trace when first asked to price it: the compiled replay prices a counted model's
visits in C as it loads them (``fidelity.compiled.priced_for``), with no counts.

From the second pricing on, the visits are priced through their classes: a stage's
visits take few distinct rows of runs and packets (balls at 512x512, a sixteenth of
the frame: 604 of 382,181 OS visits, 89 of 331,099 IC, 10 of 68,035 SC), so each
class is priced once and every visit takes its class's cycles (a gather), not a
product and a scatter a visit (0.2-0.6 s on that trace, now milliseconds).
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
        self.priced = 0                  # pricings so far (the classes are found at the second)
        self._classes = None             # (class of each visit, {stage: (first class, runs, packets)}) or ()

    @staticmethod
    def kernels(stage: str) -> tuple:
        """The kernels counted per visit of a stage (SC's making of primary rays is per ray, not per visit)."""
        return counted_kernels(stage)

    @property
    def nbytes(self) -> int:
        return int(self.flits.nbytes + sum(a.nbytes for d in (self.rows, self.runs, self.packets)
                                           for a in d.values()) + (self._classes[0].nbytes if self._classes else 0))

    def price(self, model: CostModel, procs) -> VisitCosts:
        """``model.visit_costs(trace, procs)``, from the counts: the same arrays, to the cycle."""
        procs = _check_procs(procs)
        self.priced += 1
        if self.priced > 1 and self._classes is None:
            self._classes = self._find_classes()
        if self._classes:
            return self._price_classes(model, procs)
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


    def _inject(self, model: CostModel, sc) -> tuple:
        f = int(_FLITS[SC, OS, PRIMARY])
        return (model.kernel_cycles("sc_primary", sc),
                model.kernel_cycles("send_packet", sc) + f * model.kernel_cycles("send_flit", sc), f)

    def _find_classes(self):
        """(class of each visit, int32; {stage: (its first class, distinct runs int64, distinct
        packets int64)}): class 0 is a visit of no stage (cycles 0).  Rows are told apart by a
        mixed-radix key of their columns (a sort of int64, not of rows); () where the key
        would not fit 62 bits."""
        cls = np.zeros(self.visits, np.int32)
        table, base = {}, 1
        for name in STAGES:
            rows = self.rows[name]
            if not len(rows):
                continue
            cols = [c for a in (self.runs[name], self.packets[name]) for c in a.T]
            low = [int(c.min()) for c in cols]
            radix = [int(c.max()) + 1 for c in cols]
            if min(low) < 0 or sum(np.log2(radix)) > 62:
                return ()
            key = np.zeros(len(rows), np.int64)
            for c, r in zip(cols, radix):
                np.multiply(key, r, out=key)
                np.add(key, c, out=key)
            _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
            cls[rows] = inverse + base
            table[name] = (base, self.runs[name][first].astype(np.int64), self.packets[name][first].astype(np.int64))
            base += len(first)
        return cls, table, base

    def _price_classes(self, model: CostModel, procs) -> VisitCosts:
        """``price`` through the visits' classes: each class priced once, a gather a visit."""
        cls, table, m = self._classes
        process, receive, send = (np.zeros(m, np.int64) for _ in range(3))
        for name, (b, runs, pk) in table.items():
            p = procs[name]
            cyc = np.array([model.kernel_cycles(k, p) for k in self.kernels(name)], np.int64)
            sp, sf, rp, rf = (model.kernel_cycles(k, p) for k in _COMM)
            e = b + len(runs)
            process[b:e] = runs @ cyc + model.visit_overhead[name]
            receive[b:e] = rp + pk[:, 0] * rf
            send[b:e] = pk[:, 1] * sp + pk[:, 2] * sf
        return VisitCosts(process[cls], receive[cls], send[cls], self.flits.copy(), *self._inject(model, procs["SC"]))


class CountedCostModel(CostModel):
    """A cost model (the same constants as ``model``) that prices one trace
    from its kernel counts; any other trace it prices in full.  Given the trace
    instead of its counts, it counts them when first asked to price it (a
    caller whose replays the C pricing serves never pays for them)."""

    def __init__(self, model: CostModel, counts: KernelCounts | None = None, trace=None):
        super().__init__(model.latency, model.visit_overhead, model.scale, model.info)
        if (counts is None) == (trace is None):
            raise ValueError("CountedCostModel: give the trace's counts or the trace")
        self._counts = counts
        self.trace = trace if counts is None else counts.trace

    @property
    def counts(self) -> KernelCounts:
        if self._counts is None:
            self._counts = KernelCounts(self.trace)
        return self._counts

    def visit_costs(self, trace, procs, chunk: int = 1 << 20) -> VisitCosts:
        if trace is self.trace:
            return self.counts.price(self, procs)
        return super().visit_costs(trace, procs, chunk)
