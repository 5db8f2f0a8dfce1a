"""Levels 1 and up: a design replayed on the SimPy machine model (``mprt.machine``).

The design becomes a machine configuration (the fields of a machine TOML file):
one stage per processor of the mapping with its units and copies; PEs fed
pixels interleaved, as level 0 does.
- level 1: ideal network, unbounded FIFOs, every data access a hit (the
  configurations issue 8's compiled replay covers; SimPy replays them until it
  exists);
- level 2: the ring and finite FIFOs (the design's words, in packets of the
  largest ray packet), a window of primary rays per PE small enough for the
  FIFOs;
- level 3: plus resident memory and caches (the design's KiB; 32-byte lines,
  4 ways) over ICGM and SCGM shared by the PEs.
A machine that deadlocks is reported with ``deadlock`` set and no cycle count
the search could prefer.
"""
from __future__ import annotations

from ..errors import MprtError
from .evaluate import Result
from .hwcost import cost_breakdown
from .space import processor_name, processors

DEADLOCK_CYCLES = 1e30
GLOBAL_MEMORY = {"latency": 20, "bandwidth": 8, "contention": True}
CACHE_LINE, CACHE_WAYS = 32, 4


class LevelUnavailable(MprtError, RuntimeError):
    """The fidelity level asked for needs a part of mprt that is not installed."""


def machine_config(design, level: int) -> dict:
    """The machine-configuration fields of a design at a fidelity level."""
    from ..cost import packet_flits

    words_per_packet = max(packet_flits(s, d, k) for s, d in ((0, 1), (1, 0), (1, 2), (2, 0), (0, 2))
                           for k in range(4) if _flow(s, d, k))
    stages = []
    for g in processors(design.mapping):
        st = {"subtasks": list(g), "processor": {"units": design.processor_units(g)},
              "replicas": design.processor_copies(g)}
        if level >= 2 and len(design.processors()) > 1:
            cap = max(design.fifo // words_per_packet, 1)
            st["send_fifo"] = st["receive_fifo"] = cap
        stages.append(st)
    cfg = {"name": "explored", "stage": stages, "pes": design.pes, "dis": "interleaved"}
    if level >= 2 and len(stages) > 1:
        cfg["ring"] = {"flit_time": 1, "buffer_classes": 3}
        cfg["window"] = 4
    if level >= 3:
        for s in ("IC", "SC"):
            mem = {"resident": design.resident[s] << 10}
            if design.cache[s]:
                mem["cache"] = {"size": design.cache[s] << 10, "line": CACHE_LINE, "ways": CACHE_WAYS}
            cfg[f"{s.lower()}_memory"] = mem
            cfg[f"{s.lower()}gm"] = dict(GLOBAL_MEMORY)
    return cfg


def _flow(src, dst, kind) -> bool:
    from ..cost import CostModelError, packet_flits
    try:
        packet_flits(src, dst, kind)
        return True
    except CostModelError:
        return False


def check_level(level: int) -> None:
    """Fail early (before any tracing) if the level cannot be evaluated here."""
    if level:
        simulate(None, None, level, None, check_only=True)


def simulate(trace, design, level, unit_costs, check_only=False):
    try:
        from ..machine import simulate as machine_simulate
        from ..machine.config import config_from_dict
        from ..machine.errors import DeadlockError
    except ImportError:
        raise LevelUnavailable(f"level {level} needs the machine model (mprt.machine), which this build lacks; "
                               "use level 0") from None
    if check_only:
        return None
    cfg = config_from_dict(machine_config(design, level), source=f"design at level {level}")
    cost = float(sum(cost_breakdown(design, unit_costs).values()))
    names = [processor_name(g) for g in processors(design.mapping)]
    try:
        r = machine_simulate(trace, cfg)
    except DeadlockError:
        return Result(cycles=DEADLOCK_CYCLES, level=level, cost=cost, bottleneck="deadlock", costs="mprt.cost")
    util = {n: float(r.nodes[n]["utilisation"]) for n in names if n in r.nodes}
    loads = {n: float(r.nodes[n].get("busy", 0)) for n in names if n in r.nodes}
    bott = max(util, key=util.get) if util else ""
    return Result(cycles=float(r.cycles), level=level, cost=cost, loads=loads, utilisation=util, bottleneck=bott,
                  costs="mprt.cost")
