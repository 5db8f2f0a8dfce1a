"""The explorer's figure: the search's history, cost against the workload's figure, and the
answer per scene against the paper's 3MPPE and each scene's own best machine.  Drawn with
``mprt.util.figures``' defaults (as wide as a report page's content, body-size text, legends
beside the data, tick labels that do not crowd), so ``figures.check`` finds nothing to fix."""
from __future__ import annotations

import numpy as np

from ..util import figures as F
from ..util.atomic import replacing

WHAT = {"geomean": "geometric mean of cycles", "total": "weighted total cycles",
        "worst": "worst ratio to the 3MPPE, in cycles", "pareto": "geometric mean of cycles"}


def figure(rep: dict):
    """The Figure of an explore report (its JSON): three panels, one above the other."""
    fig, axes = F.figure(13.5, nrows=3, ncols=1)
    ax = axes.ravel()
    h = [r for r in rep["history"] if r.get("phase") in ("search", "polish")]
    what = WHAT[rep["objective"]]
    n = np.arange(1, len(h) + 1)
    val = np.array([r["cycles"] if r["cycles"] is not None else np.nan for r in h], float)
    feas = np.array([bool(r["feasible"]) and r["cycles"] is not None for r in h], bool)
    bound = np.array([bool(r.get("bound")) for r in h], bool)
    ran = feas & ~bound
    if ran.any():
        ax[0].scatter(n[ran], val[ran], s=12, c="tab:blue", label="replayed at low resolution")
    if (feas & bound).any():
        ax[0].scatter(n[feas & bound], val[feas & bound], s=12, c="silver", marker="v",
                      label="ruled out: its level-1 bound")
    over = ~feas & ~np.isnan(val)
    if over.any():
        ax[0].scatter(n[over], val[over], s=12, c="tab:gray", marker="x", label="over the budget")
    best = np.fmin.accumulate(np.where(ran, val, np.inf)) if len(h) else np.zeros(0)
    if np.isfinite(best).any():
        ax[0].step(n, np.where(np.isfinite(best), best, np.nan), where="post", c="tab:red", label="best so far")
    ax[0].set(xlabel="machine evaluated", ylabel=what, title="The search")
    if ran.any():
        ax[0].set_yscale("log")
        F.cycles_axis(ax[0].yaxis, log=True)
    F.thousands_axis(ax[0].xaxis)
    cost = np.array([r["cost"] for r in h], float)
    if ran.any():
        ax[1].scatter(cost[ran], val[ran], s=12, c="tab:blue", alpha=0.5, label="machines replayed")
    if rep.get("front"):
        fr = sorted((f["cost"], f["objective"]) for f in rep["front"])
        ax[1].step([c for c, _ in fr], [y for _, y in fr], where="post", c="tab:red", marker="o", ms=5,
                   label="Pareto front")
    b = rep["best"]
    hb = [r for r in h if r.get("design") == b.get("design") and r["cycles"] is not None]
    if hb:
        ax[1].scatter([b["cost"]], [hb[-1]["cycles"]], marker="*", s=320, c="gold", edgecolors="k", zorder=5,
                      label="the answer" + (" (the front's knee)" if rep.get("front") else ""))
    if rep.get("budget"):
        ax[1].axvline(rep["budget"], c="k", ls=":", lw=1, label="budget")
    ax[1].set(xlabel="cost (kGE)", ylabel=what, title="Cost against the objective")
    if ran.any():
        ax[1].set_yscale("log")
        F.cycles_axis(ax[1].yaxis, log=True)
    F.thousands_axis(ax[1].xaxis)
    rows = rep["per_scene"]
    x = np.arange(len(rows))
    sp = [r["speedup"] or 0 for r in rows]
    own = [r["speedup"] * r["cycles"] / r["own_best"]["cycles"] if r["speedup"] else 0 for r in rows]
    ax[2].bar(x - 0.2, sp, 0.4, color="tab:red", label="the answer (one machine)")
    ax[2].bar(x + 0.2, own, 0.4, color="tab:gray", label="the scene's own best machine")
    ax[2].axhline(1.0, c="k", lw=1, label="the 3MPPE")
    F.index_axis(ax[2].xaxis, [r["scene"] for r in rows])
    ax[2].set(ylabel="speed-up over the 3MPPE", title="Per scene, on its full frame")
    for a in ax:
        if a.get_legend_handles_labels()[0]:
            F.legend_outside(a)
    fig.suptitle(f"{len(rows)} scene(s), objective {rep['objective']}"
                 + (f", budget {rep['budget']:g} kGE" if rep.get("budget") else "")
                 + f", level {rep['level']['search']}")
    F.readable(fig)
    return fig


def plot(rep: dict, path) -> None:
    """Write the figure of an explore report to a PNG file (whole or not at all)."""
    fig = figure(rep)
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=F.DPI, format="png")


__all__ = ["figure", "plot"]
