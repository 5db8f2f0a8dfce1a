"""The hardware cost of a design, from per-part unit costs.

Costs are in kGE (thousands of two-input NAND gate equivalents), the usual
size measure of standard-cell logic, so "budget" and "time x cost" have a unit.
The defaults are order-of-magnitude figures for 32-bit single-precision
datapaths of the paper's period; the reasoning for each is beside it.  A space
file's ``[cost]`` table overrides any of them.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

from .space import Design, SpaceError, processors


@dataclass(frozen=True)
class UnitCosts:
    # Control, decoder, 128 x 32-bit register file (4096 bits at ~6 GE each
    # with ports) and the packet interface: the part every processor has.
    processor: float = 30.0
    # A 32-bit integer ALU with shifter and address adder: ~2 kGE.
    int_unit: float = 2.0
    # A single-precision FP adder plus multiplier (pipelined): ~20 kGE,
    # ten integer units, as in the FP chips of the time.
    fp_unit: float = 20.0
    # The sequential processor's one unit runs integer and FP work:
    # an integer ALU plus an FP datapath.
    general_unit: float = 22.0
    # One 32-bit word (one flit) of a two-port FIFO: 32 bits of register
    # file at ~6 GE per bit.
    fifo_word: float = 0.2
    # One KiB of cache: 8192 SRAM bits at ~1.5 GE per bit plus tags, valid
    # bits and comparators (~10%).
    cache_kib: float = 13.0
    # One KiB of resident memory: SRAM without tags.
    resident_kib: float = 12.0
    # One ring node per processor: nine flit buffers (three classes, as the
    # paper's structured buffer pool) and the routing switch.
    ring_node: float = 3.0

    @classmethod
    def fields(cls) -> list[str]:
        return [f.name for f in fields(cls)]

    @classmethod
    def from_table(cls, table: dict | None, where: str = "cost") -> "UnitCosts":
        table = table or {}
        known = cls.fields()
        for k, v in table.items():
            if k not in known:
                raise SpaceError(f"{where}.{k}: unknown unit cost (known: {', '.join(known)})")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0 or v == float("inf"):
                raise SpaceError(f"{where}.{k}: {v!r} is not a finite non-negative number")
        return cls(**{k: float(v) for k, v in table.items()})

    def to_dict(self) -> dict:
        return asdict(self)


def hardware_cost(design: Design, costs: UnitCosts | None = None) -> float:
    """Total cost of the design in kGE (all PEs)."""
    return sum(cost_breakdown(design, costs).values())


def cost_breakdown(design: Design, costs: UnitCosts | None = None) -> dict:
    """Cost by part (kGE, all PEs): processors, units, FIFOs, ring, caches, resident memory."""
    c = costs or UnitCosts()
    out = {"processors": 0.0, "units": 0.0, "fifos": 0.0, "ring": 0.0, "caches": 0.0, "resident": 0.0}
    per_kind = {"int": c.int_unit, "fp": c.fp_unit, "general": c.general_unit}
    groups = processors(design.mapping)
    for g in groups:
        k = design.processor_copies(g)
        out["processors"] += k * c.processor
        out["units"] += k * sum(per_kind[u] * n for u, n in design.processor_units(g).items())
        out["fifos"] += k * 2 * design.fifo * c.fifo_word          # one send and one receive FIFO each
        if len(groups) > 1:
            out["ring"] += k * c.ring_node
    for s in ("IC", "SC"):         # each copy of the processor running s has its own memories
        k = design.processor_copies(next(g for g in groups if s in g))
        out["caches"] += k * design.cache[s] * c.cache_kib
        out["resident"] += k * design.resident[s] * c.resident_kib
    if len(groups) == 1:          # model S: no packets, so no FIFOs
        out["fifos"] = 0.0
    return {k: v * design.pes for k, v in out.items()}


def config_breakdown(cfg, costs: UnitCosts | None = None) -> dict:
    """Cost by part (kGE, all PEs) of any machine (a ``SystemConfig``: a machine file's, a built-in
    model's), priced as ``cost_breakdown`` prices a design: each stage's copies with their units,
    their FIFOs' words (a packet is ``words_per_packet`` words; an unbounded FIFO, an ideal
    model's, is priced at nothing), a ring node each where there is a ring, and the IC and SC
    memories of each copy of the stage running them.  A design's machine costs what the design
    does but for its FIFOs: the design prices the words it asks for, its machine holds whole
    packets of ``words_per_packet`` words (at least one)."""
    from .evaluate import _words_per_packet

    c = costs or UnitCosts()
    out = {"processors": 0.0, "units": 0.0, "fifos": 0.0, "ring": 0.0, "caches": 0.0, "resident": 0.0}
    per_kind = {"int": c.int_unit, "fp": c.fp_unit, "general": c.general_unit}
    wpp = _words_per_packet()
    for st in cfg.stages:
        k = st.replicas
        out["processors"] += k * c.processor
        out["units"] += k * sum(per_kind.get(u, 0.0) * n for u, n in st.processor.units.items())
        if len(cfg.stages) > 1:
            out["fifos"] += k * sum((f or 0) * wpp for f in (st.send_fifo, st.receive_fifo)) * c.fifo_word
        if cfg.ring is not None:
            out["ring"] += k * c.ring_node
    for s, mem in (("IC", cfg.ic_memory), ("SC", cfg.sc_memory)):
        if mem is None:
            continue
        k = cfg.stages[cfg.stage_of(s)].replicas
        out["caches"] += k * (mem.cache.size / 1024 if mem.cache else 0) * c.cache_kib
        out["resident"] += k * mem.resident / 1024 * c.resident_kib
    return {k: v * cfg.pes for k, v in out.items()}


def machine_breakdown(machine, costs: UnitCosts | None = None) -> dict:
    """Cost by part of a design (``cost_breakdown``) or of any machine (``config_breakdown``)."""
    return (cost_breakdown if isinstance(machine, Design) else config_breakdown)(machine, costs)


def cheapest_design(space, costs: UnitCosts | None = None) -> tuple:
    """(cost, design): the cheapest design of a space, found without a trace.  Every unit cost
    is non-negative and every count (units, copies, FIFO words, KiB, PEs) multiplies one, so
    within a stage mapping the cost cannot fall as a numeric variable grows: the cheapest
    design of a mapping has each numeric variable at its smallest value (whatever the order of
    a ``choices`` list), and the cheapest of the space is the cheapest over the mappings."""
    pos = {v.name: i for i, v in enumerate(space.variables)}
    base = []
    for v in space.variables:
        numeric = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v.values)
        base.append(min(range(v.size), key=lambda i: v.values[i]) if numeric else 0)
    best = None
    for m in range(space.variables[pos["mapping"]].size):
        idx = list(base)
        idx[pos["mapping"]] = m
        design = space.point(space.canonical(idx)).design
        c = hardware_cost(design, costs)
        if best is None or c < best[0]:
            best = (c, design)
    return best


__all__ = ["UnitCosts", "hardware_cost", "cost_breakdown", "config_breakdown", "machine_breakdown", "cheapest_design"]
