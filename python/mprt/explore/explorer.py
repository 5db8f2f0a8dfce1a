"""``explore()``: search a design space for one scene and report the best machine."""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import MprtError
from .evaluate import DEADLOCK_CYCLES, SceneEvaluator, grid_dims, machine_config
from .hwcost import UnitCosts, cost_breakdown, hardware_cost
from .parallel import Pool
from .prepass import low_resolution
from .refine import CHECK_BEHIND, SCREEN_MARGIN, Screen, refine as _refine
from .problem import front_of
from .search import Problem, cost_range, global_start, pareto, search, walk
from .space import REFERENCE_DESIGNS, Point, Space, default_space
from ..atomic import replacing


# level 2 (the ring without memories) is left out of the ladder: where it would do, level 3 costs little more
LADDER_LEVELS = (0, 1, 3)
# A design's level-1 cycles (no ring, no memories: 5 to 15 ms a design) bound its level-2 and -3 cycles from
# below, but not strictly (the order of events differs): level 3 was up to 3.2% below level 1 on 150 random
# designs of tetra, 1.4% on balls (README).  So a design is ruled out (``Problem.bound_points``) only when
# level 1 less this slack is slower than the incumbent.
BOUND_LEVEL, BOUND_SLACK = 1, 0.10


def _bounds(results) -> list:
    """Lower bounds for a search at level 2 or 3 from level-1 results: the cycles less
    BOUND_SLACK (none, 0 cycles, where level 1 deadlocks)."""
    from dataclasses import replace
    return [replace(r, cycles=0.0 if r.cycles >= DEADLOCK_CYCLES else float(np.floor(r.cycles * (1 - BOUND_SLACK))))
            for r in results]


def _bounder(pool, lv: int, objective: str, bound: bool):
    """SceneEvaluator -> the ``Problem.bound_points`` of a search at level ``lv`` (None: no bounds)."""
    if not bound or lv <= BOUND_LEVEL or objective == "pareto":
        return lambda sev: None
    return lambda sev: (lambda pts: _bounds(pool.run(sev, pts, BOUND_LEVEL)))


PREFETCH_MAX = 32      # subdivisions a search traces ahead, at most


def _prefetch_order(scene, space: Space) -> list:
    """The grids of a space's subdivisions from the middle one outwards (where DIRECT-L begins;
    the walks then step to neighbours): what the search's evaluator traces ahead while the
    global phase replays on one core (none where the space has more than PREFETCH_MAX)."""
    subs = space.subdivisions()
    if len(subs) > PREFETCH_MAX:
        return []
    m = len(subs) // 2
    return [grid_dims(scene, subs[i], space.shape) for i in sorted(range(len(subs)), key=lambda i: (abs(i - m), i))]


def _checks_ahead(scene, space: Space, problem, tasks, verify: int, got) -> tuple:
    """The full-resolution checks (``refine``) as far as the polish's walks tell them, from the
    walks (``tasks``, ``walk``'s arguments, the search's best's first) and those of them ended
    (``got``: {index in ``tasks``: rows}): (grids, designs), most likely first.  The designs:
    the search's best, each ended walk's best (within ``refine.CHECK_BEHIND`` of the best), then
    the ``verify`` best of the search and those walks; the grids: theirs.  What the walks' idle
    cores trace and run ahead; a guess, which changes no result."""
    def dims(point):
        return grid_dims(scene, point.subdivision, space.shape)

    def best(rows):
        return sorted(rows, key=lambda x: (problem.value(x[1].cycles, x[1].cost), x[1].cost))
    known = best([(e.point, e.result) for e in problem.memo.values() if not e.bound] +
                 [(point, r) for i in got for point, r, bound in got[i] if not bound])
    worst = problem.value(known[0][1].cycles, known[0][1].cost) + math.log(CHECK_BEHIND) if known else math.inf
    points = [tasks[0][0].point(tasks[0][4])] if tasks else []
    for i in sorted(got):
        points += [point for point, r in best([(point, r) for point, r, bound in got[i] if not bound])[:1]
                   if problem.value(r.cycles, r.cost) <= worst]
    points += [p for p, _ in known[:verify]]
    points = list({p.key(): p for p in points}.values())          # each once, where it came first
    return list(dict.fromkeys(dims(p) for p in points)), points


