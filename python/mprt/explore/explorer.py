"""``explore()``: search a design space for one scene and report the best machine."""
from __future__ import annotations

import time

import numpy as np

from ..errors import MprtError
from .evaluate import DEADLOCK_CYCLES, SceneEvaluator, grid_dims, machine_config
from .hwcost import UnitCosts, cost_breakdown
from .prepass import low_resolution
from .search import Problem, compass, cost_range, pareto, search
from .space import REFERENCE_DESIGNS, Point, Space, SpaceError, Var, default_space, paper_3mppe
from ..atomic import replacing


VERIFY_FREE = ("cache.", "resident.", "pes", "replication.", "fifo")   # what the verification polish varies
# level 2 (the ring without memories) is left out of the ladder: SimPy runs are its cost, and
# where level 2 would do, verifying at 3 costs only its few designs
LADDER_LEVELS = (0, 1, 3)
VERIFY_MORE = 12              # designs further down the ranking verified while all above deadlock
SEARCH_LEVEL_MAX = 1          # the compiled replay: exact, milliseconds a design; SimPy (2, 3) takes seconds


def explore(scene, width: int = 64, height: int = 64, space: Space | None = None, objective: str = "time",
            budget: float | None = None, level: int | str = "auto", tolerance: float = 0.01,
            algorithm: str = "direct-l", polish: str = "lattice", max_evals: int = 1000, seed: int = 1,
            budgets: int = 6, progress=None, threads: int = 1, fraction: int | None = None, refine: int = 2,
            refine_evals: int = 60, sample: str | None = "auto", verify: int = 4, verify_polish: int = 16,
            log=None) -> dict:
    """Search ``space`` for ``scene`` at width x height; returns the report
    as a dict (the JSON of ``mprt explore``).

    Levels: ``level`` 0-3, or "auto": the fidelity ladder is measured on a
    low-resolution trace of the scene for the reference machines and a few
    designs of the space, and the cheapest level within ``tolerance`` of the
    top level (``Table.choose``) is the verification level.  The search runs
    at that level or at level 1 (the compiled replay), whichever is lower;
    when the verification level is higher, the ``verify`` best designs found
    are re-evaluated there and the best one polished at that level
    (``verify_polish`` designs, see ``_verify``), ``log`` reporting each.

    The subdivision changes the trace, so the search runs on traces at
    1/``fraction`` of the resolution (default: about 64 pixels across; 1
    searches at full resolution), as the prepass does.  Then the ``refine``
    best subdivisions are traced at full resolution (``sample``: a sampled
    replay's tiles, scaled to the frame; "auto": ``stratified:16:1`` above
    256x256, the whole frame below) and their designs polished there (lattice
    steps, ``refine_evals`` designs each); the best of those is the answer."""
    t0 = time.perf_counter()
    say = log or (lambda text: None)
    space = space or default_space()
    unit_costs = UnitCosts.from_table(space.cost)
    if fraction is None:
        fraction = max(1, min(width, height) // 64)
    if sample == "auto":
        sample = "stratified:16:1" if width * height > 256 * 256 and fraction > 1 else None
    low = (width, height) if fraction == 1 else low_resolution(width, height, fraction)
    ev = low_ev = SceneEvaluator(scene, *low, level=0, shape=space.shape, unit_costs=unit_costs, threads=threads)
    levels = choose_levels(scene, ev, space, level, tolerance, seed, say)
    ev.level = levels["search"]
    full_space, space = space, searched_space(space, levels)
    problem = Problem(space, ev, objective, budget if objective != "pareto" else None, progress=progress)
    front = []
    if objective == "pareto":
        lo, hi = cost_range(space, unit_costs)
        sweep = np.geomspace(lo * 1.05, hi, budgets)
        res = pareto(problem, sweep, algorithm, polish, max(max_evals // budgets, 20), seed)
        front = res.front
        best = min(front, key=lambda e: (e.cycles * e.cost, e.serial))        # the knee: least time x cost
    else:
        res = search(problem, algorithm, polish, max_evals, seed)
        best = res.best
    history = [dict(r, phase="search", resolution=list(low), level=ev.level) for r in problem.history()]
    evaluations = res.evaluations
    top = [best]
    if fraction > 1:
        full = SceneEvaluator(scene, width, height, level=ev.level, shape=space.shape, unit_costs=unit_costs,
                              threads=threads, sample=sample)
        if objective == "pareto":
            fp = Problem(space, full, "time")
            fp.evaluate_many([e.index for e in front])
            front = [fp.memo[space.canonical(e.index)] for e in front]
            best = min(front, key=lambda e: (e.cycles * e.cost, e.serial))
            history += [dict(r, phase="full", resolution=[width, height], level=ev.level) for r in fp.history()]
            evaluations += len(fp.memo)
            top = [best]
        else:
            top, rows, n = _refine(problem, space, full, objective, budget, refine, refine_evals)
            history += [dict(r, phase="full", resolution=[width, height], level=ev.level) for r in rows]
            evaluations += n
        ev = full
    elif objective != "pareto":
        top = sorted(problem.memo.values(), key=problem.rank)
    if levels["verify"] > levels["search"]:
        # the search's best design of each stage mapping: its level is blind to the ring, which only
        # pipelines use, so its best few can all be pipelines that are slower at the verification's level
        mappings = {}
        if objective != "pareto":
            for e in sorted(problem.memo.values(), key=problem.rank):
                mappings.setdefault(e.point.design.mapping, e)
        best, rows = _verify(full_space, top, verify, levels["verify"], ev, low_ev, objective, budget,
                             verify_polish, say, list(mappings.values()))
        history += [dict(r, level=levels["verify"]) for r in rows]
        evaluations += len(rows)
    else:
        best = top[0]
    for i, r in enumerate(history, 1):
        r["evaluation"] = i
    final = levels["verify"]
    dims = list(grid_dims(scene, best.point.subdivision, space.shape))
    refs = {}
    for name, make in REFERENCE_DESIGNS.items():
        r = ev.run(Point(best.point.subdivision, make()), final)
        refs[name] = {"cycles": r.cycles, "cost": r.cost, "utilisation": r.utilisation, "design": make().to_dict()}
    b = best.result
    report = {
        "scene": scene.name,
        "settings": settings(scene, width, height, threads),
        "width": width, "height": height,
        "objective": objective, "budget": budget,
        "best": {"subdivision": dims, "design": best.point.design.to_dict(), "cycles": best.cycles,
                 "cost": best.cost, "cost_breakdown": cost_breakdown(best.point.design, unit_costs),
                 "utilisation": b.utilisation, "loads": b.loads, "bottleneck": b.bottleneck,
                 "speedup_over_S": refs["S"]["cycles"] / best.cycles if best.cycles else None,
                 "described": best.point.design.describe()},
        "references": refs,
        "evaluations": evaluations,
        "search_resolution": list(low),
        "full_resolution_sample": sample if fraction > 1 else None,
        "nlopt_calls": problem.calls,
        "algorithm": {"global": algorithm, "polish": polish, "max_evals": max_evals, "seed": seed},
        "level": levels,
        "tolerance": tolerance,
        "costs": b.costs,
        "traces": {"made": ev.traces_made, "seconds": ev.trace_seconds},
        "seconds": time.perf_counter() - t0,
        "history": history,
        "space": {"source": space.source, "variables": {v.name: list(v.values) for v in full_space.variables},
                  "searched": {v.name: list(v.values) for v in space.variables},
                  "unit_costs": unit_costs.to_dict()},
    }
    if objective == "pareto":
        report["front"] = [{"subdivision": list(grid_dims(scene, e.point.subdivision, space.shape)),
                            "design": e.point.design.to_dict(), "cycles": e.cycles, "cost": e.cost} for e in front]
        report["budgets"] = [float(x) for x in sweep]
    return report


def searched_space(space: Space, levels: dict) -> Space:
    """The space the search runs over: all of it, except that when the search's
    level has no memories (below 3) and the verification's has, the memory
    sizes are held at the paper's 3MPPE's (the nearest the space offers): a
    level blind to memories would take the smallest, whatever they cost at
    level 3; the verification's polish then varies them."""
    if levels["search"] >= 3 or levels["verify"] < 3:
        return space
    ref = paper_3mppe()
    want = {f"cache.{s}": ref.cache[s] for s in ("IC", "SC")} | {f"resident.{s}": ref.resident[s] for s in ("IC", "SC")}
    out = []
    for v in space.variables:
        if v.name in want and v.size > 1:
            near = min(v.values, key=lambda x: (abs(x - want[v.name]), x))
            v = Var(v.name, (near,))
        out.append(v)
    return Space(out, space.shape, space.cost, space.source)


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


def choose_levels(scene, ev: SceneEvaluator, space: Space, level, tolerance: float, seed: int, say) -> dict:
    """The search level and the verification level: as given (searching at no
    more than level 1), or with "auto" by measuring the ladder on the trace of
    the space's middle subdivision."""
    if level != "auto":
        if level not in (0, 1, 2, 3):
            raise ValueError(f"level must be 0, 1, 2, 3 or 'auto', not {level!r}")
        return {"asked": level, "search": min(level, SEARCH_LEVEL_MAX), "verify": level}
    from ..fidelity import measure

    subs = space.subdivisions()
    sub = subs[len(subs) // 2]
    tev, _ = ev.evaluator(grid_dims(scene, sub, space.shape))
    configs = [machine_config(d, tev.leaves) for d in ladder_designs(space, seed)]
    t0 = time.perf_counter()
    table = measure(tev.trace, configs, levels=LADDER_LEVELS, sample=None, cost_model=tev.cost_model)
    chosen = lowest_adequate(table, tolerance)
    say(f"ladder  {len(configs)} designs on {scene.name} at {ev.width}x{ev.height}, subdivision "
        f"{'x'.join(map(str, grid_dims(scene, sub, space.shape)))}, {time.perf_counter() - t0:.1f} s: "
        f"level {chosen} is the cheapest within {100 * tolerance:g}%")
    return {"asked": "auto", "search": min(chosen, SEARCH_LEVEL_MAX), "verify": chosen,
            "ladder": [r.to_dict() for r in table.rows], "ladder_subdivision": list(sub),
            "ladder_seconds": time.perf_counter() - t0}


class NoLiveDesignError(MprtError, RuntimeError):
    """No design the verification checked runs to the end at its level."""


def _verify(space: Space, top, verify: int, level: int, full: SceneEvaluator, low: SceneEvaluator, objective,
            budget, polish_evals: int, say, per_mapping=()):
    """The ``verify`` best designs of ``top`` (the search's ranking) re-evaluated
    at the verification level at full resolution, and further down the ranking
    (up to ``VERIFY_MORE`` more) while every one verified deadlocks there (the
    levels below have no ring: a window safe on the ideal network can still
    deadlock on it), beside ``per_mapping`` (the search's best of each stage
    mapping, at its own subdivision) and the reference designs (the paper's
    3MPPE, models M and S) at the best's subdivision where the space holds
    them; then a lattice polish from the best one at that level on the
    search's resolution (``polish_evals`` designs) over what the levels below
    are blind to or trade against it (memories, and the copies and PEs that
    share the budget with them), its two best re-evaluated at full resolution.
    Returns the best and the history rows (phases verify and verify-polish)."""
    t0 = time.perf_counter()
    if objective == "pareto":
        objective, budget = "time", None
    vp = Problem(space, lambda pts: [full.run(p, level) for p in pts], objective, budget)

    def check(e_from, what, where):
        k = space.canonical(space.index_of(e_from.point))
        fresh = k not in vp.memo
        vp.evaluate_many([k])
        if fresh:
            e = vp.memo[k]
            say(f"verify  {what} at level {level}: {e.cycles:,.0f} cycles ({where} level {e_from.result.level}: "
                f"{e_from.cycles:,.0f}), cost {e.cost:.0f} kGE, {time.perf_counter() - t0:.1f} s")

    def live():
        b = vp.best()
        return b is not None and b.cycles < DEADLOCK_CYCLES

    n_top = min(verify, len(top))
    for i, e in enumerate(top[:n_top], 1):
        check(e, f"{i}/{n_top}", "searched at")
    for e in per_mapping:
        check(e, f"best {e.point.design.mapping}", "searched at")
    # the paper's designs at the same subdivision, where the space holds them: the search's level cannot
    # see the ring or the memories, so its best few may all be slower at this level than one of these
    for name, make in REFERENCE_DESIGNS.items():
        try:
            k = space.canonical(space.index_of(Point(top[0].point.subdivision, make())))
        except SpaceError:
            continue
        if k not in vp.memo:
            vp.evaluate_many([k])
            say(f"verify  {name} at level {level}: {vp.memo[k].cycles:,.0f} cycles, cost {vp.memo[k].cost:.0f} kGE, "
                f"{time.perf_counter() - t0:.1f} s")
    for i, e in enumerate(top[n_top:n_top + VERIFY_MORE], n_top + 1):
        if live():
            break
        check(e, f"{i} (the ones above deadlock)", "searched at")
    rows = [dict(r, phase="verify", resolution=[full.width, full.height]) for r in vp.history()]
    best = vp.best()
    if polish_evals > 0:
        sub = best.point.subdivision
        sp = space.with_subdivision(sub)
        at = sp.index_of(best.point)
        sp = Space([v if v.name.startswith(VERIFY_FREE) else Var(v.name, (v.values[at[i]],))
                    for i, v in enumerate(sp.variables)], sp.shape, sp.cost, sp.source)
        lp = Problem(sp, lambda pts: [low.run(p, level) for p in pts], objective, budget)
        start = sp.canonical(sp.index_of(best.point))
        lp.evaluate_many([start])
        compass(lp, start, polish_evals)
        say(f"verify  lattice polish at level {level}, {low.width}x{low.height}: {len(lp.memo)} designs, "
            f"{time.perf_counter() - t0:.1f} s")
        rows += [dict(r, phase="verify-polish", resolution=[low.width, low.height]) for r in lp.history()]
        n = len(vp.order)
        for e in sorted(lp.memo.values(), key=lp.rank)[:2]:
            check(e, "polished", f"{low.width}x{low.height} at")
        rows += [dict(r, phase="verify", resolution=[full.width, full.height]) for r in vp.history()[n:]]
        best = vp.best()
    if not live():
        raise NoLiveDesignError(f"explore: every design verified at level {level} deadlocks ({len(vp.memo)} "
                            f"checked at {full.width}x{full.height}): the search's level cannot see the ring; "
                            f"give FIFOs more room in the space, or search at --level {level}")
    return best, rows


def settings(scene, width, height, threads) -> dict:
    """What made a report: the scene and its content hash, the image, the version."""
    from ..options import version
    return {"scene": scene.name, "scene_sha256": scene.content_hash(), "resolution": [width, height],
            "rules": "paper", "threads": threads, "mprt_version": version()}


def _refine(problem, space, full, objective, budget, refine, refine_evals):
    """The ``refine`` best subdivisions of the low-resolution search, each
    with its best design there, re-evaluated and polished at full resolution;
    returns the designs found there, best first."""
    subs = []
    for e in sorted(problem.memo.values(), key=problem.rank):
        if e.point.subdivision not in [s for s, _ in subs]:
            subs.append((e.point.subdivision, e.point.design))
        if len(subs) == refine:
            break
    found, rows, n = [], [], 0
    for sub, design in subs:
        sp = space.with_subdivision(sub)
        fp = Problem(sp, full, objective, budget)
        start = sp.canonical(sp.index_of(Point(sub, design)))
        fp.evaluate_many([start])
        compass(fp, start, refine_evals)
        found += [(fp.rank(e), e) for e in fp.memo.values()]
        rows += fp.history()
        n += len(fp.memo)
    return [e for _, e in sorted(found, key=lambda t: t[0][:2])], rows, n


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
    cyc = np.array([r["cycles"] for r in h]) * scale
    feas = np.array([r["feasible"] for r in h])
    live = np.array([r["cycles"] < DEADLOCK_CYCLES for r in h])
    feas &= live
    full = np.array([r["phase"] == "full" for r in h])
    ver = np.array([r["phase"].startswith("verify") for r in h])
    best = np.minimum.accumulate(np.where(feas, cyc, np.inf))

    def dots(a, mask, *args, **kw):
        if mask.any():                      # no legend entry without points
            a.scatter(*(x[mask] for x in args), **kw)

    dots(ax[0], feas & ~full & ~ver, n, cyc, s=6, c="tab:blue",
         label=f"search at level {lv['search']} (estimate, scaled to full res.)")
    dots(ax[0], feas & full, n, cyc, s=8, c="tab:green", label="full-resolution polish")
    dots(ax[0], feas & ver, n, cyc, s=14, c="tab:purple", marker="D", label=f"verified at level {lv['verify']}")
    dots(ax[0], ~feas & live, n, cyc, s=6, c="tab:gray", marker="x", label="over budget")
    if np.isfinite(best).any():
        ax[0].step(n, best, where="post", c="tab:red", label="best so far")
    ax[0].set(yscale="log", xlabel="evaluation", ylabel="cycles", title="search history")
    _plain_log_axis(ax[0].yaxis)
    cost = np.array([r["cost"] for r in h])
    dead = int((~live).sum())
    dots(ax[1], live & ~ver, cost, cyc, s=6, c="tab:blue", alpha=0.45,
         label=f"evaluated at level {lv['search']} (estimates)" + (f"; {dead} deadlocked left out" if dead else ""))
    dots(ax[1], live & ver, cost, cyc, s=14, c="tab:purple", marker="D", label=f"verified at level {lv['verify']}")
    if report.get("front"):
        fr = sorted((f["cost"], f["cycles"]) for f in report["front"])
        ax[1].step([c for c, _ in fr], [y for _, y in fr], where="post", c="tab:red", marker="o", ms=3,
                   label="Pareto front")
    for (name, r), mk in zip(report["references"].items(), ("s", "^", "v")):
        ax[1].scatter([r["cost"]], [r["cycles"]], marker=mk, s=40, edgecolors="k", zorder=4,
                      label=(f"model {name}" if name != "3mppe" else "paper 3MPPE") + f" (level {lv['verify']})")
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
    ax[2].set(ylim=(0, 1.05), ylabel="utilisation", title="answer (red) and the paper's 3MPPE (grey)")
    fig.suptitle(f"{report['scene']} {report['width']}x{report['height']}: objective {report['objective']}, "
                 f"{report['evaluations']} evaluations, "
                 f"level {lv['search']} (search), {lv['verify']} (verify)")
    fig.tight_layout()
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
