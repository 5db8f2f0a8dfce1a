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

import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np

from .problem import INFEASIBLE, OBJECTIVES, Evaluation, Problem  # noqa: F401 (the search's names)
from .space import Space, Var

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
# NLopt stops after this many calls in a row that found no new design.  On a lattice its methods go on
# dividing cells already known: on the six SPD scenes at 512x512 DIRECT-L found its last new design by
# the 330th call, never more than 73 calls after the one before, then made 199,700 more calls, 3-4 s of
# the explorer's time, that found nothing.  (On the small test space with 200 designs asked for it finds
# its 119 designs by call 13,617 and no more in its 40,000; asked for 400, 3 more after 23,617.)
IDLE_CALLS = 10_000
STARTS = ("whole", "mapping")    # the global phase: one start over the space, or one per stage mapping
POLISHES = ("lattice", "sbplx", "neldermead", "bobyqa", "cobyla", "none")


@dataclass
class SearchResult:
    best: Evaluation | None
    evaluations: int
    calls: int
    seconds: float
    history: list = field(default_factory=list)
    front: list = field(default_factory=list)
    phases: dict = field(default_factory=dict)      # evaluations spent in each phase


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
    # the cell's objective is kept by its raw index vector (x truncated, as bytes: within the
    # bounds that is floor(x); any other x gets its own entry, holding what the memo gives it),
    # so a revisit costs a conversion and a dictionary look-up (the search is unchanged)
    seen: dict = {}
    idle = 0                # calls since the last that found a new design

    def f(x, grad):
        nonlocal idle
        raw = np.asarray(x).astype(np.int64).tobytes()
        v = seen.get(raw)
        if v is None:
            n = len(problem.memo)
            v = problem(problem.x_to_index(x))
            if v < INFEASIBLE * 10:          # not the stop sentinel (the cap reached)
                seen[raw] = v
            idle = 0 if len(problem.memo) > n else idle + 1
        else:
            problem.calls += 1
            idle += 1
        if idle >= IDLE_CALLS and problem.opt is not None:
            problem.opt.force_stop()        # (not the closure's opt: a cycle that would hold the traces)
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
    numeric index, paid for by each minimal repair of up to two steps down elsewhere that brings
    the design within the budget: -1 on one other index, -2 on one where -1 there does not fit,
    -1 on two where neither alone fits (two caches for a copy, a unit and a cache for a copy).
    A repair with a step down not needed to fit is no trade; a cheap repair elsewhere (a PE
    for a copy) does not hide the one that keeps the PEs (every minimal one is tried)."""
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
        alone = {}               # index -> whether -1 there alone fits
        for j in num:
            if j != i and cur[j] >= 1:
                nb = list(up)
                nb[j] -= 1
                alone[j] = fits(nb)
                if alone[j]:
                    add(nb)
                elif cur[j] >= 2:
                    nb[j] -= 1
                    if fits(nb):
                        add(nb)
        short = [j for j in alone if not alone[j]]
        for a, j in enumerate(short):
            for k in short[a + 1:]:
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
        # a neighbour ruled out by its bound is replayed only if its bound beats the current design
        # (a walk from a mapping's start goes through designs slower than the incumbent: it is the
        # hedge that sends each mapping's best to full resolution, so it walks as it would unbounded)
        better = problem.best_of(cand, below=here)
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
                 seed: int, known=(), bound_points=None, progress=None) -> tuple[list, int]:
    """One start of the global phase: ``algorithm`` over ``space`` (``known``: (point,
    result) pairs evaluated before, not counted).  Returns the new (point, result) pairs in
    evaluation order and NLopt's calls; depends only on its arguments (so it may run in
    another process).  ``progress(problem)`` is told after each new design, as the search's own
    problem tells it."""
    p = Problem(space, evaluate_points, objective, budget, bound_points=bound_points, progress=progress)
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


def walk(evaluate_points, space: Space, objective: str, budget, known, idx, max_evals: int, fixed=(),
         bound_points=None, cost_of=None) -> list:
    """One mapping's polish walk (``compass`` from ``idx``) on a problem of its own that knows
    ``known`` ((point, result, bound) triples: the search so far).  Returns the designs it
    evaluated, in order, and those of ``known`` it ran where they were known by their bounds,
    as (point, result, bound); depends only on its arguments (so it may run in another
    process).  The walks of different mappings share no design, and a walk's steps do not
    depend on which designs its bounds ruled out (``Problem.ranked``), so walking on the
    search's state before the walks gives the steps walking after the others would."""
    p = Problem(space, evaluate_points, objective, budget, cost_of=cost_of, bound_points=bound_points)
    for point, r, bound in known:
        p.add(point, r, bound)
    n0 = len(p.order)
    was_bound = {k for k in p.order if p.memo[k].bound}
    compass(p, idx, max_evals, fixed)
    ran = [k for k in p.order[:n0] if k in was_bound and not p.memo[k].bound]
    return [(p.memo[k].point, p.memo[k].result, p.memo[k].bound) for k in ran + p.order[n0:]]


