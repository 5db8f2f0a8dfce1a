"""Calibration of the cost model against the paper's per-unit averages.

The digest's table "average cycles" (model M: sequential processors) gives,
for balls, mount, rings, tetra and tree at subdivisions 20, 50 and 100: OS
cycles per voxel traversed, IC cycles per intersection test, SC cycles per
input ray.  Each is a stage's processing time over a count, so our model's
value for a cell is (sum over kernels of runs x sequential cycles + visits x
per-visit overhead) / the same count, with the runs and the count taken from
OUR trace of that scene and subdivision (paper rules).  On a sequential
processor a kernel's cycles are the sum of its operations' latencies, so a
cell's value is linear in the constants: the latency of each operation class
and the per-visit overhead of each stage (10 constants for 45 cells).  They
are fitted by bounded least squares (scipy) on the cells' relative errors,
with a weak pull toward the nominal latencies (it only decides directions
the cells do not), then rounded to whole cycles by a local search.

    python -m mprt.cli.calibrate                      # fit on the shipped counts, print residuals
    python -m mprt.cli.calibrate --trace --res 256    # re-trace the 15 cells first
    python -m mprt.cli.calibrate --write              # re-trace, fit, write the shipped model + counts
    python -m mprt.cli.calibrate --scenes balls       # fit on balls only, residuals for all
"""
from __future__ import annotations

import csv
import os
from typing import NamedTuple, Sequence

import numpy as np

from .errors import CostModelError
from .kernels import KERNELS, OP_CLASSES
from .model import DEFAULT_FILE, STAGE_KERNELS, STAGES, CostModel, trace_kernel_counts  # noqa: F401 (DEFAULT_FILE: the CLI's)
from ..util.atomic import open_replacing

HERE = os.path.dirname(os.path.abspath(__file__))
COUNTS_FILE = os.path.join(HERE, "calibration_counts.csv")

SCENES = ("balls", "mount", "rings", "tetra", "tree")
SUBDIVISIONS = (20, 50, 100)
#: the digest's "average cycles" table, model M, subdivision 20 / 50 / 100
PAPER = {
    "balls": {"OS": (50, 44, 41), "IC": (24, 24, 26), "SC": (143, 144, 143)},
    "mount": {"OS": (51, 43, 40), "IC": (47, 46, 45), "SC": (110, 117, 101)},
    "rings": {"OS": (54, 44, 41), "IC": (82, 92, 101), "SC": (126, 129, 132)},
    "tetra": {"OS": (164, 137, 123), "IC": (51, 51, 55), "SC": (230, 419, 315)},
    "tree": {"OS": (46, 40, 37), "IC": (74, 75, 76), "SC": (96, 95, 94)},
}
#: the count each stage's average is per
UNIT = {"OS": "voxels", "IC": "tests", "SC": "sc_input"}
UNIT_TEXT = {"OS": "per voxel", "IC": "per test", "SC": "per SC ray"}

# The constants and their bounds.  Only the divide/square-root latency is
# fitted: on the sequential processor of model M every other class's latency
# only scales the stage totals (which the stage scales already do), so the
# cells cannot tell them apart; they stay at one cycle (the magnitude of the
# paper's averages: about one cycle per operation of its code).
FIT_LATENCY = ("fdiv",)
BASE_LATENCY = 1
LAT_BOUNDS = (1, 100)
OVH_BOUNDS = (0, 400)
SCALE_BOUNDS = (0.05, 2.0)
PRIOR_WEIGHT = 0.02


class Residual(NamedTuple):
    scene: str
    grid: int
    stage: str
    paper: float
    ours: float

    @property
    def rel(self) -> float:
        return (self.ours - self.paper) / self.paper


class Calibration(NamedTuple):
    model: CostModel
    residuals: list


# ---- counts --------------------------------------------------------------------

def _columns():
    cols = ["scene", "grid", "width", "height", "voxels", "tests", "sc_input"]
    for s in STAGES:
        cols += [f"{s}:visits"] + [f"{s}:{k}" for k in STAGE_KERNELS[s]]
    return cols


