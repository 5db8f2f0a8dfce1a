"""Processor configurations and list scheduling of kernel graphs.

A processor has functional units of a few kinds; each kind runs some
operation classes ("general" runs all).  A kernel's cycles on a processor are
the length of a list schedule of its graph: every cycle, up to issue_width
ready operations start, highest priority first (the longest latency-weighted
path from the operation to the graph's end; ties to the earlier operation in
program order), each on a free unit that can run it (the most specialised
kind first, then in the configuration's order).  An operation's result is
ready its latency after it starts; its unit is busy for its latency, or for
one cycle when the processor is pipelined.

Greedy list scheduling can, rarely, get longer when units are added (Graham's
anomalies).  A schedule for fewer units or a narrower issue is also a
schedule for more, so the cycles reported are the shortest list schedule over
the configuration and every configuration it contains: adding units or issue
width never costs cycles.
"""
from __future__ import annotations

import types
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Mapping

from .errors import CostModelError, int_table
from .kernels import OP_CLASSES, Graph

#: the operation classes each kind of functional unit runs
UNIT_KINDS = {
    "general": OP_CLASSES,
    "int": ("int", "load", "store", "branch"),
    "fp": ("fadd", "fmul", "fdiv"),
    "mem": ("load", "store"),
    "branch": ("branch",),
    "fadd": ("fadd",),
    "fmul": ("fmul",),
    "fdiv": ("fdiv",),
}

_FIELDS = ("units", "latency", "issue_width", "pipelined", "name")
# Bounds that keep the list scheduler's work finite: it advances a cycle at a time, so an
# operation latency of 10^6 would take minutes per graph (1,000 takes under a second).
MAX_LATENCY = 1024
MAX_UNITS = 64


def _is_int(x):
    return isinstance(x, int) and not isinstance(x, bool)