def _polish_bounder(bounder, lv: int):
    """``bounder`` (SceneEvaluator -> level-1 ``bound_points`` or None) for a lattice polish: work
    bounds first (``_work_bounds``), level 1 where they cannot be had."""
    def make(sev):
        level1 = bounder(sev)
        return None if level1 is None else _work_bounds(sev, lv, level1)
    return make


def explore(scene, width: int = 64, height: int = 64, space: Space | None = None, objective: str = "time",
            budget: float | None = None, level: int | str = "auto", tolerance: float = 0.01,
            algorithm: str = "direct-l", polish: str = "lattice", max_evals: int = 1000, seed: int = 1,
            budgets: int = 6, progress=None, threads: int = 1, fraction: int | None = None, refine: int = 2,
            refine_evals: int = 60, sample: str | None = "auto", verify: int = 4, workers: int | None = None,
            starts: str = "whole", log=None, rules: str = "paper", threshold: float | None = None,
            grid=None, phases=None, bound: bool = True, screen: float | None = SCREEN_MARGIN) -> dict:
    """Search ``space`` for ``scene`` at width x height; returns the report
    as a dict (the JSON of ``mprt explore``).

    Level: ``level`` 0-3, or "auto": the fidelity ladder is measured on a
    low-resolution trace of the scene for the reference machines and a few
    designs of the space, and the lowest level within ``tolerance`` of the
    top level is taken.  The search, the full-resolution checks and polish
    and the references all run at that one level, every variable of the
    space free (memory sizes included), each evaluation through the fidelity
    ladder's ``evaluate`` with engine "auto" (the compiled replay wherever it
    is exact, SimPy elsewhere).

    The subdivision changes the trace, so the search runs on traces at
    1/``fraction`` of the resolution (default: about 64 pixels across; 1
    searches at full resolution), as the prepass does.  Then the ``verify``
    best designs of the search and its best of each stage mapping are
    evaluated at full resolution (``sample``: a sampled replay's tiles,
    scaled to the frame; "auto": ``stratified:16:1`` above 256x256, the whole
    frame below), and from the ``refine`` best subdivisions among them the
    designs are polished there (lattice steps and pair trades,
    ``refine_evals`` designs each); the best of those is the answer.

    ``workers`` (default: one per core; 1: none) evaluate what does not depend
    on each other in parallel (``parallel.Pool``): the ladder's designs, a
    polish neighbourhood, the full-resolution checks, the references and,
    with ``starts="mapping"``, the global phase's starts.  While the polish's
    walks leave a worker idle, this process traces and runs the likely
    full-resolution checks and the references ahead on that core
    (``SceneEvaluator.prefetch``).  The answer does not depend on their number.

    Every trace is made under ``rules`` with the cutoff ``threshold`` (None: the library's
    default), as ``mprt render``'s.  ``grid`` (N, or (nx, ny, nz)) fixes the subdivision: N
    voxels per axis, the space's subdivision variables held at it (no subdivision search).

    ``phases`` (an ``mprt.progress.Phases``; default: silent) is told each phase as it starts,
    numbered, with its estimated time (from the phases before it: the ladder's seconds per
    design, the search's per evaluation scaled by the pixels), and draws its progress.

    ``bound`` (at levels 2 and 3, objectives other than pareto): each new design is first
    bounded; one whose bound is already slower than the best design run so far, or that is
    over the budget, is not replayed at the search's level (``Problem.bound_points``), and
    one known so is replayed as soon as a choice would take it.  In the global phase the
    bound is the design's level-1 replay less BOUND_SLACK (the global method is told it);
    from the lattice polish on, its work bound (``_work_bounds``: each stage's work over its
    processors, nothing run, below a run at any level), as the polish's steps do not depend
    on which designs the bounds rule out.  The search then makes the choices it makes
    without bounds while level 3 stays above level 1 less the slack, in far fewer level-3
    replays.

    ``screen`` (with ``bound``; None: off): the full-resolution polish's neighbours are first
    estimated from the search's own low-resolution replay, scaled by the polish start's ratio
    of full to low resolution, less this margin (``refine.Screen``); one whose estimate is
    slower than the polish's best is not replayed at full resolution."""
    if grid is not None:
        space = (space or default_space()).with_subdivision((grid,) * 3 if isinstance(grid, int) else grid)
    pool = Pool(scene, workers)
    try:
        return _explore(scene, width, height, space, objective, budget, level, tolerance, algorithm, polish,
                        max_evals, seed, budgets, progress, threads, fraction, refine, refine_evals, sample, verify,
                        starts, log or (lambda text: None), pool, rules, threshold, grid, phases or _Silent(), bound,
                        screen)
    finally:
        if pool.before_fork is not None:      # (left set where it failed: ends a prefetch still running)
            pool.before_fork()
        pool.close()