def counts_row(trace) -> dict:
    """A calibration row from a trace: scene, grid, resolution, units, kernel runs."""
    meta = trace.meta
    g = meta["grid"]
    if len(set(g)) != 1:
        raise CostModelError(f"calibration needs a cubic grid (the paper's n^3), not {g}")
    scene, _, size = str(meta["scene"]).partition(":")
    from ..scene import SPD_DEFAULT_SIZES

    if scene not in PAPER or not size or int(size) != SPD_DEFAULT_SIZES[scene]:
        raise CostModelError(f"trace of {meta['scene']!r}: the paper measured balls, mount, rings, tetra, tree "
                             "at the SPD default sizes only")
    if meta.get("rules") not in ("paper", "paper1992"):
        raise CostModelError(f"trace of {meta['scene']!r} uses rules {meta.get('rules')!r}; the paper's workload "
                             "is 'paper' or its reproduction 'paper1992'")
    c = trace_kernel_counts(trace)
    row = {"scene": scene, "grid": int(g[0]), "width": int(meta["width"]), "height": int(meta["height"])}
    row.update(c["units"])
    for s in STAGES:
        for k, n in c["stages"][s].items():
            row[f"{s}:{k}"] = n
    return row


def trace_cell(scene: str, n: int, res: int = 256, threads: int = 2):
    from ..scene import Scene

    _, tr = Scene.spd(scene).grid(n).trace(res, res, rules="paper", threads=threads)
    return tr


def collect(scenes: Sequence[str] = SCENES, subdivisions: Sequence[int] = SUBDIVISIONS, res: int = 256,
            threads: int = 2, progress=None) -> list:
    rows = []
    for s in scenes:
        for n in subdivisions:
            rows.append(counts_row(trace_cell(s, n, res, threads)))
            if progress:
                progress(f"traced {s} n={n} at {res}x{res}")
    return rows


def write_counts(rows, path=COUNTS_FILE):
    cols = _columns()
    with open_replacing(path, newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: r[k] for k in cols})


def read_counts(path=COUNTS_FILE) -> list:
    cols = _columns()
    with open(path, newline="") as f:
        rd = csv.DictReader(f)
        missing = [c for c in cols if c not in (rd.fieldnames or [])]
        if missing:
            raise CostModelError(f"{path}: columns missing: {', '.join(missing)} (regenerate with "
                                 "'python -m mprt.cli.calibrate --write')")
        rows = []
        for line, r in enumerate(rd, start=2):
            try:
                rows.append({k: (r[k] if k == "scene" else int(r[k])) for k in cols})
            except ValueError:
                raise CostModelError(f"{path}, line {line}: a count is not a whole number") from None
    return rows


# ---- the fit ---------------------------------------------------------------------

KERNEL_NAMES = tuple(dict.fromkeys(k for s in STAGES for k in STAGE_KERNELS[s]))
_OPS = np.array([[KERNELS[k].counts()[c] for c in OP_CLASSES] for k in KERNEL_NAMES], float)


def _design(rows):
    """Per (row, stage) cell: kernel runs per unit K (cells x kernels), visits
    per unit V, the stage index and the paper's value."""
    K, V, st, cells = [], [], [], []
    for r in rows:
        if r["scene"] not in PAPER or r["grid"] not in SUBDIVISIONS:
            raise CostModelError(f"no paper value for {r['scene']} at subdivision {r['grid']}")
        for si, s in enumerate(STAGES):
            denom = r[UNIT[s]]
            if denom <= 0:
                raise CostModelError(f"{r['scene']} n={r['grid']}: no {UNIT[s]} in the trace")
            k = np.zeros(len(KERNEL_NAMES))
            for j, name in enumerate(KERNEL_NAMES):
                if name in STAGE_KERNELS[s]:
                    k[j] = r[f"{s}:{name}"] / denom
            K.append(k)
            V.append(r[f"{s}:visits"] / denom)
            st.append(si)
            cells.append((r["scene"], r["grid"], s, float(PAPER[r["scene"]][s][SUBDIVISIONS.index(r["grid"])])))
    return np.array(K), np.array(V), np.array(st), cells


NL = len(OP_CLASSES)


def _theta(model):
    """[latencies..., overheads..., scales (fractions)...]"""
    return np.array([model.latency[c] for c in OP_CLASSES] + [model.visit_overhead[s] for s in STAGES]
                    + [model.scale[s] / 100 for s in STAGES], float)


def _model(theta, info=None):
    lat = {c: int(round(x)) for c, x in zip(OP_CLASSES, theta[:NL])}
    ovh = {s: int(round(x)) for s, x in zip(STAGES, theta[NL:NL + 3])}
    scl = {s: int(round(100 * x)) for s, x in zip(STAGES, theta[NL + 3:])}
    return CostModel(lat, ovh, scl, info)


