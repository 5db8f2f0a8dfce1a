"""Searching a design space with NLopt.

Every variable of a space is an index into its list of values.  NLopt sees
one continuous variable per free index, x_i in [0, size_i), and the point is
``floor(x_i)`` (clamped): a fixed, deterministic map, so equal x give equal
designs on any machine.  Evaluations are memoised on the canonical index
vector (variables that cannot change the machine set to their first value),
so NLopt may revisit a cell at no cost; only distinct designs count as
evaluations.  ``nlopt.srand(seed)`` is set before every run, so a search with
the same seed repeats exactly.

The method: a global, derivative-free NLopt algorithm (DIRECT-L by default,
see the README for the measured comparison), then a polish of the best point
on the integer lattice: compass search, which tries +-1 on each index in turn
and moves while anything improves.  NLopt's local methods (Subplex,
Nelder-Mead, BOBYQA, COBYLA) assume a smooth function; on the flat steps that
``floor`` makes they see zero change inside a cell and stop, which the
comparison measures.
"""
from __future__ import annotations

import heapq
import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .space import Point, Space, Var

OBJECTIVES = ("time", "time*cost", "pareto")
GLOBAL_ALGORITHMS = {
    "direct-l": "GN_DIRECT_L",
    "direct-l-rand": "GN_DIRECT_L_RAND",
    "direct": "GN_DIRECT",
    "crs2": "GN_CRS2_LM",
    "isres": "GN_ISRES",
    "esch": "GN_ESCH",
    "random": None,            # uniform random points (a baseline)
    "none": None,
}
STARTS = ("whole", "mapping")    # the global phase: one start over the space, or one per stage mapping
POLISHES = ("lattice", "sbplx", "neldermead", "bobyqa", "cobyla", "none")
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


@dataclass
class SearchResult:
    best: Evaluation | None
    evaluations: int
    calls: int
    seconds: float
    history: list = field(default_factory=list)
    front: list = field(default_factory=list)
    phases: dict = field(default_factory=dict)      # evaluations spent in each phase


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
    evaluation would give; the polish does not step to a design ruled out (``compass``).
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
        """Record a point evaluated elsewhere (a global start's; ``bound``: known by its bound
        only); None if it was known."""
        k = self.space.canonical(self.space.index_of(point))
        if k in self.memo:
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
        r = self.evaluate_points([e.point])[0]
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
        return self.f(self.memo[k])

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
        rows, best = [], math.inf
        for n, k in enumerate(self.order, 1):
            e = self.memo[k]
            v = self.f(e)
            if not e.bound:
                best = min(best, v)
            rows.append({"evaluation": n, "subdivision": list(e.point.subdivision), "design": e.point.design.to_dict(),
                         "cycles": e.cycles, "cost": e.cost, "objective": v, "best_objective": best,
                         "feasible": v < INFEASIBLE, "bound": e.bound})
        return rows

    def front(self) -> list[Evaluation]:
        """The designs no other evaluated design beats in both cycles and cost."""
        pts = sorted(self.memo.values(), key=lambda e: (e.cost, e.cycles, e.index))
        out, best_cycles = [], math.inf
        for e in pts:
            if e.cycles < best_cycles:
                out.append(e)
                best_cycles = e.cycles
        return out


def _nlopt_run(problem: Problem, algorithm: str, x0, max_evals: int, seed: int, step=None):
    import nlopt

    n = len(problem.free)
    if n == 0:
        problem(tuple([0] * len(problem.space.variables)))
        return
    opt = nlopt.opt(getattr(nlopt, algorithm), n)
    sizes = [problem.space.variables[i].size for i in problem.free]
    opt.set_lower_bounds([0.0] * n)
    opt.set_upper_bounds([float(s) - 1e-9 for s in sizes])
    start = len(problem.memo)
    problem.cap = start + max_evals

    # DIRECT-L asks about hundreds of points per distinct design (floor(x) is flat in a cell):
    # the cell's objective is kept by its raw index vector, so a revisit costs a floor and a
    # dictionary look-up (the same value the memo gives, so the search is unchanged)
    hi = np.array(sizes, dtype=np.int64) - 1
    seen: dict = {}

    def f(x, grad):
        raw = tuple(np.minimum(np.maximum(np.floor(x).astype(np.int64), 0), hi).tolist())
        v = seen.get(raw)
        if v is None:
            v = problem(problem.x_to_index(x))
            if v < INFEASIBLE * 10:          # not the stop sentinel (the cap reached)
                seen[raw] = v
        else:
            problem.calls += 1
        return v

    opt.set_min_objective(f)
    problem.opt = opt
    opt.set_maxeval(max(200 * max_evals, 1000))     # calls; most land in memoised cells
    if step is not None:
        opt.set_initial_step([step] * n)
    if algorithm in ("GN_CRS2_LM", "GN_ISRES", "GN_ESCH"):
        opt.set_population(max(10 * (n + 1), 20))
    nlopt.srand(seed)
    try:
        opt.optimize(list(x0))
    except (nlopt.ForcedStop, nlopt.RoundoffLimited):
        pass
    finally:
        problem.cap = None
        problem.opt = None