def _sev_bounds(sev, bound: bool):
    """The level-1 bounds (``_bounds``) of points on a SceneEvaluator, in this process (None: no bounds)."""
    return (lambda pts: _bounds([sev.run(p, BOUND_LEVEL) for p in pts])) if bound else None


def _global_task(sev, level, bound, task):
    """One start of the global phase on a SceneEvaluator (in a worker or here); ``bound``: with
    level-1 bounds (``_bounds``)."""
    return global_start(lambda pts: [sev.run(p, level) for p in pts], *task, bound_points=_sev_bounds(sev, bound))


def _work_bounds(sev, level: int, level1):
    """Bounds of points on a SceneEvaluator for the polish: each design's work bound at the search's
    level (``SceneEvaluator.work_bound``: nothing run), or where the compiled replay would not run it,
    ``level1``'s (points -> level-1 bounds)."""
    def bounds(points):
        out = [sev.work_bound(p, level) for p in points]
        miss = [i for i, b in enumerate(out) if b is None]
        for i, b in zip(miss, level1([points[i] for i in miss]) if miss else ()):
            out[i] = b
        return out
    return bounds


def _walk_task(sev, level, bound, task):
    """One mapping's polish walk on a SceneEvaluator (in a worker or here); ``bound``: with
    work bounds (``_work_bounds``)."""
    return walk(lambda pts: [sev.run(p, level) for p in pts], *task,
                bound_points=_work_bounds(sev, level, _sev_bounds(sev, True)) if bound else None,
                cost_of=lambda p: hardware_cost(p.design, sev.unit_costs))