@dataclass(frozen=True)
class ProcessorConfig:
    """A processor: functional units by kind, optional latency overrides per
    operation class (classes not given take the cost model's calibrated
    latencies), issue width (operations started per cycle; default: the
    number of units), pipelined units (busy one cycle per operation) or not
    (busy for the operation's latency; the default).  Validated on creation."""

    units: Mapping[str, int]
    latency: Mapping[str, int] = field(default_factory=dict)
    issue_width: int | None = None
    pipelined: bool = False
    name: str = ""

    def __post_init__(self):
        where = f"ProcessorConfig{' ' + repr(self.name) if self.name else ''}"
        if not isinstance(self.units, Mapping):
            raise CostModelError(f"{where}.units must be a mapping of unit kind to count, not {self.units!r}")
        units = {}
        for k, n in self.units.items():
            if k not in UNIT_KINDS:
                raise CostModelError(f"{where}.units[{k!r}]: unknown unit kind (known: {', '.join(UNIT_KINDS)})")
            if not _is_int(n) or n < 0 or n > MAX_UNITS:
                raise CostModelError(f"{where}.units[{k!r}] = {n!r}: must be a whole number in 0..{MAX_UNITS}")
            if n:
                units[k] = n
        if not units:
            raise CostModelError(f"{where}.units: no functional unit at all")
        for c in OP_CLASSES:
            if not any(c in UNIT_KINDS[k] for k in units):
                need = [k for k in UNIT_KINDS if c in UNIT_KINDS[k]]
                raise CostModelError(f"{where}.units: no unit runs operation class {c!r} "
                                     f"(give at least one of: {', '.join(need)})")
        lat = int_table(f"{where}.latency", self.latency, OP_CLASSES, 1, MAX_LATENCY, default=0,
                        what="operation class")
        width = self.issue_width
        if width is None:
            width = sum(units.values())
        elif not _is_int(width) or width < 1 or width > MAX_UNITS:
            raise CostModelError(f"{where}.issue_width = {width!r}: must be a whole number in 1..{MAX_UNITS}")
        if not isinstance(self.pipelined, bool):
            raise CostModelError(f"{where}.pipelined = {self.pipelined!r}: must be true or false")
        # canonical, immutable: zero counts dropped, kinds in the order given
        object.__setattr__(self, "units", types.MappingProxyType(units))
        object.__setattr__(self, "latency", types.MappingProxyType({c: v for c, v in lat.items() if v}))
        object.__setattr__(self, "issue_width", width)

    def __hash__(self):
        return hash((tuple(self.units.items()), tuple(sorted(self.latency.items())), self.issue_width,
                     self.pipelined))

    def __eq__(self, other):
        if not isinstance(other, ProcessorConfig):
            return NotImplemented
        return (tuple(self.units.items()) == tuple(other.units.items()) and dict(self.latency) == dict(other.latency)
                and self.issue_width == other.issue_width and self.pipelined == other.pipelined)

    def __repr__(self):
        lat = f", latency={dict(self.latency)}" if self.latency else ""
        pipe = ", pipelined=True" if self.pipelined else ""
        return f"ProcessorConfig(units={dict(self.units)}{lat}, issue_width={self.issue_width}{pipe})"

    # -- constructors -----------------------------------------------------------
    @classmethod
    def sequential(cls, latency: Mapping[str, int] | None = None) -> "ProcessorConfig":
        """One general unit, one operation at a time: the ordinary sequential
        processor of the paper's models S and M."""
        return cls(units={"general": 1}, latency=dict(latency or {}), issue_width=1, name="sequential")

    @classmethod
    def paper(cls, stage: str, latency: Mapping[str, int] | None = None) -> "ProcessorConfig":
        """The paper's 3MPPE processors: OS a VLIW with 2 integer + 2 FP units,
        IC a VLIW with 1 integer + 3 FP units, SC sequential (1 general unit)."""
        units = {"OS": {"int": 2, "fp": 2}, "IC": {"int": 1, "fp": 3}, "SC": {"general": 1}}
        if stage not in units:
            raise CostModelError(f"ProcessorConfig.paper: stage must be one of OS, IC, SC, not {stage!r}")
        return cls(units=units[stage], latency=dict(latency or {}), name=f"paper {stage}")

    @classmethod
    def from_dict(cls, d: Mapping, where: str = "processor") -> "ProcessorConfig":
        """From a TOML/JSON table {units = {...}, latency = {...}, issue_width, pipelined};
        errors name `where` (e.g. 'machine.toml: [OS]') and the field."""
        if not isinstance(d, Mapping):
            raise CostModelError(f"{where}: expected a table, not {d!r}")
        for k in d:
            if k not in _FIELDS:
                raise CostModelError(f"{where}: unknown field {k!r} (known: {', '.join(_FIELDS)})")
        if "units" not in d:
            raise CostModelError(f"{where}: field 'units' is missing")
        try:
            return cls(units=d["units"], latency=d.get("latency", {}), issue_width=d.get("issue_width"),
                       pipelined=d.get("pipelined", False), name=d.get("name", ""))
        except CostModelError as e:
            raise CostModelError(f"{where}: {e}") from None

    def to_dict(self) -> dict:
        d = {"units": dict(self.units), "issue_width": self.issue_width, "pipelined": self.pipelined}
        if self.latency:
            d["latency"] = dict(self.latency)
        return d


# ---- list scheduling ----------------------------------------------------------

def schedule_cycles(graph: Graph, proc: ProcessorConfig, latency: Mapping[str, int]) -> int:
    """Cycles of `graph` on `proc`, with `latency` (per class) for the classes
    the processor does not override."""
    lat = tuple(int(proc.latency.get(c, latency[c])) for c in OP_CLASSES)
    occ = tuple(1 for _ in OP_CLASSES) if proc.pipelined else lat
    # units beyond what the graph could ever use at once change nothing
    usable = {k: sum(1 for o in graph.ops if OP_CLASSES[o] in UNIT_KINDS[k]) for k in proc.units}
    units = tuple((k, min(n, usable[k])) for k, n in proc.units.items())
    width = min(proc.issue_width, sum(n for _, n in units))
    return _best(graph, units, width, lat, occ)


