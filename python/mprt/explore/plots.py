"""The explorer's figure: the search's history, cost against the workload's figure, and the
answer per scene against the paper's 3MPPE and each scene's own best machine."""
from __future__ import annotations

import numpy as np

from ..util.atomic import replacing

FONT = 12          # points; at 100 dpi and the report's width the text is at least body size


def _plain_log_axis(axis) -> None:
    """A log axis labelled 1, 2, 5 x 10^k in plain numbers (no overlapping labels), minor ticks unlabelled."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0), numticks=6))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:,.0f}" if v >= 1 else f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def figure(rep: dict):
    """The Figure of an explore report (its JSON)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": FONT})
    fig, ax = plt.subplots(1, 3, figsize=(18, 6.2))
    h = [r for r in rep["history"] if r.get("phase") in ("search", "polish")]
    objective = rep["objective"]
    what = {"geomean": "geometric mean of cycles", "total": "weighted total cycles",
            "worst": "worst cycles / 3MPPE's", "pareto": "geometric mean of cycles"}[objective]
    n = np.arange(1, len(h) + 1)
    val = np.array([r["cycles"] if r["cycles"] is not None else np.nan for r in h], float)
    feas = np.array([r["feasible"] and r["cycles"] is not None for r in h], bool)
    bound = np.array([bool(r.get("bound")) for r in h], bool)
    ran = feas & ~bound
    if ran.any():
        ax[0].scatter(n[ran], val[ran], s=10, c="tab:blue", label="replayed (low resolution)")
    if (feas & bound).any():
        ax[0].scatter(n[feas & bound], val[feas & bound], s=10, c="lightgray", marker="v",
                      label="level-1 bound only (at or below its figure)")
    if (~feas & ~np.isnan(val)).any():
        ax[0].scatter(n[~feas & ~np.isnan(val)], val[~feas & ~np.isnan(val)], s=10, c="tab:gray", marker="x",
                      label="over the budget")
    best = np.fmin.accumulate(np.where(ran, val, np.inf))
    if np.isfinite(best).any():
        ax[0].step(n, np.where(np.isfinite(best), best, np.nan), where="post", c="tab:red", label="best so far")
    ax[0].set(yscale="log", xlabel="machine evaluated", ylabel=what, title="search")
    if len(h):
        _plain_log_axis(ax[0].yaxis)
    cost = np.array([r["cost"] for r in h], float)
    if ran.any():
        ax[1].scatter(cost[ran], val[ran], s=10, c="tab:blue", alpha=0.5, label="machines replayed")
    if rep.get("front"):
        fr = sorted((f["cost"], f["objective"]) for f in rep["front"])
        ax[1].step([c for c, _ in fr], [y for _, y in fr], where="post", c="tab:red", marker="o", ms=4,
                   label="Pareto front")
    b = rep["best"]
    hb = [r for r in h if r.get("design") == b.get("design")]
    if hb and hb[-1]["cycles"] is not None:
        ax[1].scatter([b["cost"]], [hb[-1]["cycles"]], marker="*", s=260, c="gold", edgecolors="k", zorder=5,
                      label="answer")
    if rep.get("budget"):
        ax[1].axvline(rep["budget"], c="k", ls=":", lw=1, label="budget")
    ax[1].set(xscale="log", yscale="log", xlabel="cost (kGE)", ylabel=what, title="cost against the objective")
    if len(h):
        _plain_log_axis(ax[1].xaxis)
        _plain_log_axis(ax[1].yaxis)
    rows = rep["per_scene"]
    names = [r["scene"] for r in rows]
    x = np.arange(len(rows))
    sp = [r["speedup"] or 0 for r in rows]
    own = [(r["own_best"]["cycles"] and r["speedup"] and r["speedup"] * r["cycles"] / r["own_best"]["cycles"]) or 0
           for r in rows]
    ax[2].bar(x - 0.2, sp, 0.4, color="tab:red", label="answer (one machine)")
    ax[2].bar(x + 0.2, own, 0.4, color="tab:gray", label="the scene's own best machine")
    ax[2].axhline(1.0, c="k", lw=1)
    ax[2].set_xticks(x, names, rotation=30 if len(rows) > 3 else 0, ha="right" if len(rows) > 3 else "center")
    ax[2].set(ylabel="speed-up over the 3MPPE", title="per scene, full frame")
    for a in ax:
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=1, frameon=False)
    lv = rep["level"]["search"]
    fig.suptitle(f"{len(rows)} scene(s), objective {objective}"
                 + (f", budget {rep['budget']:g} kGE" if rep.get("budget") else "") + f", level {lv}")
    fig.tight_layout()
    return fig


def plot(rep: dict, path) -> None:
    """Write the figure of an explore report to a PNG file (whole or not at all)."""
    import matplotlib.pyplot as plt

    fig = figure(rep)
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=100, format="png")
    plt.close(fig)


__all__ = ["figure", "plot"]
