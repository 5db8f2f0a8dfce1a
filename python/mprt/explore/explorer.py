"""``explore()``: search a design space for one scene and report the best machine."""
from __future__ import annotations

import time

import numpy as np

from .evaluate import SceneEvaluator, grid_dims
from .hwcost import UnitCosts, cost_breakdown
from .prepass import low_resolution
from .search import Problem, compass, cost_range, pareto, search
from .space import REFERENCE_DESIGNS, Point, Space, default_space


def explore(scene, width: int = 64, height: int = 64, space: Space | None = None, objective: str = "time",
            budget: float | None = None, level: int = 0, algorithm: str = "direct-l", polish: str = "lattice",
            max_evals: int = 1000, seed: int = 1, budgets: int = 6, progress=None, threads: int = 1,
            fraction: int | None = None, refine: int = 2, refine_evals: int = 60) -> dict:
    """Search ``space`` for ``scene`` at width x height; returns the report
    as a dict (the JSON of ``mprt explore``).

    The subdivision changes the trace, so the search runs on traces at
    1/``fraction`` of the resolution (default: about 64 pixels across; 1
    searches at full resolution), as the prepass does.  Then the ``refine``
    best subdivisions are traced at full resolution and their designs
    polished there (lattice steps, ``refine_evals`` designs each) at the
    fidelity ``level``; the best of those is the answer."""
    t0 = time.perf_counter()
    space = space or default_space()
    unit_costs = UnitCosts.from_table(space.cost)
    if fraction is None:
        fraction = max(1, min(width, height) // 64)
    low = (width, height) if fraction == 1 else low_resolution(width, height, fraction)
    ev = SceneEvaluator(scene, *low, level=level, shape=space.shape, unit_costs=unit_costs, threads=threads)
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
    history = [dict(r, phase="search", resolution=list(low)) for r in problem.history()]
    evaluations = res.evaluations
    if fraction > 1:
        full = SceneEvaluator(scene, width, height, level=level, shape=space.shape, unit_costs=unit_costs,
                              threads=threads)
        if objective == "pareto":
            fp = Problem(space, full, "time")
            fp.evaluate_many([e.index for e in front])
            front = [fp.memo[space.canonical(e.index)] for e in front]
            best = min(front, key=lambda e: (e.cycles * e.cost, e.serial))
            history += [dict(r, phase="full", resolution=[width, height]) for r in fp.history()]
            evaluations += len(fp.memo)
        else:
            best, rows, n = _refine(problem, space, full, objective, budget, refine, refine_evals)
            history += [dict(r, phase="full", resolution=[width, height]) for r in rows]
            evaluations += n
        ev = full
    for i, r in enumerate(history, 1):
        r["evaluation"] = i
    dims = list(grid_dims(scene, best.point.subdivision, space.shape))
    refs = {}
    for name, make in REFERENCE_DESIGNS.items():
        r = ev([Point(best.point.subdivision, make())])[0]
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
        "nlopt_calls": problem.calls,
        "algorithm": {"global": algorithm, "polish": polish, "max_evals": max_evals, "seed": seed},
        "level": level,
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


def settings(scene, width, height, threads) -> dict:
    """What made a report: the scene and its content hash, the image, the version."""
    from ..options import version
    return {"scene": scene.name, "scene_sha256": scene.content_hash(), "resolution": [width, height],
            "rules": "paper", "threads": threads, "mprt_version": version()}


def _refine(problem, space, full, objective, budget, refine, refine_evals):
    """The ``refine`` best subdivisions of the low-resolution search, each
    with its best design there, re-evaluated and polished at full resolution."""
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
        found.append((fp, fp.best()))
        rows += fp.history()
        n += len(fp.memo)
    fp, best = min(found, key=lambda t: t[0].rank(t[1])[:2])
    return best, rows, n


def plot(report: dict, path) -> None:
    """History, cycles against cost (with the front), and the best design's
    utilisation per processor beside the paper's 3MPPE."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    h = report["history"]
    n = np.array([r["evaluation"] for r in h])
    W, H = report["width"], report["height"]
    # search-phase cycles scaled to the full resolution (the prepass's prediction)
    scale = np.array([W * H / (r["resolution"][0] * r["resolution"][1]) for r in h])
    cyc = np.array([r["cycles"] for r in h]) * scale
    feas = np.array([r["feasible"] for r in h])
    full = np.array([r["phase"] == "full" for r in h])
    best = np.minimum.accumulate(np.where(feas, cyc, np.inf))
    ax[0].scatter(n[feas & ~full], cyc[feas & ~full], s=6, c="tab:blue", label="search (scaled to full res.)")
    ax[0].scatter(n[feas & full], cyc[feas & full], s=8, c="tab:green", label="full-resolution polish")
    ax[0].scatter(n[~feas], cyc[~feas], s=6, c="tab:gray", marker="x", label="over budget")
    ax[0].step(n, best, where="post", c="tab:red", label="best so far")
    ax[0].set(yscale="log", xlabel="evaluation", ylabel="cycles", title="search history")
    ax[0].legend(fontsize=8)
    cost = np.array([r["cost"] for r in h])
    ax[1].scatter(cost, cyc, s=6, c="tab:blue", alpha=0.5, label="evaluated (scaled)")
    if "front" in report:
        fr = sorted((f["cost"], f["cycles"]) for f in report["front"])
        ax[1].step([c for c, _ in fr], [y for _, y in fr], where="post", c="tab:red", marker="o", ms=3,
                   label="Pareto front")
    for name, r in report["references"].items():
        ax[1].scatter([r["cost"]], [r["cycles"]], marker="s", s=30, label=f"model {name}" if name != "3mppe"
                      else "paper 3MPPE")
    ax[1].scatter([report["best"]["cost"]], [report["best"]["cycles"]], marker="*", s=120, c="gold",
                  edgecolors="k", label="best", zorder=5)
    if report.get("budget"):
        ax[1].axvline(report["budget"], c="k", ls=":", lw=1, label="budget")
    ax[1].set(xscale="log", yscale="log", xlabel="cost (kGE)", ylabel="cycles", title="cycles against cost")
    ax[1].legend(fontsize=7)
    bu, pu = report["best"]["utilisation"], report["references"]["3mppe"]["utilisation"]
    names = list(bu) + [f"{k} (3MPPE)" for k in pu]
    vals = list(bu.values()) + list(pu.values())
    colours = ["tab:red"] * len(bu) + ["tab:gray"] * len(pu)
    ax[2].bar(range(len(vals)), vals, color=colours)
    ax[2].set_xticks(range(len(vals)), names, rotation=30, ha="right", fontsize=8)
    ax[2].set(ylim=(0, 1.05), ylabel="utilisation", title="best design (red) and the paper's 3MPPE")
    fig.suptitle(f"{report['scene']} {report['width']}x{report['height']}: objective {report['objective']}, "
                 f"{report['evaluations']} evaluations, level {report['level']}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