def _random_run(problem: Problem, max_evals: int, seed: int):
    rng = np.random.default_rng(seed)
    sizes = [v.size for v in problem.space.variables]
    start = len(problem.memo)
    tries = 0
    while len(problem.memo) - start < max_evals and tries < 50 * max_evals:
        tries += 1
        problem(tuple(int(rng.integers(s)) for s in sizes))


def _neighbours(problem: Problem, cur, pairs: bool, fixed=()) -> list[tuple]:
    """Lattice neighbours: +-1 on a numeric index, any other value of a named
    one (mapping, feed: their order means nothing); with ``pairs``, also +1 on
    one numeric index and -1 on another (a trade under a budget: a cache for a
    copy, units for FIFO words).  Indices in ``fixed`` do not move."""
    sizes = [v.size for v in problem.space.variables]
    named = [isinstance(problem.space.variables[i].values[0], str) for i in range(len(sizes))]
    free = [i for i in problem.free if i not in fixed]
    out = []

    def add(nb):
        out.append(problem.space.canonical(nb))

    for i in free:
        steps = [j for j in range(sizes[i]) if j != cur[i]] if named[i] else \
            [cur[i] + d for d in (-1, 1) if 0 <= cur[i] + d < sizes[i]]
        for j in steps:
            nb = list(cur)
            nb[i] = j
            add(nb)
    if pairs:
        num = [i for i in free if not named[i]]
        if problem.cost_of is not None and problem.budget is not None:
            _trades(problem, cur, num, sizes, add)
        else:
            for i in num:
                for j in num:
                    if i != j and cur[i] + 1 < sizes[i] and cur[j] >= 1:
                        nb = list(cur)
                        nb[i] += 1
                        nb[j] -= 1
                        add(nb)
    return list(dict.fromkeys(out))


def _trades(problem: Problem, cur, num, sizes, add) -> None:
    """Trades under the budget (costs known before evaluating, ``Problem.cost_of``): +1 on one
    numeric index, paid for by the fewest steps down elsewhere that bring the design within
    the budget: -1 on one other index, else -2 on one, else -1 on two (two caches for a copy).
    Only the smallest repairs are kept (a step down not needed to fit is no trade)."""
    def fits(nb):
        return not problem.over_budget(problem.space.canonical(nb))

    for i in num:
        if cur[i] + 1 >= sizes[i]:
            continue
        up = list(cur)
        up[i] += 1
        if fits(up):
            add(up)              # no trade needed (a single step, already in the neighbourhood)
            continue
        found = False
        for j in num:
            for d in (1, 2):
                if j != i and cur[j] >= d:
                    nb = list(up)
                    nb[j] -= d
                    if fits(nb):
                        add(nb)
                        found = True
                        break
        if found:
            continue
        for a, j in enumerate(num):
            for k in num[a + 1:]:
                if i not in (j, k) and cur[j] >= 1 and cur[k] >= 1:
                    nb = list(up)
                    nb[j] -= 1
                    nb[k] -= 1
                    if fits(nb):
                        add(nb)