@lru_cache(maxsize=1 << 16)
def _best(graph, units, width, lat, occ):
    """Shortest list schedule over (units, width) and every configuration it contains."""
    best = _list_schedule(graph, units, width, lat, occ)
    if best == _lower_bound(graph, units, width, lat, occ):
        return best
    for i, (k, n) in enumerate(units):
        if n == 0:
            continue
        fewer = units[:i] + ((k, n - 1),) + units[i + 1:]
        if _covers(graph, fewer):
            best = min(best, _best(graph, fewer, min(width, sum(m for _, m in fewer)), lat, occ))
    if width > 1:
        best = min(best, _best(graph, units, width - 1, lat, occ))
    return best


def _covers(graph, units):
    kinds = [k for k, n in units if n]
    return all(any(OP_CLASSES[o] in UNIT_KINDS[k] for k in kinds) for o in set(graph.ops))


@lru_cache(maxsize=4096)
def _priorities(graph, lat):
    """Longest latency-weighted path from each operation to the graph's end."""
    n = len(graph.ops)
    prio = [0] * n
    for i in range(n - 1, -1, -1):
        prio[i] += lat[graph.ops[i]]
        for d in graph.deps[i]:
            if prio[i] > prio[d]:
                prio[d] = prio[i]
    return prio


def _lower_bound(graph, units, width, lat, occ):
    """No schedule is shorter: the critical path, the issue bound, and for each
    class the work of the classes confined to its units over their number."""
    if not graph.ops:
        return 0
    lb = max(_priorities(graph, lat))
    lb = max(lb, -(-len(graph.ops) // width))
    kinds_of = {c: frozenset(k for k, n in units if n and OP_CLASSES[c] in UNIT_KINDS[k]) for c in set(graph.ops)}
    count = dict(units)
    for c, ks in kinds_of.items():
        work = sum(occ[o] for o in graph.ops if kinds_of[o] <= ks)
        lb = max(lb, -(-work // sum(count[k] for k in ks)))
    return lb


def _list_schedule(graph, units, width, lat, occ):
    n = len(graph.ops)
    if n == 0:
        return 0
    prio = _priorities(graph, lat)
    # the units, most specialised kind first, then in the configuration's order
    pool = []
    for order, (k, m) in enumerate(units):
        pool += [(len(UNIT_KINDS[k]), order, k)] * m
    pool.sort()
    unit_classes = [set(UNIT_KINDS[k]) for _, _, k in pool]
    free_at = [0] * len(pool)
    succ = [[] for _ in range(n)]
    waiting = [len(d) for d in graph.deps]
    for i, ds in enumerate(graph.deps):
        for d in ds:
            succ[d].append(i)
    ready_at = [0] * n                       # when the operands are all there
    ready = [i for i in range(n) if waiting[i] == 0]
    finish = 0
    t = 0
    done = 0
    while done < n:
        ready.sort(key=lambda i: (-prio[i], i))
        issued = 0
        left = []
        for i in ready:
            if issued == width or ready_at[i] > t:
                left.append(i)
                continue
            cls = OP_CLASSES[graph.ops[i]]
            for u, ok in enumerate(unit_classes):
                if free_at[u] <= t and cls in ok:
                    break
            else:
                left.append(i)
                continue
            o = graph.ops[i]
            free_at[u] = t + occ[o]
            end = t + lat[o]
            finish = max(finish, end)
            issued += 1
            done += 1
            for s in succ[i]:
                ready_at[s] = max(ready_at[s], end)
                waiting[s] -= 1
                if waiting[s] == 0:
                    left.append(s)
        ready = left
        if done == n:
            break
        # next cycle at which something can start
        nxt = [ready_at[i] for i in ready if ready_at[i] > t] + [f for f in free_at if f > t]
        blocked_now = any(ready_at[i] <= t for i in ready)
        t = t + 1 if blocked_now or not nxt else min(nxt)
    return finish
