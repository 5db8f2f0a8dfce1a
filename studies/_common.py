"""Helpers shared by the studies: arguments and output folders, tables, timing, rays, and the
paper's balls figures.

A study lives in ``studies/NN_name/`` with ``README.md`` (Overview, Steps,
Observations), ``run.py`` and ``ref/``: the output of ``run.py --quick``,
which ``tests/test_studies.py`` regenerates and compares byte for byte.  Checks
a study makes on its own results go to ``checks.csv`` as booleans, which the
test requires to be true.  A run.py finds this module with

    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
"""
from __future__ import annotations

import argparse
import csv
import os
import time

import numpy as np

import mprt
from mprt import Outcome, RayKind, Stage

STUDIES = os.path.dirname(os.path.abspath(__file__))


def study_args(run_file: str, description: str, quick_help: str, argv=None, extra=None):
    """Parse a study's command line: --quick (small, deterministic, written to the study's ref/),
    --out DIR (default studies/out/NN_name, or ref/ with --quick) and --threads.  ``extra(parser)``
    adds the study's own options.  Returns (args, output folder), the folder created."""
    here = os.path.dirname(os.path.abspath(run_file))
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--quick", action="store_true", help=quick_help + "; writes to ref/ (the committed reference)")
    ap.add_argument("--out", default=None, help="output folder (default studies/out/<study>, or ref/ with --quick)")
    ap.add_argument("--threads", type=int, default=2)
    if extra:
        extra(ap)
    a = ap.parse_args(argv)
    out = a.out or (os.path.join(here, "ref") if a.quick else os.path.join(STUDIES, "out", os.path.basename(here)))
    os.makedirs(out, exist_ok=True)
    return a, out


def per_scene_study(run_file: str, description: str, csv_name: str, row, argv=None) -> int:
    """Run a study whose table has one row per scene of SCENES, ``row(scene, res, threads)``,
    at the resolution and size of quick_or_full; write it as csv_name."""
    a, out = study_args(run_file, description, "64x64, scenes at size 2", argv)
    res, size, _ = quick_or_full(a.quick)
    write_table(out, csv_name, [{"scene": name, **row(mprt.Scene.spd(name, size), res, a.threads)}
                                for name in SCENES])
    return 0


def command_env(pythonpath: str | None = None) -> dict:
    """The environment a timed command runs in: this one, with Python's bytecode cached as a
    user's installation has it (PYTHONDONTWRITEBYTECODE removed; the cache under
    PYTHONPYCACHEPREFIX, a folder in the temporary directory unless one is set, so no tree
    gets __pycache__ folders) and ``pythonpath`` (another build's) first on the path.  Where
    bytecode is not cached every command compiles the modules it imports first (80-170 ms here),
    which a best-of-N over fresh processes would otherwise count every time."""
    import tempfile

    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.setdefault("PYTHONPYCACHEPREFIX", os.path.join(tempfile.gettempdir(), "mprt-studies-pycache"))
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    return env


def log(msg: str) -> None:
    print(msg, flush=True)


# ---- tables ---------------------------------------------------------------------------------

def write_csv(path: str, rows: list) -> None:
    """Dict rows as CSV (columns: the union of their keys, in first-seen order; floats to 4 places)."""
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in r.items()})


def write_table(out: str, name: str, rows: list) -> None:
    """Write rows to out/name as CSV and print them as a Markdown table."""
    write_csv(os.path.join(out, name), rows)
    log(md_rows(rows))


def write_checks(path: str, checks: dict) -> None:
    """A study's checks of its own results: one row per check, value true or false."""
    write_csv(path, [{"check": k, "value": "true" if v else "false"} for k, v in checks.items()])


def cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
        return f"{v:,}"
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def md_table(header: list, rows: list) -> str:
    s = "| " + " | ".join(header) + " |\n|" + "|".join("---" for _ in header) + "|\n"
    for r in rows:
        s += "| " + " | ".join(str(x) for x in r) + " |\n"
    return s


def md_rows(rows: list) -> str:
    """A Markdown table of dict rows (union of their keys)."""
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    return md_table(keys, [[cell(r.get(k, "")) for k in keys] for r in rows])


def fmt_unit(v, unit: str) -> str:
    """K: thousands; M: millions; '': as is."""
    if v == "" or v is None:
        return ""
    if unit == "K":
        return f"{v / 1e3:,.0f}"
    if unit == "M":
        return f"{v / 1e6:,.1f}" if v < 1e8 else f"{v / 1e6:,.0f}"
    if isinstance(v, float):
        return f"{v:.2f}"
    return f"{v:,}"


# ---- timing and rays --------------------------------------------------------------------------