def compass(problem: Problem, idx, max_evals: int, fixed=()) -> tuple:
    """Polish on the integer lattice: move to the best neighbour while one
    improves; when none does, widen the neighbourhood to pair trades once
    (a budget makes single steps up infeasible and single steps down
    slower: a cache for a copy, units for FIFO words).  A neighbourhood is
    evaluated as one batch (in parallel where the evaluator has workers);
    from a design within the budget, neighbours known to be over it
    (``Problem.cost_of``) are not evaluated.  Indices in ``fixed`` (the
    mapping, from a mapping's own start) do not move.  Stops at a local
    optimum or after ``max_evals`` new designs."""
    cur = problem.space.canonical(idx)
    start = len(problem.memo)
    problem.resolve(problem.memo[cur])
    pairs = False
    while True:
        nbrs = _neighbours(problem, cur, pairs, fixed)
        if problem.f(problem.memo[cur]) < INFEASIBLE:
            nbrs = [k for k in nbrs if k in problem.memo or not problem.over_budget(k)]
        room = max_evals - (len(problem.memo) - start)
        fresh = [k for k in nbrs if k not in problem.memo][:max(room, 0)]
        problem.evaluate_many(fresh)
        cand = [problem.memo[k] for k in nbrs if k in problem.memo]
        here = problem.rank(problem.memo[cur])[:2]
        # a neighbour ruled out by its bound (slower than the incumbent) is not stepped to: the
        # polish walks through designs that can still matter
        better = problem.best_of(cand, below=here, run=False)
        if better is None:
            if pairs or len(problem.memo) - start >= max_evals:
                return cur
            pairs = True
            continue
        cur = better.index
        pairs = False
        if len(problem.memo) - start >= max_evals:
            return cur


def _polish_starts(problem: Problem) -> list[tuple]:
    """Where the polish starts: the stage mappings are separate landscapes, so
    from the best design found of each mapping; where every design found of a
    mapping is over the budget, from that mapping's cheapest design (every
    numeric index at its smallest value) instead, which the polish then grows."""
    space = problem.space
    pos = space.names.index("mapping")
    by_map: dict = {}
    for e in problem.memo.values():
        by_map.setdefault(e.index[pos], []).append(e)
    bests = [problem.best_of(es) for es in by_map.values()]        # each mapping's best, run
    starts = {e.index[pos]: e.index for e in sorted(bests, key=problem.rank) if problem.f(e) < INFEASIBLE}
    if space.variables[pos].size > 1:
        for m in range(space.variables[pos].size):
            if m not in starts:
                idx = [0] * len(space.variables)
                idx[pos] = m
                k = space.canonical(idx)
                problem.evaluate_many([k])
                if k in problem.memo and problem.f(problem.memo[k]) < INFEASIBLE:
                    starts[m] = k
    if not starts:
        starts[-1] = problem.best().index
    return list(starts.values())


def split_by_mapping(space: Space) -> list[Space]:
    """The global phase's starts: one sub-space per stage mapping (separate landscapes; the
    order of a named variable's values means nothing to a method working in x), or the space
    itself when it has one mapping."""
    pos = space.names.index("mapping")
    var = space.variables[pos]
    if var.size == 1:
        return [space]
    return [Space([Var(v.name, (m,)) if i == pos else v for i, v in enumerate(space.variables)], space.shape,
                  space.cost, space.source) for m in var.values]


def global_start(evaluate_points, space: Space, objective: str, budget, algorithm: str, max_evals: int,
                 seed: int, known=(), bound_points=None) -> tuple[list, int]:
    """One start of the global phase: ``algorithm`` over ``space`` (``known``: (point,
    result) pairs evaluated before, not counted).  Returns the new (point, result) pairs in
    evaluation order and NLopt's calls; depends only on its arguments (so it may run in
    another process)."""
    p = Problem(space, evaluate_points, objective, budget, bound_points=bound_points)
    for point, r, bound in known:
        p.add(point, r, bound)
    n0 = len(p.order)
    sizes = [space.variables[i].size for i in p.free]
    if algorithm == "random":
        _random_run(p, max_evals, seed)
    elif algorithm != "none":
        _nlopt_run(p, GLOBAL_ALGORITHMS[algorithm], [s / 2.0 for s in sizes], max_evals, seed)
    else:
        p(p.x_to_index([s / 2.0 for s in sizes]))
    return [(p.memo[k].point, p.memo[k].result, p.memo[k].bound) for k in p.order[n0:]], p.calls


def _local_starts(problem: Problem):
    def run(tasks):
        return [global_start(problem.evaluate_points, *t, bound_points=problem.bound_points) for t in tasks]
    return run


