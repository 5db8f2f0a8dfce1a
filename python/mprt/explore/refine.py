"""The explorer's full-resolution phase: the search's best designs checked at full
resolution, then polished there, each polish neighbour first screened by the search's
own low-resolution replay.

The screen (``Screen``): the full-resolution polish walks from the best design of a
subdivision among designs within a few percent of it, so level 1 (less its slack) rules out
few of them, while each costs a replay at full resolution.  The search has replayed most of
them, at the same level, on the low-resolution trace of the same grid, and the ratio of full
to low resolution varies little between neighbours (measured:
``studies/20_design_space/screen_error.py``).  So a neighbour's full-resolution cycles are
estimated as its low-resolution cycles as the search knows them (its replay, or its level-1
bound where it ruled the design out; nothing where it never saw it) times the polish
start's ratio, less ``SCREEN_MARGIN``; that estimate joins the level-1 bound (the larger of the two rules out),
and level 1 is replayed only where the estimate does not rule the design out already.  A
design ruled out is kept with the larger figure (``bound``), replayed when a choice would
take it (``Problem.ranked``), as with the level-1 bounds alone.  Unlike level 1, the
estimate is no proof: the margin covers the ranking error measured, and the report says the
worst error seen on the designs replayed (``screen`` in the JSON).
"""
from __future__ import annotations

import math
import time
import weakref
from dataclasses import replace

from .evaluate import DEADLOCK_CYCLES, Result
from .hwcost import cost_breakdown
from .search import Problem, compass

# How far below its estimate a design's full-resolution cycles may fall: the ranking error of the
# low-resolution replay against the full-resolution one among polish neighbours, with room
SCREEN_MARGIN = 0.15

# A stage mapping's best is checked at full resolution (the hedge against the low resolution's
# ranking) unless its objective at the search's resolution is more than this many times the
# search's best: measured on the six SPD scenes at 512x512, a check's full-resolution cycles
# relative to the best's were 0.56 to 1.07 times its relative cycles at 64x64 (the coarse
# grids gain most), so one four times behind would have to gain twice that; tracing such a
# check's grid at full resolution (gears' 4x4x1: 3.8 s) was the only thing it cost, its level-1
# bound there ruling it out each time
CHECK_BEHIND = 4.0


def first_checks(problem: Problem, verify: int) -> list:
    """The designs the full-resolution phase checks first: the search's ``verify`` best, then
    each stage mapping's best (the hedge; within CHECK_BEHIND of the best), best first."""
    ranked = problem.ranked()
    out = [e for _, e in zip(range(max(verify, 1)), ranked)]
    by_map: dict = {}
    for e in problem.memo.values():
        by_map.setdefault(e.point.design.mapping, []).append(e)
    worst = problem.f(out[0]) + math.log(CHECK_BEHIND) if out else math.inf
    for e in sorted((problem.best_of(es) for es in by_map.values()), key=problem.rank):
        if e.index not in [c.index for c in out] and problem.f(e) <= worst:
            out.append(e)
    return out


class Screen:
    """Low-resolution cycles at the search's level from the search's memo, and the errors of
    the estimates made from them on the designs replayed at full resolution.  The screen
    replays nothing at low resolution (``low``, the search's evaluator, only lends its unit
    costs): replaying each design the search had not seen cost as much as the
    full-resolution replays it saved (tetra at 512x512, side by side)."""

    def __init__(self, problem: Problem, low, level: int, margin: float = SCREEN_MARGIN):
        self.problem, self.low, self.level, self.margin = problem, low, level, margin
        self.errors: list = []           # full / estimate - 1 of each design replayed at full resolution
        self.ruled_out = 0               # designs the estimate alone ruled out (no level-1 replay)

    def cycles(self, point, exact: bool = False):
        """The design's low-resolution cycles as the search knows them: replayed, or its
        level-1 bound there when it ruled the design out (a lower figure, so the estimate
        only falls); None where the search never saw it (or, ``exact``, only bounded it),
        so that the screen costs no replay of its own."""
        sp = self.problem.space
        e = self.problem.memo.get(sp.canonical(sp.index_of(point)))
        if e is None or (exact and e.bound):
            return None
        return e.cycles

    def bounder(self, fp: Problem, start_cycles: float, start_point, level1):
        """``Problem.bound_points`` for the polish ``fp`` from a start of ``start_cycles`` at full
        resolution: the screen's estimates, joined by level 1 (``level1``: points -> bounds, or
        None) where the estimate alone does not rule the design out."""
        low0 = self.cycles(start_point, exact=True)
        if low0 is None or low0 >= DEADLOCK_CYCLES or start_cycles >= DEADLOCK_CYCLES or low0 <= 0:
            return level1
        ratio = start_cycles / low0
        polish = weakref.ref(fp)        # fp holds these bounds: no cycle (it would keep the traces alive)

        def bounds(points):
            fp = polish()
            est = []
            for p in points:
                c = self.cycles(p)
                cost = float(fp.cost_of(p) if fp.cost_of is not None else
                             sum(cost_breakdown(p.design, getattr(self.low, "unit_costs", None)).values()))
                guess = 0.0 if c is None or c >= DEADLOCK_CYCLES else float(math.floor(c * ratio * (1 - self.margin)))
                est.append(Result(cycles=guess, level=self.level, cost=cost))
            inc = fp.incumbent()
            need = [i for i, r in enumerate(est) if fp.value(r.cycles, r.cost) <= inc]
            self.ruled_out += len(points) - len(need)
            if level1 is not None and need:
                for i, b in zip(need, level1([points[i] for i in need])):
                    est[i] = replace(b, cycles=max(b.cycles, est[i].cycles))
            return est

        def record(e):
            c = self.cycles(e.point, exact=True)
            if c is not None and c < DEADLOCK_CYCLES and e.cycles < DEADLOCK_CYCLES:
                self.errors.append(e.cycles / (c * ratio) - 1)
        bounds.record = record
        return bounds

    def note(self, fp: Problem) -> None:
        """Record the errors of the estimates on the designs the polish ``fp`` replayed (its
        start, the first design, apart)."""
        record = getattr(fp.bound_points, "record", None)
        if record is not None:
            for k in fp.order[1:]:
                if not fp.memo[k].bound:
                    record(fp.memo[k])

    def report(self) -> dict:
        return {"margin": self.margin, "ruled_out": self.ruled_out, "checked": len(self.errors),
                "worst_below": min(self.errors, default=None), "worst_above": max(self.errors, default=None)}


