"""The coarse prepass: choose the voxel subdivision from low-resolution traces.

The paper proposes tracing at a fraction of the resolution for a few
subdivisions and keeping the best.  Here the candidates are searched: the
subdivision n (voxels along the scene box's longest axis, the other axes in
proportion, or n per axis with ``shape="cube"``) is tried up a geometric
ladder over the range until the time has risen on ``past`` rungs past the
best (default 1: large grids cost the most to build, and the rung past the
best already closes the bracket; 2 chose the same subdivision on all six SPD
scenes and the stadium at 512x512, at up to 3x the cost on gears) and at
least MIN_RUNGS rungs have been tried, then the bracket around the best rung
is narrowed by golden-section steps until its ends are within ``ratio`` (the
time is close to unimodal in n, fewer tests as voxels shrink, more steps and
set-up, and flat near its minimum).  The low resolution is
at least LOW_FLOOR pixels per axis (the whole frame where smaller).  Each candidate's
full-resolution time is predicted as its low-resolution cycles times the
ratio of pixel counts; the machine replayed is the machine model's 3MPPE
(``mprt.machine`` built-in ``3mppe``) unless a Design or SystemConfig is given
(``mprt prepass --model/--config``), at ``level``: 0 to 3, or "auto" (the
CLI's default), the lowest level whose error against the machine's own level
is within ``tolerance`` on the trace of the middle of the range
(``fidelity.measure``, levels 0 up to the machine's own), as the explorer
chooses its level.  Every evaluation goes through the fidelity ladder with
engine "auto": the compiled replay where it is exact, SimPy elsewhere.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import MprtError
from ..machine.config import builtin
from .evaluate import TraceEvaluator, grid_dims, is_deadlock, machine_config
from .hwcost import UnitCosts
from .space import Design

FIXED_RULES = ("pbrt", "density8", "paper-best")


LOW_FLOOR = 32      # the low resolution's floor per axis (the frame's own size where smaller)
MIN_RUNGS = 4       # the walk up the ladder tries at least this many rungs


class PrepassDeadlockError(MprtError, RuntimeError):
    """The machine deadlocks on every candidate subdivision the prepass tried: no choice to make."""


_WHY = ("its FIFOs cannot hold this scene's ray trees with its DIS window; give the FIFOs more room or a "
        "smaller window (--config)")




def _name(cfg) -> str:
    return getattr(cfg, "source", None) or cfg.name


def _grids(dims) -> str:
    return ", ".join("x".join(map(str, d)) for d in dims)


def low_resolution(width: int, height: int, fraction: int) -> tuple[int, int]:
    """width/fraction x height/fraction, but at least LOW_FLOOR per axis (or the frame's own
    size, where smaller): below that a trace has too few rays to tell subdivisions apart
    (at 8x8, tetra:1's ladder stopped after 2x2x2 and 3x3x3)."""
    return tuple(max(int(round(n / fraction)), min(n, LOW_FLOOR)) for n in (width, height))


def fixed_rule(scene, rule: str) -> tuple:
    """The subdivision a fixed rule picks: pbrt's 3 * N^(1/3) along the longest
    axis, ours (density 8, Scene.default_grid), or (for 'paper-best') None:
    the best of 20, 50, 100 per axis needs evaluating."""
    if rule == "pbrt":
        return tuple(scene.default_grid(density=3.0))
    if rule == "density8":
        return tuple(scene.default_grid())
    raise ValueError(rule)


class _Cands:
    def __init__(self, scene, w, h, design, shape, unit_costs, threads, level, rules="paper", threshold=None,
                 limits=None):
        self.scene, self.w, self.h, self.design, self.shape = scene, w, h, design, shape
        self.unit_costs, self.threads, self.level = unit_costs, threads, level
        self.rules, self.threshold, self.limits = rules, threshold, dict(limits or {})
        self.seen: dict = {}          # dims -> cycles at low resolution

    def __call__(self, n) -> float:
        dims = grid_dims(self.scene, (n,) if np.isscalar(n) else n, self.shape)
        if dims not in self.seen:
            _, tr = self.scene.grid(dims).trace(self.w, self.h, rules=self.rules, threshold=self.threshold,
                                                threads=self.threads, **self.limits)
            self.seen[dims] = TraceEvaluator(tr, self.unit_costs, counted=False).run_config(self.design,
                                                                                           self.level).cycles
        return self.seen[dims]


def default_range(scene, density=(1.0, 32.0), limit: int = 768) -> tuple[int, int]:
    """The n searched by default: density x N^(1/3) along the longest axis for
    density 1 to 32 (pbrt's rule is 3, ours 8; tree's best at 512x512 is 26),
    within 2..``limit``.  The walk up the ladder stops once the time rises, so
    the large end is only built for scenes that need it."""
    c = max(scene.info()["prims"], 1) ** (1.0 / 3.0)
    return (int(min(max(round(density[0] * c), 2), limit)), int(min(max(round(density[1] * c), 2), limit)))


def prepass(scene, width: int = 512, height: int = 512, candidates=None, n_range=None, fraction: int = 16,
            design=None, shape: str = "proportional", rungs: int = 7, level: int | str = 1,
            unit_costs: UnitCosts | None = None, threads: int = 1, ratio: float = 1.15, check: int = 0,
            check_sample: str | None = None, past: int = 1, refine: str = "golden", tolerance: float = 0.01,
            rules: str = "paper", threshold: float | None = None, axes: bool = True, limits=None) -> dict:
    """Predict the full-resolution cycles of candidate subdivisions from traces
    at width/fraction x height/fraction, and return the best.  ``candidates``:
    explicit subdivisions (n or (nx, ny, nz)), all evaluated; otherwise n is
    searched over ``n_range`` (default: ``default_range(scene)``).  ``check``:
    the best few predictions are then traced at full resolution on the tiles of
    ``check_sample`` (a sampled replay, scaled by the frame's samples over the
    sample's) and the best of those is the choice: where the time is jagged in
    n, a low-resolution trace cannot tell neighbouring candidates apart.
    Default sample: ``stratified:K:1`` with K such that about 16 tiles of 16x16
    are traced (a sixty-fourth of a 512x512 frame; all of a frame of 16 tiles
    or fewer).  Every trace is made under ``rules`` with the cutoff ``threshold`` (None: the
    library's default).  ``axes`` (searched n only): then each axis on its own, from the best
    of the line (``_per_axis``): the subdivision is free per axis, the rule only the start."""
    if refine not in ("golden", "parabola", "none"):
        raise ValueError(f"prepass: refine must be 'parabola', 'golden' or 'none', not {refine!r}")
    t0 = time.perf_counter()
    w, h = low_resolution(width, height, fraction)
    scale = (width * height) / (w * h)
    if design is None:
        design = builtin("3mppe")
    elif isinstance(design, Design):
        design = machine_config(design)
    if n_range is None and not candidates:
        n_range = default_range(scene)
    ladder_rows = None
    if level == "auto":
        level, ladder_rows = trusted_level(scene, w, h, design, shape, candidates, n_range, tolerance, threads,
                                           rules, threshold, {k: v for k, v in (limits or {}).items() if v})
    elif level not in (0, 1, 2, 3):
        raise ValueError(f"prepass: level must be 0, 1, 2, 3 or 'auto', not {level!r}")
    limits = {k: v for k, v in (limits or {}).items() if v}      # max_rays, max_depth (0/None: the defaults)
    f = _Cands(scene, w, h, design, shape, unit_costs or UnitCosts(), threads, level, rules, threshold, limits)
    if candidates:
        for c in candidates:
            f(c)
    else:
        lo, hi = (int(v) for v in n_range)
        if not 1 <= lo <= hi:
            raise ValueError(f"prepass: subdivision range {lo}..{hi} is empty")
        ladder = sorted({int(round(x)) for x in np.geomspace(lo, hi, min(rungs, hi - lo + 1))})
        # up the ladder until the time has risen on `past` rungs past the best (the large grids cost most),
        # but at least MIN_RUNGS rungs: one rise at the bottom of the ladder is often the noise of a small trace
        vals = []
        for n in ladder:
            vals.append(f(n))
            i = int(np.argmin(vals))
            if len(vals) - 1 - i >= past and len(vals) >= min(MIN_RUNGS, len(ladder)):
                break
        if refine == "parabola":
            _parabola(f, ladder[max(i - 1, 0)], ladder[i], ladder[min(i + 1, len(ladder) - 1)])
        elif refine == "golden":
            _golden(f, ladder[max(i - 1, 0)], ladder[min(i + 1, len(ladder) - 1)], ratio)
        if axes:
            _per_axis(f, ratio)

    cands = sorted(f.seen.items(), key=lambda kv: kv[0])
    live = [kv for kv in cands if not is_deadlock(kv[1])]
    if not live:
        raise PrepassDeadlockError(
            f"machine {_name(f.design)} deadlocks at level {level} on every subdivision tried at {w}x{h} "
            f"({_grids(d for d, _ in cands)}): {_WHY}")
    best = min(live, key=lambda kv: (kv[1], kv[0]))
    checked = {}
    if check > 0 and check_sample is None:
        tiles = -(-width // 16) * -(-height // 16)
        check_sample = f"stratified:{min(max(tiles // 16, 1), 64)}:1"
    if check > 0:
        from .evaluate import SceneEvaluator
        from .space import Point
        full = SceneEvaluator(scene, width, height, level=level, shape="cube", unit_costs=f.unit_costs,
                              threads=threads, sample=check_sample, rules=rules, threshold=threshold, **limits)
        for dims, _ in sorted(live, key=lambda kv: (kv[1], kv[0]))[:check]:
            checked[dims] = full.run(Point(dims, f.design)).cycles
            full._held.clear()
        ran = [kv for kv in checked.items() if not is_deadlock(kv[1])]
        if not ran:
            raise PrepassDeadlockError(
                f"machine {_name(f.design)} deadlocks at level {level} at {width}x{height} (on "
                f"{check_sample}) on each of the {len(checked)} best subdivisions of {w}x{h} "
                f"({_grids(checked)}): {_WHY}")
        best = min(ran, key=lambda kv: (kv[1], kv[0]))
        best = (best[0], f.seen[best[0]])
    return {"subdivision": list(best[0]), "predicted_cycles": best[1] * scale,
            "settings": settings(scene, width, height, threads, rules, threshold),
            "per_axis": bool(axes and not candidates),
            # (a subdivision where the machine deadlocks: no cycles, "deadlock" true)
            "candidates": [dict({"subdivision": list(d), "predicted_cycles": None if is_deadlock(c) else c * scale,
                                 "deadlock": is_deadlock(c)},
                                **({"sampled_cycles": None if is_deadlock(checked[d]) else checked[d],
                                    "sampled_deadlock": is_deadlock(checked[d])} if d in checked else {}))
                           for d, c in cands],
            "check_sample": check_sample if check > 0 else None,
            "low_resolution": [w, h], "full_resolution": [width, height], "machine": f.design.name,
            "level": level, "ladder": ladder_rows, "refine": refine if not candidates else None,
            "seconds": time.perf_counter() - t0}


def trusted_level(scene, w: int, h: int, config, shape: str, candidates, n_range, tolerance: float,
                  threads: int = 1, rules: str = "paper", threshold: float | None = None, limits=None) -> tuple:
    """(level, ladder rows): the lowest level within ``tolerance`` of the machine's own level
    (``native_level``) for ``config`` on the w x h trace of the middle candidate (or of the
    geometric middle of ``n_range``)."""
    from ..fidelity import measure, native_level
    from .ladder import lowest_adequate

    if candidates:
        mid = sorted(grid_dims(scene, c, shape) for c in candidates)[len(candidates) // 2]
    else:
        lo, hi = (int(v) for v in n_range)
        mid = grid_dims(scene, (int(round(math.sqrt(lo * hi))),), shape)
    _, tr = scene.grid(mid).trace(w, h, rules=rules, threshold=threshold, threads=threads, **(limits or {}))
    top = native_level(config)
    if top == 1:
        return 1, None
    table = measure(tr, [config], levels=tuple(range(top + 1)), sample=None)
    return lowest_adequate(table, tolerance), [r.to_dict() for r in table.rows]


AXIS_STEP = 1.25       # the per-axis descent's step: n x or / this, rounded (at least 1 voxel)


def _per_axis(f, ratio: float = AXIS_STEP, rounds: int = 8) -> None:
    """From the best subdivision ``f`` has seen, each axis in turn one step up and down (x or /
    ``AXIS_STEP``) while the time falls, until no axis moves (a coordinate descent)."""
    from ..settings import GRID_MAX

    def live_best():
        live = [kv for kv in f.seen.items() if not is_deadlock(kv[1])]
        return min(live, key=lambda kv: (kv[1], kv[0]))[0] if live else None
    best = live_best()
    if best is None:
        return
    step = max(ratio, AXIS_STEP)
    for _ in range(rounds):
        moved = False
        for axis in range(3):
            while True:
                n = best[axis]
                cands = []
                for k in (max(n + 1, int(round(n * step))), min(n - 1, int(n / step))):
                    if 1 <= k <= GRID_MAX:
                        c = list(best)
                        c[axis] = k
                        cands.append(tuple(c))
                for c in cands:
                    f(c)
                nxt = min([best] + cands, key=lambda d: (f.seen[d], d))
                if nxt == best:
                    break
                best, moved = nxt, True
        if not moved:
            break


def settings(scene, width, height, threads, rules: str = "paper", threshold=None, grid=None) -> dict:
    """What made a prepass report: the scene and its content hash, the image, the rules and cutoff of
    its traces, the subdivision when it was fixed, the version."""
    from ..settings import threshold_setting, version
    return {"scene": scene.name, "scene_sha256": scene.content_hash(), "resolution": [width, height],
            "rules": rules, "threshold": threshold_setting(rules, threshold),
            "grid": None if grid is None else ([grid] * 3 if isinstance(grid, int) else list(grid)),
            "threads": threads, "mprt_version": version()}


def _parabola(f, a: int, m: int, b: int) -> None:
    """One step, the alternative to the golden section (``refine="parabola"``):
    the vertex of the parabola through the three rungs around the best (in
    log n, where the ladder is even), evaluated once.  It takes half the
    candidates but is not close enough where the time is jagged in n: at
    512x512 it chose 6-8% slower subdivisions on rings and tetra, where the
    golden section's were the best (studies/20_design_space/prepass_table.py)."""
    if not a < m < b:
        return
    x = np.log([a, m, b])
    c2, c1, _ = np.polyfit(x, [f(a), f(m), f(b)], 2)
    if not c2 > 0:
        return
    n = int(round(math.exp(min(max(-c1 / (2 * c2), x[0]), x[2]))))
    f(min(max(n, a + 1), b - 1))


def _golden(f, a: int, b: int, ratio: float) -> None:
    """Narrow [a, b] around the minimum of f over the integers (golden
    section) until b / a is at most ``ratio``: near its minimum the time is
    flat in n, so a few percent in n changes it little."""
    g = (math.sqrt(5) - 1) / 2
    while b - a > 2 and b > a * ratio:
        c = int(round(b - g * (b - a)))
        d = int(round(a + g * (b - a)))
        if c == d:
            d = c + 1
        if f(c) <= f(d):
            b = d
        else:
            a = c