def search(problem: Problem, algorithm: str = "direct-l", polish: str = "lattice", max_evals: int = 1000,
           seed: int = 1, polish_evals: int | None = None, starts: str = "whole", run_starts=None) -> SearchResult:
    """Global search then polish; ``max_evals`` distinct designs for the global phase, shared
    by its starts: one over the whole space (``starts="whole"``, the default: the method
    measured in the README), or one per stage mapping (``"mapping"``, ``split_by_mapping``:
    they can run in parallel, but each sees a share of the evaluations; on the small space
    at 80 evaluations it missed tetra's optimum under 300 kGE, which one start finds).  ``run_starts(tasks)`` runs
    the starts, each task ``global_start``'s arguments after ``evaluate_points``, and returns
    their results in order (default: one after another here; the explorer's runs them on its
    workers); they are merged in the order of the starts, so the result does not depend on
    how they ran."""
    if algorithm not in GLOBAL_ALGORITHMS:
        raise ValueError(f"algorithm must be one of {', '.join(GLOBAL_ALGORITHMS)}, not {algorithm!r}")
    if polish not in POLISHES:
        raise ValueError(f"polish must be one of {', '.join(POLISHES)}, not {polish!r}")
    t0 = time.perf_counter()
    n0 = len(problem.memo)
    if starts not in STARTS:
        raise ValueError(f"starts must be one of {', '.join(STARTS)}, not {starts!r}")
    subs = split_by_mapping(problem.space) if starts == "mapping" else [problem.space]
    tasks = []
    for k, sp in enumerate(subs):
        m = sp.value([0] * len(sp.variables), "mapping") if sp is not problem.space else None
        known = [(e.point, e.result, e.bound) for e in problem.memo.values()
                 if m is None or e.point.design.mapping == m]
        share = max_evals // len(subs) + (1 if k < max_evals % len(subs) else 0)
        tasks.append((sp, problem.objective, problem.budget, algorithm, max(share, 1), seed, known))
    for rows, calls in (run_starts or _local_starts(problem))(tasks):
        problem.calls += calls
        for point, r, bound in rows:
            if problem.add(point, r, bound) is not None and problem.progress:
                problem.progress(problem)
    n1 = len(problem.memo)
    best = problem.best()
    if polish_evals is None:
        polish_evals = max(max_evals, 32 * len(problem.free))        # as many again, at least 32 a variable
    if polish == "lattice":
        starts = _polish_starts(problem)
        # each mapping's start its share within its mapping (a step to another mapping would leave it
        # before its own trades are tried), then the best found gets what is left, anywhere
        fixed = (problem.space.names.index("mapping"),) if len(starts) > 1 else ()
        for idx in starts:
            compass(problem, idx, polish_evals // (len(starts) + 1), fixed)
        compass(problem, problem.best().index, polish_evals - (len(problem.memo) - n1))
    elif polish != "none":
        name = {"sbplx": "LN_SBPLX", "neldermead": "LN_NELDERMEAD", "bobyqa": "LN_BOBYQA", "cobyla": "LN_COBYLA"}
        _nlopt_run(problem, name[polish], problem.index_to_x(best.index), polish_evals, seed, step=1.0)
    n2 = len(problem.memo)
    return SearchResult(problem.best(), len(problem.memo), problem.calls, time.perf_counter() - t0,
                        phases={"global": n1 - n0, "polish": n2 - n1})


def exhaustive(problem: Problem, batch: int = 4096) -> SearchResult:
    """Every distinct design of the space (for checking a search on small spaces)."""
    t0 = time.perf_counter()
    seen = set()
    todo = []
    for idx in itertools.product(*(range(v.size) for v in problem.space.variables)):
        k = problem.space.canonical(idx)
        if k not in seen:
            seen.add(k)
            todo.append(k)
        if len(todo) >= batch:
            problem.evaluate_many(todo)
            todo = []
    problem.evaluate_many(todo)
    return SearchResult(problem.best(), len(problem.memo), problem.calls, time.perf_counter() - t0)


def cost_range(space: Space, unit_costs) -> tuple[float, float]:
    """The cheapest and dearest design of a space (costs need no trace)."""
    from .hwcost import hardware_cost

    lo, hi = math.inf, 0.0
    pos = {v.name: i for i, v in enumerate(space.variables)}
    for m in range(space.variables[pos["mapping"]].size):
        for end in (0, -1):
            idx = [(v.size - 1 if end else 0) for v in space.variables]
            idx[pos["mapping"]] = m
            c = hardware_cost(space.point(space.canonical(idx)).design, unit_costs)
            lo, hi = min(lo, c), max(hi, c)
    return lo, hi


def pareto(problem: Problem, budgets, algorithm="direct-l", polish="lattice", max_evals=200, seed=1) -> SearchResult:
    """The front of cycles against cost: a time search under each budget, sharing evaluations."""
    t0 = time.perf_counter()
    for b in budgets:
        problem.budget = float(b)
        search(problem, algorithm, polish, max_evals, seed)
    problem.budget = None
    front = problem.front()
    return SearchResult(front[0] if front else None, len(problem.memo), problem.calls, time.perf_counter() - t0,
                        front=front)
