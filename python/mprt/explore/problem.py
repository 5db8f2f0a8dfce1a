"""A search problem: a design space, an evaluator and an objective, with memoised
evaluations and, optionally, cheap lower bounds that rule designs out before they are
run (``Problem.bound_points``; the explorer's are level 1 under level 3)."""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from .space import Point, Space

OBJECTIVES = ("time", "time*cost", "pareto")
INFEASIBLE = 1e3                # objective floor of a design over the budget (log-cycles are < 60)


@dataclass
class Evaluation:
    index: tuple
    point: Point
    cycles: float
    cost: float
    serial: int                 # 1 for the first design evaluated
    result: object = None
    bound: bool = False         # cycles are a lower bound (``Problem.bound_points``'s): not run at the level


def deadlocked(e: Evaluation) -> bool:
    """The evaluation's design deadlocked (``evaluate.is_deadlock`` of its result)."""
    from .evaluate import is_deadlock

    return is_deadlock(e.result)


def front_of(evals) -> list[Evaluation]:
    """The evaluations no other beats in both cycles and cost, cheapest first (a design that
    deadlocked is on no front)."""
    out, low = [], math.inf
    for e in sorted((e for e in evals if not deadlocked(e)), key=lambda e: (e.cost, e.cycles, e.index)):
        if e.cycles < low:
            out.append(e)
            low = e.cycles
    return out