def _explore(scene, width, height, space, objective, budget, level, tolerance, algorithm, polish, max_evals, seed,
             budgets, progress, threads, fraction, refine, refine_evals, sample, verify, starts, say, pool,
             rules="paper", threshold=None, grid=None, phases=None, bound=True, screen=SCREEN_MARGIN) -> dict:
    t0 = time.perf_counter()
    space = space or default_space()
    unit_costs = UnitCosts.from_table(space.cost)
    if fraction is None:
        fraction = max(1, min(width, height) // 64)
    if sample == "auto":
        sample = "stratified:16:1" if width * height > 256 * 256 and fraction > 1 else None
    low = (width, height) if fraction == 1 else low_resolution(width, height, fraction)
    phases.n = (level == "auto") + 1 + (fraction > 1) * (1 if objective == "pareto" else 2) + 1
    ev = SceneEvaluator(scene, *low, level=0, shape=space.shape, unit_costs=unit_costs, threads=threads, rules=rules,
                        threshold=threshold)
    if level == "auto":
        with phases.step(f"ladder: {len(ladder_designs(space, seed))} designs at levels "
                         f"{', '.join(map(str, LADDER_LEVELS))} on a {low[0]}x{low[1]} trace"):
            said = []          # its line after the step's (a bar may be drawn meanwhile)
            levels = choose_levels(scene, ev, space, level, tolerance, seed, said.append, pool)
        for text in said:
            say(text)
    else:
        levels = choose_levels(scene, ev, space, level, tolerance, seed, say, pool)
    ev.level = lv = levels["search"]
    per_eval = _seconds_per_design(levels, lv, pool.workers)
    # the polish may take as many designs again as the global phase, at least 32 a free variable
    n_search = max_evals + max(max_evals, 32 * sum(v.size > 1 for v in space.variables))
    phases.line(f"search: up to {max_evals} designs ({algorithm}), then the {polish} polish, at level {lv}, "
                f"{low[0]}x{low[1]}", None if per_eval is None else per_eval * n_search)
    t_search = time.perf_counter()
    cost_of = lambda p: hardware_cost(p.design, unit_costs)  # noqa: E731
    bounder = _bounder(pool, lv, objective, bound)
    # the full-resolution evaluator, made now: the walks' idle cores trace its checks' grids ahead
    full = None if fraction == 1 else SceneEvaluator(scene, width, height, level=lv, shape=space.shape,
                                                     unit_costs=unit_costs, threads=threads, sample=sample,
                                                     rules=rules, threshold=threshold)
    problem = Problem(space, lambda pts: pool.run(ev, pts, lv), objective,
                      budget if objective != "pareto" else None, progress=progress, cost_of=cost_of,
                      bound_points=bounder(ev))
    run_starts = lambda tasks: pool.map(_global_task, ev,  # noqa: E731
                                        [(lv, problem.bound_points is not None, t) for t in tasks])
    front = []
    if objective == "pareto":
        lo, hi = cost_range(space, unit_costs)
        sweep = np.geomspace(lo * 1.05, hi, budgets)
        res = pareto(problem, sweep, algorithm, polish, max(max_evals // budgets, 20), seed)
        front = res.front
        best = _knee(front, lv, res.evaluations)
    else:
        def run_walks(tasks):
            # the walks report nothing until they end: say what runs meanwhile
            say(f"polish  walks from each of {len(tasks)} stage mappings' best, up to {tasks[0][5]} designs "
                f"each, on {min(pool.workers, len(tasks))} worker(s); then from the best")
            # the first start is the search's best: its neighbours are mostly slower than the incumbent,
            # itself, so its walk is the shortest (0.3-1.1 s of the six SPD scenes' 1.3 to 7.7 s walks at
            # 512x512): given last, the others first, the workers end closer together (the results
            # keep the starts' order, so the answer is the same)
            order = list(range(1, len(tasks))) + [0] if len(tasks) > 2 else list(range(len(tasks)))
            def ahead(got):
                dims, points = _checks_ahead(scene, space, problem, tasks, verify,
                                             {order[k]: rows for k, rows in got.items()})
                # then the references, at the grid of the search's best (the answer's, most often)
                full.prefetch(dims, points + [Point(points[0].subdivision, make())
                                              for make in REFERENCE_DESIGNS.values()])
            done = pool.map_forked(_walk_task, ev, [(lv, problem.bound_points is not None, tasks[i]) for i in order],
                                   idle=None if full is None else ahead)
            out = [None] * len(tasks)
            for i, rows in zip(order, done):
                out[i] = rows
            return out
        polish_bounds = None if problem.bound_points is None else _work_bounds(ev, lv, problem.bound_points)
        pool.before_fork = lambda: [e.stop_prefetch() for e in (ev, full) if e is not None]
        if starts == "whole" and pool.workers > 1:     # the global phase replays on one core: trace on the other
            ev.prefetch(_prefetch_order(scene, space))
        try:
            res = search(problem, algorithm, polish, max_evals, seed, starts=starts, run_starts=run_starts,
                         run_walks=run_walks, polish_bounds=polish_bounds)
        except BaseException:
            pool.before_fork()
            raise
        finally:
            ev.stop_prefetch()
        best = res.best
    say(f"search  {len(problem.memo)} designs at level {lv}, {low[0]}x{low[1]}"
        f"{_ruled_out(problem)}: best {best.cycles:,.0f} cycles, cost {best.cost:.0f} kGE, "
        f"{time.perf_counter() - t0:.1f} s")
    scr = None
    history = []        # after the search's rows (below: the full-resolution phase may run designs it bounded)
    runs = {}
    evaluations = res.evaluations
    per_eval = (time.perf_counter() - t_search) / max(len(problem.memo), 1)   # at the search's resolution
    if fraction > 1:
        per_eval *= width * height / (low[0] * low[1]) * (_sample_fraction(sample, width, height) if sample else 1)
        if objective == "pareto":
            fp = Problem(space, lambda pts: pool.run(full, pts, lv), "time")
            with phases.step(f"front at {width}x{height}: {len(front)} designs", per_eval * len(front)):
                fp.evaluate_many([e.index for e in front])
            front = front_of([fp.memo[space.canonical(e.index)] for e in front])     # (less any that deadlock here)
            best = _knee(front, lv, len(fp.memo))
            history += [dict(r, phase="full", resolution=[width, height], level=lv) for r in fp.history()]
            evaluations += len(fp.memo)
        else:
            scr = Screen(problem, ev, lv, screen) if screen is not None and problem.bound_points is not None else None
            full.stop_prefetch()          # (the refinement runs on it: one design at a time)
            best, rows, n, ran = _refine(problem, space, full, objective, budget, refine, refine_evals, verify,
                                         pool, cost_of, phases, per_eval, _polish_bounder(bounder, lv), scr)
            history += [dict(r, resolution=[width, height], level=lv) for r in rows]
            evaluations += n
            runs.update(full=ran, full_bounded=n - ran)
            say(f"full    {n} designs at level {lv}, {width}x{height}"
                f"{' (' + sample + ')' if sample else ''}{_ruled_out(n=n, ran=ran, screened=scr is not None)}"
                f"{_screened(scr, low)}: best {best.cycles:,.0f} cycles, "
                f"cost {best.cost:.0f} kGE, {time.perf_counter() - t0:.1f} s")
        ev = full
    history[:0] = [dict(r, phase="search", resolution=list(low), level=lv) for r in problem.history()]
    runs.update(search=problem.runs, search_bounded=len(problem.memo) - problem.runs)
    pool.before_fork = None
    if best.cycles >= DEADLOCK_CYCLES:
        raise NoLiveDesignError.at(lv, evaluations)
    for i, r in enumerate(history, 1):
        r["evaluation"] = i
    dims = list(grid_dims(scene, best.point.subdivision, space.shape))
    refs = {}
    made = {name: make() for name, make in REFERENCE_DESIGNS.items()}
    with phases.step(f"references: the paper's 3MPPE, models M and S at level {lv}, {ev.width}x{ev.height}",
                     per_eval * len(made) if fraction > 1 else None):
        got = pool.run(ev, [Point(best.point.subdivision, d) for d in made.values()], lv)
    for (name, d), r in zip(made.items(), got):
        refs[name] = {"cycles": None if r.deadlocked else r.cycles, "cost": r.cost, "utilisation": r.utilisation,
                      "deadlock": r.deadlocked, "design": d.to_dict()}
    b = best.result
    report = {
        "scene": scene.name,
        "settings": settings(scene, width, height, threads, rules, threshold, grid),
        "width": width, "height": height,
        "objective": objective, "budget": budget,
        "best": {"subdivision": dims, "design": best.point.design.to_dict(), "cycles": best.cycles,
                 "cost": best.cost, "cost_breakdown": cost_breakdown(best.point.design, unit_costs),
                 "utilisation": b.utilisation, "loads": b.loads, "bottleneck": b.bottleneck,
                 "speedup_over_S": refs["S"]["cycles"] / best.cycles if best.cycles and refs["S"]["cycles"] else None,
                 "described": best.point.design.describe()},
        "references": refs,
        "evaluations": evaluations,
        "runs": runs,
        "bound": {"level": BOUND_LEVEL, "slack": BOUND_SLACK, "polish": "work"}
        if problem.bound_points is not None else None,
        "screen": scr.report() if scr is not None else None,
        "search_resolution": list(low),
        "full_resolution_sample": sample if fraction > 1 else None,
        "nlopt_calls": problem.calls,
        "algorithm": {"global": algorithm, "polish": polish, "max_evals": max_evals, "seed": seed, "starts": starts},
        "workers": pool.workers,
        "level": levels,
        "tolerance": tolerance,
        "costs": b.costs,
        "traces": {"made": ev.traces_made, "seconds": ev.trace_seconds},
        "seconds": time.perf_counter() - t0,
        "history": history,
        "space": {"source": space.source, "variables": {v.name: list(v.values) for v in space.variables},
                  "unit_costs": unit_costs.to_dict()},
    }
    if objective == "pareto":
        report["front"] = [{"subdivision": list(grid_dims(scene, e.point.subdivision, space.shape)),
                            "design": e.point.design.to_dict(), "cycles": e.cycles, "cost": e.cost} for e in front]
        report["budgets"] = [float(x) for x in sweep]
    return report


def ladder_designs(space: Space, seed: int, extra: int = 2) -> list:
    """The designs the ladder is measured on: the paper's 3MPPE, models M and S,
    and ``extra`` designs of the space drawn with the seed."""
    designs = [make() for make in REFERENCE_DESIGNS.values()]
    rng = np.random.default_rng(seed)
    for _ in range(extra):
        idx = [int(rng.integers(v.size)) for v in space.variables]
        designs.append(space.point(space.canonical(idx)).design)
    return designs


def lowest_adequate(table, tolerance: float) -> int:
    """The lowest level whose worst error against the top level is within the
    tolerance (the top level when none is).  ``Table.choose`` takes the fastest
    measured; the levels are in order of cost, and choosing by their order
    keeps the explorer's result independent of timings on a busy machine."""
    ok = [r.level for r in table.rows if r.error_top_worst <= tolerance]
    return min(ok) if ok else table.rows[-1].level


def _ladder_task(sev, dims, design, levels):
    """One design of the ladder at every level on the trace of ``dims``: {level: (cycles or
    None on deadlock, seconds, engine)}."""
    from ..machine.errors import DeadlockError

    tev, _ = sev.evaluator(dims)
    cfg = machine_config(design, tev.leaves)
    out = {}
    for lv in levels:
        try:
            e = tev.evaluator(cfg).evaluate(cfg, lv)
            out[lv] = (e.cycles, e.seconds, e.engine)
        except DeadlockError:
            out[lv] = (None, None, None)
    return out


def choose_levels(scene, ev: SceneEvaluator, space: Space, level, tolerance: float, seed: int, say,
                  pool: Pool | None = None) -> dict:
    """The level of the search and of everything after it: as given, or with "auto" the
    lowest adequate one (``lowest_adequate``) of the ladder measured on the trace of the
    space's middle subdivision, its designs evaluated in parallel on ``pool``'s workers.
    (``verify`` is the same level: kept in the report for its readers.)"""
    if level != "auto":
        if level not in (0, 1, 2, 3):
            raise ValueError(f"level must be 0, 1, 2, 3 or 'auto', not {level!r}")
        return {"asked": level, "search": level, "verify": level}
    from ..fidelity.ladder import tabulate

    pool = pool or Pool(scene, 1)
    subs = space.subdivisions()
    sub = subs[len(subs) // 2]
    dims = grid_dims(scene, sub, space.shape)
    designs = ladder_designs(space, seed)
    t0 = time.perf_counter()
    got = pool.map(_ladder_task, ev, [(dims, d, LADDER_LEVELS) for d in designs])
    names = [f"design#{i}" for i in range(len(designs))]
    cycles = {(n, lv): g[lv][0] for n, g in zip(names, got) for lv in LADDER_LEVELS}
    seconds = {lv: [g[lv][1] for g in got if g[lv][1] is not None] for lv in LADDER_LEVELS}
    engines = {lv: {g[lv][2] for g in got if g[lv][2] is not None} for lv in LADDER_LEVELS}
    table = tabulate(names, list(LADDER_LEVELS), cycles, seconds, engines)
    chosen = lowest_adequate(table, tolerance)
    say(f"ladder  {len(designs)} designs on {scene.name} at {ev.width}x{ev.height}, subdivision "
        f"{'x'.join(map(str, dims))}, {time.perf_counter() - t0:.1f} s: "
        f"level {chosen} is the lowest within {100 * tolerance:g}%; the search runs there")
    return {"asked": "auto", "search": chosen, "verify": chosen,
            "ladder": [r.to_dict() for r in table.rows], "ladder_subdivision": list(sub),
            "ladder_seconds": time.perf_counter() - t0}


class _Silent:
    """Phases told to no one (``explore`` without ``phases``)."""
    n = 0

    def step(self, name, estimate=None):
        from contextlib import nullcontext
        return nullcontext()

    def line(self, name, estimate=None):
        pass


def _seconds_per_design(levels: dict, lv: int, workers: int):
    """The ladder's mean seconds per design at level ``lv`` over the workers (None: no ladder)."""
    for row in levels.get("ladder") or ():
        if row.get("level") == lv and row.get("seconds_per_design"):
            return float(row["seconds_per_design"]) / max(workers, 1)
    return None


def _sample_fraction(sample: str, width: int, height: int) -> float:
    """The share of a frame's tiles a tile sample traces (for the estimate only): N of them for
    random:N, one in K for stratified:K and regular:K."""
    from ..fidelity import Sampling
    s = Sampling.parse(sample)
    tiles = -(-width // 16) * -(-height // 16)
    return min(s.k / tiles if s.method == "random" else 1 / max(s.k, 1), 1.0)


def _ruled_out(problem=None, n=None, ran=None, screened: bool = False) -> str:
    """', N run, M ruled out by their bounds' (nothing when none was)."""
    if problem is not None:
        n, ran = len(problem.memo), problem.runs
    by = "their bounds" + (" or the screen" if screened else "")
    return f" ({ran} replayed, {n - ran} ruled out by {by})" if n != ran else ""


def _screened(scr, low) -> str:
    """The full phase's line on the screen: margin, designs it alone ruled out, worst error (or nothing)."""
    if scr is None:
        return ""
    r = scr.report()
    worst = "" if r["worst_below"] is None else f", worst error on those replayed {100 * r['worst_below']:+.1f}%"
    return (f"; the polish screened by the {low[0]}x{low[1]} replay less {100 * r['margin']:g}%: "
            f"{r['ruled_out']} of those ruled out by it alone{worst}")


class NoLiveDesignError(MprtError, RuntimeError):
    """No design the explorer evaluated runs to the end at its level."""

    @classmethod
    def at(cls, level, evaluations) -> "NoLiveDesignError":
        return cls(f"explore: every design evaluated at level {level} deadlocks ({evaluations} designs): "
                   "give the FIFOs more room in the space")


def _knee(front, level, evaluations):
    """The front's knee (least time x cost); an error where every design deadlocked (no front)."""
    if not front:
        raise NoLiveDesignError.at(level, evaluations)
    return min(front, key=lambda e: (e.cycles * e.cost, e.serial))


def settings(scene, width, height, threads, rules: str = "paper", threshold=None, grid=None) -> dict:
    """What made a report: the scene and its content hash, the image, the rules and cutoff of
    its traces, the subdivision when it was fixed (``grid``: None when searched), the version."""
    from ..options import threshold_setting, version
    return {"scene": scene.name, "scene_sha256": scene.content_hash(), "resolution": [width, height],
            "rules": rules, "threshold": threshold_setting(rules, threshold),
            "grid": None if grid is None else ([grid] * 3 if isinstance(grid, int) else list(grid)),
            "threads": threads, "mprt_version": version()}


def _plain_log_axis(axis) -> None:
    """A log axis labelled 1, 2, 5 x 10^k in plain numbers, minor ticks unlabelled (no overlaps)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:,.0f}" if v >= 1 else f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def plot(report: dict, path) -> None:
    """History, cycles against cost (with the front), and the best design's
    utilisation per processor beside the paper's 3MPPE.  The search's points are
    estimates at the search's level (scaled to the full resolution); the star is the
    answer, verified at the verification's level: the legends say which is which, and
    sit below the axes so that they cover no data."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(16, 5.6))
    h = report["history"]
    lv = report["level"]
    n = np.array([r["evaluation"] for r in h])
    W, H = report["width"], report["height"]
    # search-phase cycles scaled to the full resolution (the prepass's prediction)
    scale = np.array([W * H / (r["resolution"][0] * r["resolution"][1]) for r in h])
    live = np.array([r["cycles"] is not None for r in h], bool)      # (a design that deadlocked has none)
    cyc = np.array([r["cycles"] if r["cycles"] is not None else np.nan for r in h], float) * scale
    feas = np.array([r["feasible"] for r in h], bool)
    feas &= live
    full = np.array([r["phase"].startswith("full") for r in h])
    ver = np.array([r["phase"].startswith("verify") for r in h])
    bnd = np.array([bool(r.get("bound")) for r in h])          # known by a level-1 bound only: not drawn as cycles
    feas &= ~bnd
    best = np.minimum.accumulate(np.where(feas, cyc, np.inf))

    def dots(a, mask, *args, **kw):
        if mask.any():                      # no legend entry without points
            a.scatter(*(x[mask] for x in args), **kw)

    dots(ax[0], feas & ~full & ~ver, n, cyc, s=6, c="tab:blue",
         label=f"search at level {lv['search']} (estimate, scaled to full res.)")
    dots(ax[0], feas & full, n, cyc, s=8, c="tab:green", label="full-resolution polish")
    dots(ax[0], feas & ver, n, cyc, s=14, c="tab:purple", marker="D", label=f"verified at level {lv['verify']}")
    dots(ax[0], ~feas & live & ~bnd, n, cyc, s=6, c="tab:gray", marker="x", label="over budget")
    dots(ax[0], bnd & live, n, cyc, s=4, c="lightgray", label="ruled out by its bound")
    if np.isfinite(best).any():
        ax[0].step(n, best, where="post", c="tab:red", label="best so far")
    ax[0].set(yscale="log", xlabel="evaluation", ylabel="cycles", title="search history")
    _plain_log_axis(ax[0].yaxis)
    cost = np.array([r["cost"] for r in h])
    dead = int((~live).sum())
    dots(ax[1], live & ~ver & ~bnd, cost, cyc, s=6, c="tab:blue", alpha=0.45,
         label=f"evaluated at level {lv['search']} (estimates)" + (f"; {dead} deadlocked left out" if dead else ""))
    dots(ax[1], live & ver, cost, cyc, s=14, c="tab:purple", marker="D", label=f"verified at level {lv['verify']}")
    if report.get("front"):
        fr = sorted((f["cost"], f["cycles"]) for f in report["front"])
        ax[1].step([c for c, _ in fr], [y for _, y in fr], where="post", c="tab:red", marker="o", ms=3,
                   label="Pareto front")
    for (name, r), mk in zip(report["references"].items(), ("s", "^", "v")):
        dead = r["cycles"] is None          # deadlocks at this level: a legend entry, no point
        ax[1].scatter([] if dead else [r["cost"]], [] if dead else [r["cycles"]], marker=mk, s=40, edgecolors="k",
                      zorder=4, label=(f"model {name}" if name != "3mppe" else "paper 3MPPE") + f" (level {lv['verify']})"
                      + (": deadlocks, not drawn" if dead else ""))
    ax[1].scatter([report["best"]["cost"]], [report["best"]["cycles"]], marker="*", s=220, c="gold",
                  edgecolors="k", label=f"answer (level {lv['verify']})", zorder=5)
    if report.get("budget"):
        ax[1].axvline(report["budget"], c="k", ls=":", lw=1, label="budget")
    ax[1].set(xscale="log", yscale="log", xlabel="cost (kGE)", ylabel="cycles", title="cycles against cost")
    _plain_log_axis(ax[1].xaxis)
    _plain_log_axis(ax[1].yaxis)
    for a in ax[:2]:
        a.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, frameon=False)
    bu, pu = report["best"]["utilisation"], report["references"]["3mppe"]["utilisation"]
    names = list(bu) + [f"{k} (3MPPE)" for k in pu]
    vals = list(bu.values()) + list(pu.values())
    colours = ["tab:red"] * len(bu) + ["tab:gray"] * len(pu)
    ax[2].bar(range(len(vals)), vals, color=colours)
    ax[2].set_xticks(range(len(vals)), names, rotation=30, ha="right", fontsize=8)
    ax[2].set(ylim=(0, 1.05), ylabel="utilisation", title="answer (red) and the paper's 3MPPE (grey)"
              + ("\n(the 3MPPE deadlocks: no bars of its own)" if report["references"]["3mppe"]["cycles"] is None else ""))
    fig.suptitle(f"{report['scene']} {report['width']}x{report['height']}: objective {report['objective']}, "
                 f"{report['evaluations']} evaluations, "
                 f"level {lv['search']}")
    fig.tight_layout()
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