def _predict(theta, K, V, st, exact):
    """Cells' values: exact (whole-cycle kernels, as CostModel computes them
    on a sequential processor) or continuous (for the optimiser)."""
    lat, ovh, scl = theta[:NL], theta[NL:NL + 3], theta[NL + 3:]
    seq = _OPS @ lat                                      # sequential cycles per kernel
    kst = np.array([STAGES.index(next(s for s in STAGES if k in STAGE_KERNELS[s])) for k in KERNEL_NAMES])
    if exact:
        pct = np.round(scl * 100).astype(np.int64)[kst]
        cyc = np.maximum((seq.astype(np.int64) * pct + 50) // 100, 1).astype(float)
        return K @ cyc + V * ovh[st]
    return scl[st] * (K @ seq) + V * ovh[st]


def residuals_of(model: CostModel, rows) -> list:
    """Every cell's paper value and ours, with `model`'s kernels on the
    sequential processor of model M (through CostModel.kernel_cycles)."""
    from .schedule import ProcessorConfig

    K, V, st, cells = _design(rows)
    seq = ProcessorConfig.sequential()
    cyc = np.array([model.kernel_cycles(k, seq) for k in KERNEL_NAMES], float)
    ovh = np.array([model.visit_overhead[s] for s in STAGES], float)
    ours = K @ cyc + V * ovh[st]
    return [Residual(sc, g, s, p, float(o)) for (sc, g, s, p), o in zip(cells, ours)]


def fit(rows, scenes: Sequence[str] | None = None, fit_latency: Sequence[str] = FIT_LATENCY,
        free_scale: bool = True, loss: str = "soft_l1", f_scale: float = 0.25) -> Calibration:
    """Fit the constants to the paper's cells of `scenes` (default: all in
    rows); residuals are reported for every row.  fit_latency: the operation
    classes whose latency is fitted (the others are BASE_LATENCY);
    free_scale=False keeps the stage scales at 100%."""
    from scipy.optimize import least_squares

    scenes = tuple(scenes) if scenes else tuple(dict.fromkeys(r["scene"] for r in rows))
    for s in scenes:
        if s not in PAPER:
            raise CostModelError(f"calibrate: unknown scene {s!r} (the paper's: {', '.join(PAPER)})")
    for c in fit_latency:
        if c not in OP_CLASSES:
            raise CostModelError(f"calibrate: fit_latency names unknown operation class {c!r}")
    use = [r for r in rows if r["scene"] in scenes]
    if not use:
        raise CostModelError(f"calibrate: no counts for scenes {', '.join(scenes)}")
    K, V, st, cells = _design(use)
    y = np.array([c[3] for c in cells])
    nom = _theta(CostModel.nominal())
    lo = np.array([LAT_BOUNDS[0] if c in fit_latency else BASE_LATENCY for c in OP_CLASSES]
                  + [OVH_BOUNDS[0]] * 3 + [SCALE_BOUNDS[0] if free_scale else 1.0] * 3, float)
    hi = np.array([LAT_BOUNDS[1] if c in fit_latency else BASE_LATENCY for c in OP_CLASSES]
                  + [OVH_BOUNDS[1]] * 3 + [SCALE_BOUNDS[1] if free_scale else 1.0] * 3, float)
    free = hi > lo

    def full(x):
        t = lo.copy()
        t[free] = x
        return t

    def res(theta, exact=False):
        r = (_predict(theta, K, V, st, exact) - y) / y
        prior = PRIOR_WEIGHT * np.concatenate([(theta[:NL] - nom[:NL]) / nom[:NL], theta[NL + 3:] - 1])
        return np.concatenate([r, prior])

    def cost(theta, exact=True):
        z = (res(theta, exact) / f_scale) ** 2
        return float(np.sum(2 * (np.sqrt(1 + z) - 1)) if loss == "soft_l1" else np.sum(z))

    x0 = np.clip(nom, lo, hi)[free]
    sol = least_squares(lambda x: res(full(x)), x0, bounds=(lo[free], hi[free]), loss=loss, f_scale=f_scale,
                        method="trf", x_scale="jac", max_nfev=20000)
    cont = full(sol.x)
    # whole cycles and percentages: round, then move one constant at a time
    # by one unit (a cycle, or 1% of a scale) while that lowers the exact cost
    unit = np.array([1.0] * (NL + 3) + [0.01] * 3)
    theta = np.clip(np.round(cont / unit) * unit, lo, hi)
    best = cost(theta)
    improved = True
    while improved:
        improved = False
        for i in np.flatnonzero(free):
            for step in (-1, 1):
                t = theta.copy()
                t[i] = round((t[i] + step * unit[i]) / unit[i]) * unit[i]
                if lo[i] - 1e-9 <= t[i] <= hi[i] + 1e-9:
                    c = cost(t)
                    if c < best - 1e-12:
                        theta, best, improved = t, c, True
    names = list(OP_CLASSES) + [f"overhead_{s}" for s in STAGES] + [f"scale_{s}" for s in STAGES]
    info = {"source": "python -m mprt.cli.calibrate", "scenes": list(scenes),
            "resolution": sorted({f"{r['width']}x{r['height']}" for r in use}),
            "fit_latency": list(fit_latency), "free_scale": free_scale,
            "loss": loss, "f_scale": f_scale, "prior_weight": PRIOR_WEIGHT,
            "continuous_fit": {n: round(float(v), 3) for n, v in zip(names, cont)}}
    model = _model(theta, info)
    return Calibration(model, residuals_of(model, rows))


def calibrate(sources=None, scenes: Sequence[str] | None = None, res: int = 256, threads: int = 2,
              **kw) -> Calibration:
    """Fit the cost model.  sources: None (the shipped counts), a counts CSV
    path, a list of traces (paper rules, SPD default sizes, cubic grids of
    20/50/100), a list of scene names (traced at res x res for 20, 50, 100),
    or a list of count rows."""
    if sources is None:
        rows = read_counts()
    elif isinstance(sources, (str, os.PathLike)):
        rows = read_counts(sources)
    else:
        rows = []
        for s in sources:
            if isinstance(s, str):
                rows += collect([s], SUBDIVISIONS, res, threads)
            elif isinstance(s, dict):
                rows.append(s)
            else:
                rows.append(counts_row(s))
    return fit(rows, scenes, **kw)


def residual_table(residuals, scenes_fitted=None) -> str:
    """Markdown: per scene and stage, paper / ours / relative error at 20, 50, 100."""
    by = {(r.scene, r.grid, r.stage): r for r in residuals}
    lines = ["| scene | stage | paper 20 / 50 / 100 | ours 20 / 50 / 100 | error 20 / 50 / 100 |",
             "|---|---|---|---|---|"]
    for sc in dict.fromkeys(r.scene for r in residuals):
        mark = "" if not scenes_fitted or sc in scenes_fitted else " (predicted)"
        for s in STAGES:
            rs = [by.get((sc, g, s)) for g in SUBDIVISIONS]
            if not all(rs):
                continue
            lines.append(f"| {sc}{mark} | {s} {UNIT_TEXT[s]} | " + " / ".join(f"{r.paper:.0f}" for r in rs) + " | "
                         + " / ".join(f"{r.ours:.1f}" for r in rs) + " | "
                         + " / ".join(f"{100 * r.rel:+.0f}%" for r in rs) + " |")
    rel = np.array([r.rel for r in residuals])
    lines.append("")
    lines.append(f"RMS relative error {100 * np.sqrt(np.mean(rel ** 2)):.1f}%, median |error| "
                 f"{100 * np.median(np.abs(rel)):.1f}%, largest |error| {100 * np.max(np.abs(rel)):.0f}% "
                 f"over {len(rel)} cells.")
    return "\n".join(lines)


def resolution_check(spec: str, threads: int = 2) -> int:
    """Per-unit averages of one cell at several resolutions (the shipped model)."""
    try:
        scene, n, res = spec.split(":")
        n, res = int(n), [int(x) for x in res.split(",")]
    except ValueError:
        raise CostModelError(f"--check {spec!r}: expected SCENE:N:RES,RES,... e.g. balls:50:128,256,512") from None
    model = CostModel.default()
    print(f"| {scene} n={n} | " + " | ".join(f"{s} {UNIT_TEXT[s]}" for s in STAGES) + " |")
    print("|---|---|---|---|")
    for r in res:
        rs = residuals_of(model, [counts_row(trace_cell(scene, n, r, threads))])
        print(f"| {r}x{r} | " + " | ".join(f"{x.ours:.2f}" for x in rs) + " |")
    return 0


def kernel_report(model: CostModel | None = None) -> str:
    """Markdown: every kernel's operations by class and its cycles on the
    sequential processor and on the paper's OS / IC / SC processors."""
    from .kernels import KERNEL_STAGE
    from .schedule import ProcessorConfig

    model = model or CostModel.default()
    procs = {"seq": ProcessorConfig.sequential()}
    procs.update({s: ProcessorConfig.paper(s) for s in STAGES})
    lines = ["| kernel | stage | ops | " + " | ".join(OP_CLASSES) + " | sequential | paper OS | paper IC | paper SC |",
             "|---" * (len(OP_CLASSES) + 7) + "|"]
    for name, g in KERNELS.items():
        c = g.counts()
        lines.append(f"| {name} | {KERNEL_STAGE[name]} | {len(g)} | " + " | ".join(str(c[k]) for k in OP_CLASSES)
                     + " | " + " | ".join(str(model.kernel_cycles(name, p)) for p in procs.values()) + " |")
    return "\n".join(lines)
