"""Measuring the ladder: each level's error against the next, and the cheapest
adequate level.

    table = measure(trace_or_scene, configs, levels=(0, 1, 2, 3), sample="stratified:16:1")
    print(table.text())
    table.choose(0.01)          # the cheapest level within 1% of the most faithful one measured

Every configuration is evaluated at every level on the same (sampled) trace:
sampling changes what is replayed, not the comparison between levels, so the
errors are those of the levels themselves.  A level's error for a
configuration is |cycles - the next level's| / the next level's, and against
the top (the highest level measured); seconds per design is the evaluation's
wall time (costing excluded: it is shared by all levels with the same
processors).  A machine that deadlocks at a level has an infinite error there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..machine.config import SystemConfig, builtin
from ..machine.errors import DeadlockError
from .levels import LEVELS, Evaluator
from .sampled import Sampling, sample_trace, trace_sample


@dataclass
class Row:
    """One level over the configurations tried."""

    level: int
    seconds: float                 # median seconds per design
    error_median: float            # against the next level measured
    error_worst: float
    error_top_median: float        # against the top level measured
    error_top_worst: float
    engines: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"level": self.level, "seconds_per_design": self.seconds, "error_median": self.error_median,
                "error_worst": self.error_worst, "error_top_median": self.error_top_median,
                "error_top_worst": self.error_top_worst, "engines": self.engines}


@dataclass
class Table:
    """What ``measure`` found: a row per level, the cycles behind it, the sample used."""

    rows: list
    cycles: dict                   # (config name, level) -> cycles (None: deadlock)
    sampled: float                 # fraction of the frame's samples evaluated
    sample: str | None

    def choose(self, tolerance: float) -> int:
        """The cheapest level whose worst error against the top level is within tolerance
        (a fraction: 0.01 is 1%); the top level when none is."""
        ok = [r for r in self.rows if r.error_top_worst <= tolerance]
        if not ok:
            return self.rows[-1].level
        return min(ok, key=lambda r: (r.seconds, r.level)).level

    def to_dict(self) -> dict:
        return {"rows": [r.to_dict() for r in self.rows], "sampled": self.sampled, "sample": self.sample,
                "cycles": [{"config": c, "level": lv, "cycles": v} for (c, lv), v in self.cycles.items()]}

    def text(self) -> str:
        lines = [f"{'level':>5s} {'s/design':>10s} {'err med':>8s} {'err max':>8s} {'top med':>8s} "
                 f"{'top max':>8s}  engine"]
        for r in self.rows:
            lines.append(f"{r.level:5d} {r.seconds:10.4f} {_pct(r.error_median):>8s} {_pct(r.error_worst):>8s} "
                         f"{_pct(r.error_top_median):>8s} {_pct(r.error_top_worst):>8s}  {','.join(r.engines)}")
        return "\n".join(lines)


def _pct(x: float) -> str:
    return "inf" if math.isinf(x) else f"{100 * x:.2f}%"


def _err(a, b) -> float:
    if a is None or b is None:
        return 0.0 if a is None and b is None else math.inf
    return abs(a - b) / b if b else (0.0 if a == b else math.inf)


def measure(source, configs, levels=LEVELS, sample: str | None = "stratified:16:1", tile: int | None = None,
            width: int = 0, height: int = 0, grid=None, cost_model=None, **trace_options) -> Table:
    """Each level's error and speed over ``configs`` (SystemConfigs or built-in names) on
    ``source``: a Trace of a whole frame (sampled here), or a Scene or scene name (traced
    here, only the sampled tiles, or the whole frame for runs, at ``width`` x ``height`` with
    ``grid`` subdivisions).
    ``sample`` None evaluates everything."""
    from ..scene import Scene
    from ..trace import Trace

    levels = sorted(set(levels))
    if not levels or any(lv not in LEVELS for lv in levels):
        raise ValueError(f"levels must be some of {LEVELS}, not {levels!r}")
    configs = [builtin(c) if isinstance(c, str) else c for c in configs]
    if not configs or not all(isinstance(c, SystemConfig) for c in configs):
        raise ValueError("configs: give one or more SystemConfigs or built-in model names")
    if isinstance(source, Trace):
        if sample is None:
            trace, fraction = source, 1.0
        else:
            st = sample_trace(source, sample, tile)
            trace, fraction = st.trace, st.fraction
    else:
        scene = Scene.spd(source) if isinstance(source, str) and "." not in source else \
            (Scene.load(source) if isinstance(source, str) else source)
        g = scene.grid(grid)
        if sample is None:
            _, trace = g.trace(width, height, tile=tile, **trace_options)
            fraction = 1.0
        elif Sampling.parse(sample).method == "runs":      # runs sample the whole frame's trace
            st = sample_trace(g.trace(width, height, tile=tile, **trace_options)[1], sample)
            trace, fraction = st.trace, st.fraction
        else:
            st = trace_sample(g, Sampling.parse(sample), width, height, tile or 16, **trace_options)
            trace, fraction = st.trace, st.fraction
    ev = Evaluator(trace, cost_model)
    cycles, seconds, engines = {}, {lv: [] for lv in levels}, {lv: set() for lv in levels}
    names = []
    for i, cfg in enumerate(configs):
        name = cfg.name if cfg.name not in names else f"{cfg.name}#{i}"
        names.append(name)
        for lv in levels:
            try:
                e = ev.evaluate(cfg, lv)
                cycles[name, lv] = e.cycles
                seconds[lv].append(e.seconds)
                engines[lv].add(e.engine)
            except DeadlockError:
                cycles[name, lv] = None
    return tabulate(names, levels, cycles, seconds, engines, fraction, sample)


def tabulate(names, levels, cycles: dict, seconds: dict, engines: dict, sampled: float = 1.0,
             sample: str | None = None) -> Table:
    """The Table of configurations ``names`` evaluated at ``levels`` (sorted): ``cycles`` by
    (name, level), None for a deadlock; ``seconds`` and ``engines`` by level, lists and sets
    over the configurations (for measurements made elsewhere, e.g. in parallel)."""
    top = levels[-1]
    rows = []
    for k, lv in enumerate(levels):
        nxt = levels[k + 1] if k + 1 < len(levels) else lv
        en = [_err(cycles[n, lv], cycles[n, nxt]) for n in names]
        et = [_err(cycles[n, lv], cycles[n, top]) for n in names]
        rows.append(Row(lv, float(np.median(seconds[lv])) if seconds[lv] else math.inf, float(np.median(en)),
                        float(max(en)), float(np.median(et)), float(max(et)), sorted(engines[lv])))
    return Table(rows, cycles, sampled, sample)


def choose(table: Table, tolerance: float) -> int:
    """``table.choose(tolerance)``."""
    return table.choose(tolerance)
