"""Machine configurations: frozen, validated dataclasses and the built-in models
(TOML files: ``configfile.py``).

A configuration says which parts the machine has; the model builds only
those (no ring without ``ring``, no cache without ``cache``).  Model S and
model M of the paper are configurations like any other:

    S      one sequential processor running OS, IC and SC; ideal network, memory
    M      three sequential processors (OS, IC, SC); unbounded FIFOs, ideal network
    3mppe  the paper's VLIW processors on a ring with finite FIFOs, caches,
           resident memories, global memories and 2 PEs

A TOML file holds the same fields (see ``python/mprt/machine/README.md``);
every field is checked and an error names the field and the file.  Its reading
and writing (``config_from_dict``, ``load_config``, ``resolve``, ``config_toml``)
live in ``mprt.machine.configfile`` and are importable from here too.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from .errors import ConfigError

SUBTASKS = ("OS", "IC", "SC")
DIS_POLICIES = ("blocks", "interleaved", "dynamic")
# How a stage's copies get their packets: one shared receive FIFO (an idle copy takes the
# next packet), or a receive FIFO per copy fed round-robin or by the shortest queue.
FEEDS = ("shared", "round-robin", "shortest-queue")
MAX_CACHE = 1 << 40     # bytes: the largest cache a configuration may have (both engines)


@dataclass(frozen=True)
class StageConfig:
    """A stage: ``replicas`` processors of one configuration running the
    given subtasks, behind one ring node with a send and a receive FIFO
    (capacity in packets; None = unbounded).  ``feed``: "shared" (the copies
    share the receive FIFO), "round-robin" or "shortest-queue" (each copy has
    a receive FIFO of that capacity and a local queue of its own; see the
    README's event semantics)."""

    subtasks: tuple
    processor: Any
    replicas: int = 1
    send_fifo: int | None = None
    receive_fifo: int | None = None
    processor_spec: Any = "sequential"
    feed: str = "shared"

    @property
    def name(self) -> str:
        return "+".join(self.subtasks)


@dataclass(frozen=True)
class RingConfig:
    """The unidirectional ring joining the stages of a PE in their order:
    one flit per ``flit_time`` cycles per link; ``buffer_classes`` flit
    buffers per node (the paper's structured pool has one class per hop,
    3 for 3 stages; 1 is a single shared buffer per node)."""

    flit_time: int = 1
    buffer_classes: int = 3


@dataclass(frozen=True)
class CacheConfig:
    """A set-associative LRU cache: size and line in bytes, ways per set."""

    size: int
    line: int
    ways: int


@dataclass(frozen=True)
class LocalMemoryConfig:
    """A processor's local memory for IC or SC data: a resident part (bytes,
    filled with the most referenced data) and a cache of the global memory
    (None: whatever is not resident is read from global memory uncached)."""

    resident: int = 0
    cache: CacheConfig | None = None


@dataclass(frozen=True)
class GlobalMemoryConfig:
    """ICGM or SCGM: a miss costs ``latency`` cycles plus the line's transfer
    at ``bandwidth`` bytes per cycle; with ``contention`` all PEs share one
    port (transfers queue first come, first served), else each PE has its own."""

    latency: int
    bandwidth: int
    contention: bool = True


@dataclass(frozen=True)
class SystemConfig:
    """A whole machine: PEs of the given stages, network, memories, DIS."""

    name: str
    stages: tuple
    ring: RingConfig | None = None
    ic_memory: LocalMemoryConfig | None = None
    sc_memory: LocalMemoryConfig | None = None
    icgm: GlobalMemoryConfig | None = None
    scgm: GlobalMemoryConfig | None = None
    pes: int = 1
    dis: str = "dynamic"
    window: int = 256
    source: str | None = field(default=None, compare=False)
    # "auto": the window is chosen from the trace's ray trees (``auto_window``) and halved while
    # the machine deadlocks (``with_window_for``); ``window`` is then the rule's most, before a trace
    window_rule: str | None = None

    def __post_init__(self):
        _validate(self)

    # -- derived ------------------------------------------------------------
    def stage_of(self, subtask: str) -> int:
        """Index (ring position) of the stage that runs a subtask."""
        for i, s in enumerate(self.stages):
            if subtask in s.subtasks:
                return i
        raise KeyError(subtask)

    @property
    def level(self) -> int:
        """Fidelity level: 3 when caches or memories are modelled, else 2."""
        return 3 if (self.ic_memory or self.sc_memory) else 2

    @property
    def finite_fifos(self) -> bool:
        return any(s.send_fifo is not None or s.receive_fifo is not None for s in self.stages)

    @property
    def cycle_capacity(self) -> int | None:
        """The fewest live rays a PE needs for its FIFOs to deadlock (None:
        never): every stage of a cycle then has a full receive FIFO, a full
        send FIFO and a packet in each of its blocked processors, so it is at
        least the smallest sum of two stages' capacities, a stage's being what
        it holds when nothing can enter it (``stage_capacity``)."""
        caps = [stage_capacity(s) for s in self.stages]
        finite = sorted(c for c in caps if c is not None)
        if len(finite) < 2:
            return None
        return finite[0] + finite[1]

    def processors(self) -> dict:
        """The processor configuration that runs each subtask (for the cost model)."""
        return {t: self.stages[self.stage_of(t)].processor for t in SUBTASKS}

    def replace(self, **changes) -> "SystemConfig":
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """The settings as plain data (JSON), processors by their specification."""
        def part(x):
            return None if x is None else dataclasses.asdict(x)
        return {
            "name": self.name,
            "source": self.source,
            "pes": self.pes,
            "dis": self.dis,
            "window": self.window,
            "stages": [{"subtasks": list(s.subtasks), "processor": _spec_json(s.processor_spec),
                        "replicas": s.replicas, "send_fifo": s.send_fifo, "receive_fifo": s.receive_fifo,
                        **({} if s.feed == "shared" else {"feed": s.feed})}
                       for s in self.stages],
            "ring": part(self.ring),
            "ic_memory": part(self.ic_memory),
            "sc_memory": part(self.sc_memory),
            "icgm": part(self.icgm),
            "scgm": part(self.scgm),
            "level": self.level,
            **({"window_rule": self.window_rule} if self.window_rule else {}),
        }


def stage_capacity(s: StageConfig) -> int | None:
    """The fewest packets a stage holds (None: unbounded) when it is part of a
    FIFO deadlock: its send FIFO full and no room to enter it, its non-idle
    copies each blocked with a packet.  Shared: the receive FIFO full and every
    copy blocked.  Round-robin: the next copy's FIFO full and that copy
    blocked (the others may be idle).  Shortest-queue: every copy's FIFO full
    and every copy blocked."""
    if s.send_fifo is None or s.receive_fifo is None:
        return None
    if s.feed == "round-robin":
        return s.send_fifo + s.receive_fifo + 1
    if s.feed == "shortest-queue":
        return s.send_fifo + s.replicas * (s.receive_fifo + 1)
    return s.send_fifo + s.receive_fifo + s.replicas


def _spec_json(spec):
    return spec if isinstance(spec, (str, dict)) else repr(spec)


# ---- validation ---------------------------------------------------------------

def _where(cfg) -> str:
    return f"{cfg.source}: " if cfg.source else ""


# Upper bounds of every numeric field (by its last name), so that no value can make a
# replay's work or memory run away: a machine larger than these is not one of the paper's
# family, and each stays far above any design the explorer or a study considers.
LIMITS = {
    "replicas": 256,            # processors of one stage
    "pes": 1024,
    "window": 1 << 20,          # live rays per PE
    "send_fifo": 1 << 20,       # packets
    "receive_fifo": 1 << 20,
    "flit_time": 1 << 16,       # cycles per flit
    "resident": 1 << 40,        # bytes
    "line": 1 << 12,            # cache line bytes
    "ways": 1 << 10,
    "latency": 1 << 20,         # global memory cycles
    "bandwidth": 1 << 20,       # bytes per cycle
}
# (cache bytes: at most MAX_CACHE; the compiled replay sizes its caches by the data they can
# hold and refuses, before a run, caches of more than 2^28 entries over all PEs)


def _int(value, where, name, lo=1, allow_none=False):
    """An integer in lo..LIMITS[field] (bool is not an integer here)."""
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{where}{name}: must be an integer, not {value!r}")
    if value < lo:
        raise ConfigError(f"{where}{name}: must be at least {lo}, not {value}")
    hi = LIMITS.get(name.rsplit(".", 1)[-1].lstrip("-"))
    if hi is not None and value > hi:
        raise ConfigError(f"{where}{name}: must be at most {hi}, not {value}")
    return value


def _validate(cfg: SystemConfig) -> None:
    w = _where(cfg)
    if not isinstance(cfg.name, str) or not cfg.name:
        raise ConfigError(f"{w}name: must be a non-empty string")
    if not isinstance(cfg.stages, tuple) or not cfg.stages:
        raise ConfigError(f"{w}stage: at least one stage is needed")
    seen = []
    for i, s in enumerate(cfg.stages):
        where = f"stage[{i}]"
        if not isinstance(s, StageConfig):
            raise ConfigError(f"{w}{where}: not a StageConfig")
        if not isinstance(s.subtasks, tuple) or not s.subtasks:
            raise ConfigError(f"{w}{where}.subtasks: must list one or more of {', '.join(SUBTASKS)}")
        for t in s.subtasks:
            if t not in SUBTASKS:
                raise ConfigError(f"{w}{where}.subtasks: unknown subtask {t!r} (known: {', '.join(SUBTASKS)})")
            if t in seen:
                raise ConfigError(f"{w}{where}.subtasks: {t} is already run by another stage")
            seen.append(t)
        _int(s.replicas, w, f"{where}.replicas")
        _int(s.send_fifo, w, f"{where}.send_fifo", allow_none=True)
        _int(s.receive_fifo, w, f"{where}.receive_fifo", allow_none=True)
        if s.feed not in FEEDS:
            raise ConfigError(f"{w}{where}.feed: must be one of {', '.join(FEEDS)}, not {s.feed!r}")
    missing = [t for t in SUBTASKS if t not in seen]
    if missing:
        raise ConfigError(f"{w}stage: no stage runs {', '.join(missing)}")
    if cfg.ring is not None:
        if len(cfg.stages) < 2:
            raise ConfigError(f"{w}ring: a ring needs at least 2 stages (one stage has no network)")
        _int(cfg.ring.flit_time, w, "ring.flit_time")
        _int(cfg.ring.buffer_classes, w, "ring.buffer_classes")
        if cfg.ring.buffer_classes > len(cfg.stages):
            raise ConfigError(f"{w}ring.buffer_classes: at most {len(cfg.stages)} (one per hop plus the "
                              f"source's) with {len(cfg.stages)} stages, not {cfg.ring.buffer_classes}")
    for mem, gm, tag in ((cfg.ic_memory, cfg.icgm, "ic"), (cfg.sc_memory, cfg.scgm, "sc")):
        if mem is not None:
            _int(mem.resident, w, f"{tag}_memory.resident", lo=0)
            if mem.cache is not None:
                c = mem.cache
                _int(c.size, w, f"{tag}_memory.cache.size")
                _int(c.line, w, f"{tag}_memory.cache.line")
                _int(c.ways, w, f"{tag}_memory.cache.ways")
                if c.size > MAX_CACHE:
                    raise ConfigError(f"{w}{tag}_memory.cache.size: at most 2^40 bytes (1 TiB), not {c.size}")
                if c.line > c.size:
                    raise ConfigError(f"{w}{tag}_memory.cache.line: the line ({c.line} bytes) is larger than "
                                      f"the cache ({c.size} bytes)")
                if c.line & (c.line - 1):
                    raise ConfigError(f"{w}{tag}_memory.cache.line: must be a power of two, not {c.line}")
                if c.size % (c.line * c.ways):
                    raise ConfigError(f"{w}{tag}_memory.cache.size: {c.size} bytes is not a whole number of "
                                      f"sets of {c.ways} ways x {c.line}-byte lines")
            if gm is None:
                raise ConfigError(f"{w}{tag}gm: {tag}_memory is modelled, so its misses need a global memory "
                                  f"([{tag}gm] with latency and bandwidth)")
        if gm is not None:
            _int(gm.latency, w, f"{tag}gm.latency", lo=0)
            _int(gm.bandwidth, w, f"{tag}gm.bandwidth")
            if not isinstance(gm.contention, bool):
                raise ConfigError(f"{w}{tag}gm.contention: must be true or false, not {gm.contention!r}")
    _int(cfg.pes, w, "pes")
    if cfg.dis not in DIS_POLICIES:
        raise ConfigError(f"{w}dis: unknown policy {cfg.dis!r} (known: {', '.join(DIS_POLICIES)})")
    _int(cfg.window, w, "window")
    if cfg.window_rule not in WINDOW_RULES:
        raise ConfigError(f"{w}window: the only rule is \"auto\", not {cfg.window_rule!r}")


# The DIS window rule of ``window = "auto"`` (what the explorer's designs use): WINDOW_PER_COPY
# primary rays per PE for each copy of the most replicated stage, but no more than keeps the
# FIFOs from deadlocking on the trace's largest ray tree (window x leaves < cycle_capacity);
# a machine that deadlocks all the same (the bound is the ideal network's) runs again with half
# the window, down to 1.
WINDOW_RULES = (None, "auto")
WINDOW_PER_COPY = 4


def rule_window(cfg: "SystemConfig") -> int:
    """The most ``window = "auto"`` gives a machine (before a trace tells its trees)."""
    return WINDOW_PER_COPY * max(s.replicas for s in cfg.stages)


def auto_window(cfg: "SystemConfig", leaves: int | None) -> int:
    """The window of the "auto" rule for trees of up to ``leaves`` leaves (rays that make no
    rays): ``rule_window``, capped where the FIFOs are finite so that window x leaves stays
    below the machine's ``cycle_capacity``, at least 1."""
    w = rule_window(cfg)
    cap = cfg.cycle_capacity
    if len(cfg.stages) > 1 and leaves and cap is not None:
        w = min(w, max((cap - 1) // leaves, 1))
    return w


def with_window_for(cfg: "SystemConfig", leaves: int | None) -> "SystemConfig":
    """The configuration with its window rule applied for trees of up to ``leaves`` leaves (as it
    is where it has no rule)."""
    if cfg.window_rule != "auto":
        return cfg
    return dataclasses.replace(cfg, window=auto_window(cfg, leaves))


def halved_window(cfg: "SystemConfig") -> "SystemConfig | None":
    """After a deadlock: the configuration with half its window under the "auto" rule (None where
    it has no rule or its window is 1 already: the deadlock stands)."""
    if cfg.window_rule != "auto" or cfg.window <= 1:
        return None
    return dataclasses.replace(cfg, window=cfg.window // 2)


def check_config(config) -> SystemConfig:
    """The configuration an engine is handed, checked again as when it was built (both engines
    call this first): one changed after it was built (``object.__setattr__`` on the frozen
    dataclass) is refused by SimPy and the compiled replay with the same ConfigError, never
    run by one and refused, or deadlocked, by the other."""
    if not isinstance(config, SystemConfig):
        raise ConfigError(f"a machine configuration must be a SystemConfig or a model name (S, M, 3mppe), "
                          f"not {type(config).__name__}")
    _validate(config)
    return config


# ---- processors -----------------------------------------------------------------

def make_processor(spec, subtasks, where="processor"):
    """A ProcessorConfig from a specification: "sequential", "paper" (the
    paper's processor for the stage's one subtask), "paper:OS|IC|SC", or a
    table of ProcessorConfig's fields (units, latency, issue_width)."""
    from ..cost import ProcessorConfig

    if isinstance(spec, ProcessorConfig):
        return spec
    try:
        if spec == "sequential":
            return ProcessorConfig.sequential()
        if isinstance(spec, str) and spec.startswith("paper"):
            sub = spec[6:] if spec.startswith("paper:") else None
            if spec not in ("paper",) and sub is None:
                raise ConfigError(f"{where}: unknown processor {spec!r}")
            if sub is None:
                if len(subtasks) != 1:
                    raise ConfigError(f"{where}: 'paper' is ambiguous for a stage running "
                                      f"{'+'.join(subtasks)}; write 'paper:OS', 'paper:IC' or 'paper:SC'")
                sub = subtasks[0]
            if sub not in SUBTASKS:
                raise ConfigError(f"{where}: unknown paper processor {sub!r} (known: {', '.join(SUBTASKS)})")
            return ProcessorConfig.paper(sub)
        if isinstance(spec, dict):
            return ProcessorConfig.from_dict(spec, where=where)
    except ConfigError:
        raise
    except (TypeError, ValueError) as e:
        msg = str(e)
        raise ConfigError(msg if msg.startswith(where) else f"{where}: {msg}") from None
    raise ConfigError(f"{where}: must be 'sequential', 'paper', 'paper:OS|IC|SC' or a table of "
                      f"units/latency/issue_width, not {spec!r}")


def make_stage(subtasks, processor="sequential", replicas=1, send_fifo=None, receive_fifo=None,
               feed="shared") -> StageConfig:
    """A StageConfig with its processor built from a specification."""
    subtasks = tuple(subtasks)
    return StageConfig(subtasks, make_processor(processor, subtasks), replicas, send_fifo, receive_fifo, processor,
                       feed)


# ---- built-in configurations --------------------------------------------------

def model_s() -> SystemConfig:
    """The paper's model S: one sequential processor runs OS, IC and SC."""
    return SystemConfig("S", (make_stage(SUBTASKS),))


def model_m() -> SystemConfig:
    """The paper's model M: three identical sequential processors, unbounded
    FIFOs, zero network latency, every data access a hit."""
    return SystemConfig("M", tuple(make_stage((t,)) for t in SUBTASKS))


def model_3mppe() -> SystemConfig:
    """The paper's 3MPPE: VLIW OS (2 int + 2 FP) and IC (1 int + 3 FP), a
    sequential SC, on a ring (structured buffer pool, 1 cycle per flit) with
    finite FIFOs; IC and SC with resident memory and a cache in front of
    ICGM/SCGM shared by 2 PEs.  Sizes are our choices (the paper gives none);
    window and FIFOs are such that the FIFOs cannot deadlock for trees of up
    to 28 leaves (4 x 28 < 2 x (8 + 48 + 1), see README.md)."""
    return SystemConfig(
        "3mppe",
        tuple(make_stage((t,), "paper", send_fifo=8, receive_fifo=48) for t in SUBTASKS),
        ring=RingConfig(flit_time=1, buffer_classes=3),
        ic_memory=LocalMemoryConfig(resident=64 << 10, cache=CacheConfig(size=32 << 10, line=32, ways=4)),
        sc_memory=LocalMemoryConfig(resident=4 << 10, cache=CacheConfig(size=4 << 10, line=32, ways=2)),
        icgm=GlobalMemoryConfig(latency=20, bandwidth=8, contention=True),
        scgm=GlobalMemoryConfig(latency=20, bandwidth=8, contention=True),
        pes=2, dis="dynamic", window=4)


BUILTIN = {"S": model_s, "M": model_m, "3mppe": model_3mppe}


def builtin(name: str) -> SystemConfig:
    """A built-in configuration by name (S, M, 3mppe)."""
    if name not in BUILTIN:
        raise ConfigError(f"unknown model {name!r} (known: {', '.join(BUILTIN)})")
    return BUILTIN[name]()


# ---- TOML: machine files (configfile.py), its names importable from here too ------------------
# (at the end: configfile imports this module, whose names are all defined by now)
from .configfile import config_from_dict, config_toml, load_config, resolve  # noqa: E402,F401
