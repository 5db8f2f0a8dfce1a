"""The fidelity ladder's levels and engines: ``evaluate(trace, config, level)``.

    level 0  analytical (numpy): stage loads, critical paths (analytical.py)
    level 1  the machine with an ideal network and ideal memory (ring and
             memories taken out), replayed exactly
    level 2  with its ring network (finite FIFOs as configured)
    level 3  with its caches, resident memories and global memories: the
             configuration as written

A configuration without a ring is the same machine at levels 1 and 2, and one
without memories the same at 2 and 3; ``at_level`` gives the machine a level
models, and a level above the configuration's own (``native_level``) changes
nothing.  Engines: ``analytical`` (level 0), ``compiled`` (the C replay: every
machine, so every level from 1: the ring and the memories) and ``simpy`` (the
machine model, any level from 1).  ``auto`` takes the compiled replay wherever
it is exact (levels 1 to 3) and SimPy elsewhere.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

from ..machine.config import SystemConfig, builtin
from ..machine.errors import ConfigError
from .analytical import Analytical
from .compiled import Compiled, costs_for, priced_for, unsupported
from .memdata import MemoryData
from ..trace.tracevalid import check_trace

LEVELS = (0, 1, 2, 3)
ENGINES = ("auto", "analytical", "compiled", "simpy")


TIMELINE_VISITS = 1 << 22


def at_level(config: SystemConfig, level: int) -> SystemConfig:
    """The machine as a level models it (level 0 and 1: no ring, no memories; 2: no memories)."""
    if level not in LEVELS:
        raise ConfigError(f"level must be one of {', '.join(map(str, LEVELS))}, not {level!r}")
    changes = {}
    if level <= 2 and (config.ic_memory or config.sc_memory or config.icgm or config.scgm):
        changes.update(ic_memory=None, sc_memory=None, icgm=None, scgm=None)
    if level <= 1 and config.ring is not None:
        changes["ring"] = None
    return config.replace(**changes) if changes else config


def native_level(config: SystemConfig) -> int:
    """The lowest level that models all of the configuration (1, 2 or 3)."""
    if config.ic_memory or config.sc_memory:
        return 3
    return 2 if config.ring is not None else 1


def engine_for(config: SystemConfig, level: int, engine: str = "auto") -> str:
    """The engine that evaluates a configuration at a level; ConfigError naming the reason
    when the engine asked for cannot."""
    if engine not in ENGINES:
        raise ConfigError(f"engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    if level == 0:
        if engine not in ("auto", "analytical"):
            raise ConfigError(f"level 0 is analytical; the {engine} engine replays (levels 1 to 3)")
        return "analytical"
    if engine == "analytical":
        raise ConfigError(f"the analytical engine is level 0, not level {level}")
    why = unsupported(at_level(config, level))
    if engine == "compiled" and why:
        raise ConfigError(f"level {level}: {why}")
    if engine == "auto":
        return "simpy" if why else "compiled"
    return engine


@dataclass
class Evaluation:
    """One configuration evaluated at one level: the machine model's SimResult (cycles,
    per-stage processing, communication, waiting, ...), the engine and the seconds taken."""

    result: object
    level: int
    engine: str
    seconds: float

    @property
    def cycles(self) -> int:
        return self.result.cycles


class Evaluator:
    """Evaluates configurations on one trace, costing it once per set of processors (the
    cost model is the expensive part) and keeping each costed trace's level-0 and compiled
    forms.  ``costs``: per-visit costs to use for every configuration instead."""

    def __init__(self, trace, cost_model=None, costs=None):
        check_trace(trace)          # a trace built in memory: its ranges before any level reads it
        self.trace = trace
        self.cost_model = cost_model
        self.costs = costs
        self._costed = {}
        self._memory = MemoryData.of(trace)  # level 3's per-key data, shared by every costing

    def engine_for(self, config: SystemConfig, level: int, engine: str = "auto") -> str:
        """``engine_for``, and for ``auto`` on this trace: SimPy where the compiled replay refuses
        the caches (more than 2^28 entries over all PEs, ``memory_estimate.compiled_cache_overflow``)
        and SimPy's estimate fits the memory available (``memory_estimate.available``); else a
        ConfigError naming the limit and the figures."""
        from .. import memory_estimate as me

        eng = engine_for(config, level, engine)
        if eng != "compiled" or engine != "auto":
            return eng
        cfg = at_level(config, level)
        figures = lambda tag, mc: me.memory_figures(self._memory, tag, mc)  # noqa: E731
        why = me.compiled_cache_overflow(cfg, figures)
        if why is None:
            return eng
        est = me.Estimate()
        me.replay_parts(est, cfg, "simpy", len(self.trace.visits), len(self.trace.rays), figures)
        have, source = me.available()
        if est.total > have:
            where = f"{cfg.source}: " if cfg.source else ""
            raise ConfigError(f"{where}{why}, and the SimPy model would need {est.text()}, {me.size_text(have)} "
                              f"available ({source})")
        return "simpy"

    def _key(self, config):
        return tuple((t, repr(p)) for t, p in sorted(config.processors().items()))

    def costed(self, config: SystemConfig) -> dict:
        """The forms of the trace costed for the configuration's processors: ``costs`` (the
        per-visit arrays, made here once), and ``compiled``, ``analytical`` once made."""
        c = self._costed.setdefault(self._key(config), {})
        if "costs" not in c:
            c["costs"] = self.costs if self.costs is not None else costs_for(self.trace, config, self.cost_model)
        return c

    def prepare(self, config: SystemConfig | str, level: int | None = None, engine: str = "auto") -> tuple:
        """(configuration at the level, engine, its costed forms, level): the visits costed and the
        engine's form of the trace loaded (the compiled replay's copy of it), as ``evaluate`` needs
        them; a caller that reports each phase calls this first (``mprt simulate``)."""
        if isinstance(config, str):
            config = builtin(config)
        level = native_level(config) if level is None else level
        cfg = at_level(config, level)
        eng = self.engine_for(config, level, engine)
        c = self._costed.setdefault(self._key(cfg), {})
        if eng == "compiled" and "compiled" not in c:
            costs = c.get("costs", self.costs)
            if costs is None:       # priced by C as the visits load (no per-visit arrays), where it can
                costs = priced_for(self.trace, cfg, self.cost_model) or self.costed(cfg)["costs"]
            c["compiled"] = Compiled(self.trace, costs,      # the ring's packets as SimPy sizes them
                                     None if self.cost_model is None else self.cost_model.packet_flits,
                                     self._memory)
        elif eng != "compiled":
            c = self.costed(cfg)
            if eng == "analytical" and "analytical" not in c:
                c["analytical"] = Analytical(self.trace, c["costs"])
        return cfg, eng, c, level

    def work_bound(self, config: SystemConfig, level: int) -> int | None:
        """A lower bound of the configuration's cycles at ``level`` with nothing run
        (``Compiled.work_bound``: each stage's work over its processors), from the trace
        loaded as a run at that level would load it; None where that run is not the
        compiled replay's."""
        cfg, eng, c, _ = self.prepare(config, level)
        return c["compiled"].work_bound(cfg) if eng == "compiled" else None

    def evaluate(self, config: SystemConfig | str, level: int | None = None, engine: str = "auto",
                 record: bool = False, timeline: bool = False, progress: bool = False) -> Evaluation:
        """The configuration at a level (default: its native level) on an engine; raises
        DeadlockError when the machine deadlocks, ConfigError for an impossible choice."""
        cfg, eng, c, level = self.prepare(config, level, engine)
        t0 = time.perf_counter()
        if eng == "analytical":
            res = c["analytical"].result(cfg)
        elif eng == "compiled":
            # a timeline comes from the event log (64 bytes a visit), so only for traces of
            # up to TIMELINE_VISITS visits
            log = record or (timeline and len(self.trace.visits) <= TIMELINE_VISITS)
            res = c["compiled"].result(cfg, record=log)
            if timeline and log:
                from ..machine.result import Timeline

                res.timeline = Timeline.from_log(res.log)
                if not record:
                    res.log = None
        else:
            from ..machine.system import System

            res = System(self.trace, cfg, costs=c["costs"], cost_model=self.cost_model, record=record,
                         timeline=timeline).run(progress=progress)
        seconds = time.perf_counter() - t0
        res.level = level
        res.wall_seconds = seconds
        return Evaluation(res, level, eng, seconds)


def evaluate(trace, config: SystemConfig | str, level: int | None = None, engine: str = "auto", cost_model=None,
             costs=None, **kw) -> Evaluation:
    """``Evaluator(trace, cost_model, costs).evaluate(config, level, engine, ...)``."""
    return Evaluator(trace, cost_model, costs).evaluate(config, level, engine, **kw)