def _local_starts(problem: Problem):
    def run(tasks):
        return [global_start(problem.evaluate_points, *t, bound_points=problem.bound_points,
                             progress=problem.progress) for t in tasks]
    return run


def search(problem: Problem, algorithm: str = "direct-l", polish: str = "lattice", max_evals: int = 1000,
           seed: int = 1, polish_evals: int | None = None, starts: str = "whole", run_starts=None,
           run_walks=None, polish_bounds=None) -> SearchResult:
    """Global search then polish; ``max_evals`` distinct designs for the global phase, shared
    by its starts: one over the whole space (``starts="whole"``, the default: the method
    measured in the README), or one per stage mapping (``"mapping"``, ``split_by_mapping``:
    they can run in parallel, but each sees a share of the evaluations; on the small space
    at 80 evaluations it missed tetra's optimum under 300 kGE, which one start finds).  ``run_starts(tasks)`` runs
    the starts, each task ``global_start``'s arguments after ``evaluate_points``, and returns
    their results in order (default: one after another here; the explorer's runs them on its
    workers); they are merged in the order of the starts, so the result does not depend on
    how they ran.  ``run_walks(tasks)`` likewise runs the polish's walks from each mapping's
    start (each task ``walk``'s arguments after ``evaluate_points``; default: one after
    another on this problem), merged in the order of the starts.  ``polish_bounds`` (with the
    lattice polish and a problem with bounds): the problem's ``bound_points`` from the polish
    on, e.g. cheaper ones (the lattice's steps do not depend on which designs the bounds rule
    out, only the global method is told a bound)."""
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
        for point, r, bound in rows:       # (run here, the starts told the progress as they ran)
            if problem.add(point, r, bound) is not None and problem.progress and run_starts is not None:
                problem.progress(problem)
    n1 = len(problem.memo)
    best = problem.best()
    if polish_evals is None:
        polish_evals = max(max_evals, 32 * len(problem.free))        # as many again, at least 32 a variable
    if polish == "lattice":
        if polish_bounds is not None and problem.bound_points is not None:
            problem.bound_points = polish_bounds
        starts = _polish_starts(problem)
        # each mapping's start its share within its mapping (a step to another mapping would leave it
        # before its own trades are tried), then the best found gets what is left, anywhere
        fixed = (problem.space.names.index("mapping"),) if len(starts) > 1 else ()
        share = polish_evals // (len(starts) + 1)
        if run_walks is not None and len(starts) > 1:
            known = [(problem.memo[k].point, problem.memo[k].result, problem.memo[k].bound) for k in problem.order]
            for rows in run_walks([(problem.space, problem.objective, problem.budget, known, idx, share, fixed)
                                   for idx in starts]):
                for point, r, bound in rows:
                    if problem.add(point, r, bound) is not None and problem.progress:
                        problem.progress(problem)
        else:
            for idx in starts:
                compass(problem, idx, share, fixed)
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