class Problem:
    """A space, an evaluator and an objective; memoises evaluations.

    ``evaluate_points(points) -> list of results`` (each with ``cycles`` and
    ``cost``) is called with batches; the search itself asks one at a time.

    ``bound_points(points) -> list of results`` (optional: a cheaper evaluation whose cycles
    no ``evaluate_points`` result undercuts, e.g. level 1 under level 3) bounds each new
    design first: one whose bound is already worse than the best design run so far (or
    that is over the budget, where cycles do not count) is kept with its bound (``bound``)
    and not run; the others are run best bound first, each tightening the incumbent.  A
    design known by its bound is run when it would come first (``ranked``, ``best``,
    ``best_of``), so the best, the polish's starts and the designs verified are the ones full
    evaluation would give, and so are the polish's steps (``compass``).
    """

    def __init__(self, space: Space, evaluate_points, objective: str = "time", budget: float | None = None,
                 progress=None, cost_of=None, bound_points=None):
        if objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, not {objective!r}")
        self.space = space
        self.evaluate_points = evaluate_points
        self.objective = objective
        self.budget = budget
        self.memo: dict[tuple, Evaluation] = {}
        self.order: list[tuple] = []            # canonical keys in evaluation order
        self.calls = 0
        self.cap = None
        self.opt = None
        self.progress = progress
        self.free = [i for i, v in enumerate(space.variables) if v.size > 1]
        self.cost_of = cost_of                  # point -> kGE without evaluating it (lets the polish skip
                                                # designs over the budget), or None
        self.bound_points = bound_points if objective != "pareto" else None   # the front needs every design's cycles
        self.runs = 0                           # designs run by evaluate_points (the rest known by their bound)
        self._incumbent = None                  # (budget, value): the best run design's objective

    def over_budget(self, key) -> bool:
        """Whether a design is known, before evaluating it, to cost more than the budget."""
        return self.budget is not None and self.cost_of is not None and \
            self.cost_of(self.space.point(key)) > self.budget

    def add(self, point, result, bound: bool = False) -> Evaluation | None:
        """Record a point evaluated elsewhere (a global start's, a walk's; ``bound``: known by its
        bound only); None if it was known (a design known here by its bound and run elsewhere
        takes the run's result, in its place, as ``resolve`` would)."""
        k = self.space.canonical(self.space.index_of(point))
        if k in self.memo:
            if self.memo[k].bound and not bound:
                self._settle(self.memo[k], result)
            return None
        e = Evaluation(k, self.space.point(k), float(result.cycles), float(result.cost), len(self.memo) + 1, result,
                       bound)
        self.memo[k] = e
        self.order.append(k)
        self._ran(e)
        return e

    def _ran(self, e: Evaluation) -> None:
        """Count a design run and tighten the incumbent."""
        if e.bound:
            return
        self.runs += 1
        if self._incumbent is not None and self._incumbent[0] == self.budget:
            self._incumbent = (self.budget, min(self._incumbent[1], self.f(e)))

    def incumbent(self) -> float:
        """The objective of the best design run so far (inf: none)."""
        if self._incumbent is None or self._incumbent[0] != self.budget:
            self._incumbent = (self.budget, min((self.f(e) for e in self.memo.values() if not e.bound),
                                                default=math.inf))
        return self._incumbent[1]

    def _results(self, points) -> list[tuple]:
        """(result, known by its bound only) per point: every point run, or with ``bound_points``
        only those whose bound does not rule them out, best bound first."""
        if self.bound_points is None:
            return [(r, False) for r in self.evaluate_points(points)]
        lows = self.bound_points(points)
        vals = [self.value(r.cycles, r.cost) for r in lows]
        out = [None] * len(points)
        best = self.incumbent()
        for i in sorted(range(len(points)), key=lambda i: (vals[i], i)):
            if vals[i] > best or (self.budget is not None and lows[i].cost > self.budget):
                out[i] = (lows[i], True)
            else:
                r = self.evaluate_points([points[i]])[0]
                out[i] = (r, False)
                best = min(best, self.value(r.cycles, r.cost))
        return out

    def resolve(self, e: Evaluation) -> Evaluation:
        """The design run (in place of its bound; same serial)."""
        if not e.bound:
            return e
        return self._settle(e, self.evaluate_points([e.point])[0])

    def _settle(self, e: Evaluation, r) -> Evaluation:
        """A design known by its bound takes its run's result ``r``, in its place (same serial)."""
        e = Evaluation(e.index, e.point, float(r.cycles), float(r.cost), e.serial, r)
        self.memo[e.index] = e
        self._ran(e)
        return e

    def ranked(self, evals=None, budget=None, below=None, run: bool = True):
        """Evaluations (default: all) best first, each run: a design known by its bound is run
        when it comes first (its rank can only fall), so the order is full evaluation's.
        ``below``: only those whose (objective, cost) is below it (none run to find out more);
        ``run`` false: only those run already (a design ruled out stays out)."""
        heap = [(self.rank(e, budget), e.index) for e in (self.memo.values() if evals is None else evals)
                if run or not e.bound]
        heapq.heapify(heap)
        while heap:
            r, k = heapq.heappop(heap)
            if below is not None and r[:2] >= below:
                return
            e = self.memo[k]
            if e.bound:
                e = self.resolve(e)
                heapq.heappush(heap, (self.rank(e, budget), k))
                continue
            yield e

    def best_of(self, evals, budget=None, below=None, run: bool = True) -> Evaluation | None:
        """The best of some evaluations (run if it was known by its bound; None if none is
        below ``below``; ``run`` false: the best of those run)."""
        return next(self.ranked(evals, budget, below, run), None)

    def value(self, cycles: float, cost: float, budget=None) -> float:
        budget = self.budget if budget is None else budget
        if budget is not None and cost > budget:
            return INFEASIBLE + math.log1p((cost - budget) / budget)
        v = math.log(max(cycles, 1.0))
        return v + math.log(max(cost, 1e-9)) if self.objective == "time*cost" else v

    def evaluate_many(self, idxs) -> list[Evaluation]:
        """Evaluate index vectors (memoised), new ones in one batch."""
        keys = [self.space.canonical(i) for i in idxs]
        new = list(dict.fromkeys(k for k in keys if k not in self.memo))
        if self.cap is not None and len(self.memo) + len(new) > self.cap:
            new = new[:max(self.cap - len(self.memo), 0)]
        if new:
            results = self._results([self.space.point(k) for k in new])
            for k, (r, bound) in zip(new, results):
                e = Evaluation(k, self.space.point(k), float(r.cycles), float(r.cost), len(self.memo) + 1, r, bound)
                self.memo[k] = e
                self.order.append(k)
                self._ran(e)
                if self.progress:
                    self.progress(self)
        return [self.memo[k] for k in keys if k in self.memo]

    def __call__(self, idx) -> float:
        self.calls += 1
        k = self.space.canonical(idx)
        if k not in self.memo:
            if self.cap is not None and len(self.memo) >= self.cap:
                if self.opt is not None:          # NLopt: ask it to stop (exceptions in callbacks misbehave)
                    self.opt.force_stop()
                return INFEASIBLE * 10
            self.evaluate_many([k])
        return self.f(self.memo[k])         # a ruled-out design's bound: the global method is told that

    def f(self, e: Evaluation, budget=None) -> float:
        """The objective of an evaluation (under the current budget)."""
        return self.value(e.cycles, e.cost, budget)

    def best(self, budget=None) -> Evaluation | None:
        return self.best_of(self.memo.values(), budget)

    def rank(self, e: Evaluation, budget=None) -> tuple:
        """Order of preference: objective, then cost (a tie in time goes to the cheaper design)."""
        return (self.f(e, budget), e.cost, e.serial)

    def x_to_index(self, x) -> tuple:
        idx = [0] * len(self.space.variables)
        for j, i in enumerate(self.free):
            n = self.space.variables[i].size
            idx[i] = min(max(int(math.floor(x[j])), 0), n - 1)
        return tuple(idx)

    def index_to_x(self, idx) -> np.ndarray:
        return np.array([idx[i] + 0.5 for i in self.free], dtype=float)

    def history(self) -> list[dict]:
        """A row per evaluation, in order.  A design that deadlocked has no cycles and, within the
        budget, no objective (None: the search's stand-in for them is no figure of the design's),
        and ``deadlock`` true; ``best_objective`` is None until a design has run."""
        rows, best = [], math.inf
        for n, k in enumerate(self.order, 1):
            e = self.memo[k]
            v = self.f(e)
            dead = deadlocked(e)
            if not e.bound and not dead:
                best = min(best, v)
            rows.append({"evaluation": n, "subdivision": list(e.point.subdivision), "design": e.point.design.to_dict(),
                         "cycles": None if dead else e.cycles, "cost": e.cost,
                         "objective": None if dead and v < INFEASIBLE else v,
                         "best_objective": best if best < math.inf else None,
                         "feasible": v < INFEASIBLE, "bound": e.bound, "deadlock": dead})
        return rows

    def front(self) -> list[Evaluation]:
        """The designs no other evaluated design beats in both cycles and cost (``front_of``)."""
        return front_of(self.memo.values())