def best_time(fn, repeat: int):
    """(best wall time of ``repeat`` calls, the last call's result)."""
    best = float("inf")
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def random_rays(scene, n: int, seed: int = 1):
    """Origins uniform in the scene box, directions uniform on the sphere."""
    info = scene.info()
    lo, hi = np.array(info["lo"]), np.array(info["hi"])
    rng = np.random.default_rng(seed)
    o = lo + (hi - lo) * rng.random((n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return o, d


# ---- the paper's balls column ------------------------------------------------------------------

# the SPD scenes the studies tabulate (gears, all polygons, adds little beside tetra and mount)
SCENES = ("balls", "mount", "rings", "tetra", "tree")


def quick_or_full(quick: bool):
    """(resolution, SPD size factor, subdivisions) of a study's quick mode (64, 2, (8, 16)) or
    full run (512, the SPD default, the paper's 20, 50 and 100)."""
    return (64, 2, (8, 16)) if quick else (512, None, PAPER_SUBDIVISIONS)


# Digest section 4, subdivision 20 / 50 / 100; counts in thousands, voxels and tests in millions.
PAPER_SUBDIVISIONS = (20, 50, 100)
PAPER_BALLS = {
    "os_input": (6797, 7515, 9182),
    "os_input_primary": (262, 262, 262),
    "os_input_returns": (4657, 5346, 7011),
    "os_input_new": (1878, 1906, 1907),
    "os_kills": (50, 45, 45),
    "os_to_ic": (6206, 6921, 8593),
    "os_to_sc_shadow": (540, 548, 543),
    "ic_kills": (861, 877, 882),
    "ic_to_os": (4657, 5346, 7011),
    "hits": (686, 696, 697),
    "sc_input": (1228, 1246, 1242),
    "sc_made_secondary": (476, 481, 481),
    "sc_made_shadow": (1402, 1425, 1426),
    "suppressed": (1420, 1455, 1458),
    "voxels_traversed": (20, 45, 88),
    "tests": (1376, 346, 92),
    "returns_per_ray": (2.2, 2.5, 3.2),
}
GAP_KEYS = ("hits", "os_kills", "sc_made_secondary", "sc_made_shadow", "ic_kills", "os_to_sc_shadow", "suppressed")


def nonshadow_hits(c: dict) -> int:
    """Primary/secondary rays that hit, from render counters: SC visits are those hits plus the
    unblocked shadow rays; 'hits' counts them plus the blocked shadow rays."""
    return (c["sc_visits"] + c["hits"] - c["shadow_rays"]) // 2


def candidates_per_hit(secondary, shadow, suppressed, hits) -> float:
    """(secondary + shadow + suppressed) / hits: the child rays SC considered per hit."""
    return round((secondary + shadow + suppressed) / hits, 4)


def counts_row(c: dict) -> dict:
    """The paper's ray rows from one render's counters."""
    h = nonshadow_hits(c)
    sec = c["reflect_rays"] + c["refract_rays"]
    blocked = c["hits"] - h
    return {"eye_hits": c["eye_hits"], "hits": h, "os_kills": c["eye_rays"] + sec - h, "sc_made_secondary": sec,
            "sc_made_shadow": c["shadow_rays"], "ic_kills": blocked, "os_to_sc_shadow": c["shadow_rays"] - blocked,
            "suppressed": c["suppressed_rays"],
            "candidates_per_hit": candidates_per_hit(sec, c["shadow_rays"], c["suppressed_rays"], h)}


def paper_counts_row(i: int = 1) -> dict:
    """The paper's balls figures (subdivision 20/50/100 -> i = 0/1/2) in counts_row's keys."""
    p = {k: v[i] * 1000 for k, v in PAPER_BALLS.items()}
    row = {k: p[k] for k in GAP_KEYS}
    row["candidates_per_hit"] = candidates_per_hit(p["sc_made_secondary"], p["sc_made_shadow"], p["suppressed"],
                                                   p["hits"])
    return row


def by_ray_class(tr) -> dict:
    """Rays, IC -> OS returns and voxels stepped of a trace's primary, secondary, blocked shadow and
    unblocked shadow rays, as rays_<class>, returns_<class>, voxels_<class>."""
    v, kind = tr.visits, tr.rays["kind"]
    blocked = np.zeros(len(tr.rays), dtype=bool)
    blocked[v["ray"][(v["stage"] == Stage.IC) & (v["outcome"] == Outcome.BLOCKED)]] = True
    ret = (v["stage"] == Stage.IC) & (v["outcome"] == Outcome.RETURN)
    shadow = kind == RayKind.SHADOW
    row = {}
    for label, rays_m in (("primary", kind == RayKind.PRIMARY), ("secondary", (kind != RayKind.PRIMARY) & ~shadow),
                          ("shadow_blocked", shadow & blocked), ("shadow_unblocked", shadow & ~blocked)):
        row["rays_" + label] = int(rays_m.sum())
        row["returns_" + label] = int(np.sum(ret & rays_m[v["ray"]]))
        row["voxels_" + label] = int(v["steps"][rays_m[v["ray"]]].sum())
    return row