def refine(problem, space, full, objective, budget, refine, refine_evals, verify, pool, cost_of, phases=None,
           per_eval=None, bounder=lambda sev: None, screen: Screen | None = None):
    """The full-resolution phase, at the search's level: the ``verify`` best designs of the
    low-resolution search and its best of each stage mapping (``first_checks``: within
    CHECK_BEHIND of the best) evaluated at full resolution in one batch; then, from the best
    design there of each of the ``refine`` best subdivisions, a lattice polish
    (``refine_evals`` designs each; a subdivision after the first only if its best is within
    ``SCREEN_MARGIN`` of the best, 1 / (1 - margin) in cycles), its neighbours screened by
    ``screen`` (None: by their level-1 bounds alone).  Returns the best, the history rows (phases
    ``full-check`` and ``full``), the designs evaluated and those of them run at the level
    (the rest known by their bounds, ``bounder``)."""
    from .explorer import _Silent

    lv = full.level
    checks = first_checks(problem, verify)
    phases = phases or _Silent()
    vp = Problem(space, lambda pts: pool.run(full, pts, lv), objective, budget, cost_of=cost_of,
                 bound_points=bounder(full))
    t0 = time.perf_counter()
    with phases.step(f"full-resolution checks: {len(checks)} designs at {full.width}x{full.height}",
                     None if per_eval is None else per_eval * len(checks) / max(min(pool.workers, len(checks)), 1)):
        vp.evaluate_many([e.index for e in checks])
    per_eval = (time.perf_counter() - t0) / max(len(checks), 1) * max(min(pool.workers, len(checks)), 1)
    # a further subdivision is polished only if its best is within the screen's margin of the
    # best there: a polish cannot prune against another's incumbent, so from a start far behind it
    # walks through designs that cannot win (balls' 16x16x1, 2.2x behind, took a quarter of the run)
    subs, first = [], None
    for e in vp.ranked():
        if first is None:
            first = vp.f(e)
        elif vp.f(e) > first - math.log1p(-SCREEN_MARGIN):
            break
        if e.point.subdivision not in [s for s, _ in subs]:
            subs.append((e.point.subdivision, e))
        if len(subs) == refine:
            break
    with phases.step(f"polish at {full.width}x{full.height}: up to {refine_evals} designs from each of "
                     f"{len(subs)} subdivision(s)", per_eval * refine_evals * len(subs)):
        polished = polish(space, full, objective, budget, refine_evals, pool, cost_of, subs, lv, bounder, screen)
    # the best of the checks, then of each polish (its start, a check, left out): the first on ties
    found = [vp.best()] + [p.best_of([e for e in p.memo.values() if e.index != start]) for p, start in polished]
    best = min((e for e in found if e is not None), key=lambda e: vp.rank(e)[:2])
    rows = [dict(r, phase="full-check") for r in vp.history()]
    for p, _ in polished:
        rows += [dict(r, phase="full") for r in p.history() if r["evaluation"] > 1]
    n = len(vp.memo) + sum(len(p.memo) - 1 for p, _ in polished)
    ran = vp.runs + sum(p.runs - 1 for p, _ in polished)
    return best, rows, n, ran


def polish(space, full, objective, budget, refine_evals, pool, cost_of, subs, lv, bounder, screen=None) -> list:
    """The lattice polish from the best design of each subdivision in ``subs``; returns
    each polish's (Problem, start)."""
    out = []
    for sub, e in subs:
        sp = space.with_subdivision(sub)
        fp = Problem(sp, lambda pts: pool.run(full, pts, lv), objective, budget, cost_of=cost_of,
                     bound_points=bounder(full))
        if screen is not None and objective != "pareto":
            fp.bound_points = screen.bounder(fp, e.cycles, e.point, fp.bound_points)
        start = sp.canonical(sp.index_of(e.point))
        fp.add(e.point, e.result)
        compass(fp, start, refine_evals)
        if screen is not None:
            screen.note(fp)
        out.append((fp, start))
    return out
