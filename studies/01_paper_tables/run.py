"""Paper tables: our 3MPRT counts in the layout of the paper's results.

For balls, mount, rings, tetra and tree (SPD default sizes) at subdivisions
20, 50 and 100 (n^3 voxels over the scene's box), 512x512, `paper` rules and
the default threshold, every ray is traced and tabulated in the paper's rows
(digest section 4), with tests by primitive kind, and balls is set beside the
paper's column.  Also measured: the returns IC makes while it already holds
the ray's final hit (an IC accepting hits beyond its voxel would not make
them).  Checked: every count that does not describe the grid is the same at
every subdivision.

Writes paper_rows.csv, balls_vs_paper.csv, checks.csv, tables.md and
paper_tables.png to studies/out/01_paper_tables/ (--quick: 64x64,
subdivisions 8 and 16, scenes at size 2, no plot, to ref/).

    python studies/01_paper_tables/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import (PAPER_BALLS, PAPER_SUBDIVISIONS, SCENES, by_ray_class, fmt_unit, log,  # noqa: E402
                     md_table, quick_or_full, study_args, write_checks, write_csv)
from mprt import Outcome, RayKind, Stage  # noqa: E402

# (key, label, unit): unit K = thousands, M = millions, '' = as is
ROWS = [
    ("os_input", "OS input rays", "K"),
    ("os_input_primary", "  of which primary", "K"),
    ("os_input_returns", "  of which returns from IC", "K"),
    ("os_input_new", "  of which new rays from SC", "K"),
    ("os_kills", "OS kills (ray left the space)", "K"),
    ("os_to_ic", "OS -> IC", "K"),
    ("os_to_sc", "OS -> SC", "K"),
    ("os_to_sc_shadow", "  of which unblocked shadow rays", "K"),
    ("os_to_sc_late_hits", "  of which late hits (nearest hit accepted by OS after the walk)", "K"),
    ("ic_kills", "IC kills (blocked shadow rays)", "K"),
    ("ic_to_os", "IC -> OS (returns)", "K"),
    ("ic_to_sc", "IC -> SC (hits)", "K"),
    ("hits", "hits (IC -> SC + late hits)", "K"),
    ("sc_input", "SC input", "K"),
    ("sc_made_secondary", "SC makes: secondary rays", "K"),
    ("sc_made_shadow", "SC makes: shadow rays", "K"),
    ("suppressed", "rays suppressed by the contribution threshold", "K"),
    ("voxels_traversed", "voxels traversed (millions)", "M"),
    ("tests", "intersection tests (millions)", "M"),
    ("tests_sphere", "  sphere tests (millions)", "M"),
    ("tests_polygon", "  polygon tests (millions)", "M"),
    ("tests_cylinder", "  cylinder tests (millions)", "M"),
    ("tests_cone", "  cone tests (millions)", "M"),
    ("returns_per_ray", "returns per ray entering OS from outside", ""),
    ("returns_holding_hit", "returns while IC holds the final hit", "K"),
    ("returns_per_ray_early_accept", "returns per ray if IC accepted hits beyond its voxel", ""),
]
# rows of the balls comparison that the paper does not have
OURS_ONLY = ("os_to_sc", "os_to_sc_late_hits", "ic_to_sc", "tests_sphere", "tests_polygon", "returns_holding_hit",
             "returns_per_ray_early_accept")
# counts that describe the grid; all others must be the same at every subdivision
GRID_KEYS = {"subdivision", "os_input", "os_input_returns", "os_to_ic", "ic_to_os", "ic_to_sc", "os_to_sc",
             "os_to_sc_shadow", "os_to_sc_late_hits", "voxels_traversed", "tests", "tests_sphere", "tests_polygon",
             "tests_cylinder", "tests_cone", "returns_per_ray", "returns_holding_hit", "returns_per_ray_early_accept",
             "ic_input", "sc_input_from_ic", "sc_input_from_os", "visits", "polygon_vertices", "grid_nonempty",
             "grid_refs", "tests_by_primary", "tests_by_secondary", "tests_by_shadow", "returns_primary",
             "returns_secondary", "returns_shadow_blocked", "returns_shadow_unblocked", "voxels_primary",
             "voxels_secondary", "voxels_shadow_blocked", "voxels_shadow_unblocked"}


def returns_holding_hit(tr) -> int:
    """IC -> OS returns made after IC has tested (and so found) the primitive the ray finally
    hits: IC holds that hit but it lies beyond the voxel.  Found from the voxel lists: the
    first IC visit whose voxel lists the final primitive, and every return from then on."""
    v = tr.visits
    stage, out = v["stage"], v["outcome"]
    final = np.full(len(tr.rays), -1, dtype=np.int64)
    m = ((stage == Stage.IC) & (out == Outcome.HIT)) | ((stage == Stage.OS) & (out == Outcome.LATE_HIT))
    final[v["ray"][m]] = v["prim"][m]
    icv = np.flatnonzero((stage == Stage.IC) & (final[v["ray"]] >= 0))
    if icv.size == 0:
        return 0
    start, ids = tr.voxel_start.astype(np.int64), tr.voxel_ids.astype(np.int64)
    nprim = len(tr.prim_kind)
    vox_of_ref = np.repeat(np.arange(len(start) - 1, dtype=np.int64), np.diff(start))
    keys = np.sort(vox_of_ref * nprim + ids)
    q = v["voxel_id"][icv].astype(np.int64) * nprim + final[v["ray"][icv]]
    pos = np.searchsorted(keys, q)
    listed = (pos < len(keys)) & (keys[np.minimum(pos, len(keys) - 1)] == q)
    first = np.full(len(tr.rays), np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first, v["ray"][icv[listed]], icv[listed])
    ret = icv[out[icv] == Outcome.RETURN]
    return int(np.sum(ret >= first[v["ray"][ret]]))


def trace_row(scene, n, res, threads, progress) -> dict:
    """One scene at subdivision n: the trace's statistics plus our own rows."""
    grid = scene.grid(n)
    _, tr = grid.trace(res, res, rules="paper", threads=threads, progress=progress)
    st = tr.stats()
    row = {k: v for k, v in st.items() if not isinstance(v, (dict, list))}
    for k, v in st["tests_by_kind"].items():
        row["tests_" + k] = v
    row["os_to_sc_shadow"] = st["os_to_sc"] - st["os_to_sc_late_hits"]
    row["hits"] = st["ic_to_sc"] + st["os_to_sc_late_hits"]
    row["returns_holding_hit"] = returns_holding_hit(tr)
    outside = st["os_input_primary"] + st["os_input_new"]
    row["returns_per_ray_early_accept"] = (st["os_input_returns"] - row["returns_holding_hit"]) / outside
    # tests by the kind of ray that made them
    kind = tr.rays["kind"][tr.visits["ray"]]
    tests = tr.visits["tests"].sum(axis=1)
    row["tests_by_primary"] = int(tests[kind == RayKind.PRIMARY].sum())
    row["tests_by_shadow"] = int(tests[kind == RayKind.SHADOW].sum())
    row["tests_by_secondary"] = int(tests.sum() - row["tests_by_primary"] - row["tests_by_shadow"])
    row.update(by_ray_class(tr))
    gs = grid.stats()
    row["grid_nonempty"], row["grid_refs"] = gs["nonempty"], gs["refs"]
    return row


def grid_independent(trace_rows) -> bool:
    """Whether every count not describing the grid is the same at every subdivision, per scene."""
    ok = True
    for name in SCENES:
        rs = [r for r in trace_rows if r["scene"] == name]
        for key in rs[0]:
            if key not in GRID_KEYS and any(r[key] != rs[0][key] for r in rs):
                ok = False
                log(f"WARNING: {name} {key} differs between subdivisions")
    return ok


def balls_comparison(balls_rows, subdivisions):
    """Rows: (key, label, unit, [(ours, paper, ratio) per subdivision]), and the same as CSV rows;
    the paper's values only where our subdivision is one of the paper's."""
    out, csv_rows = [], []
    for key, label, unit in ROWS:
        if key not in PAPER_BALLS and key not in OURS_ONLY:
            continue
        cells = []
        for n in subdivisions:
            ours = balls_rows[n][key]
            paper = None
            if key in PAPER_BALLS and n in PAPER_SUBDIVISIONS:
                pv = PAPER_BALLS[key][PAPER_SUBDIVISIONS.index(n)]
                paper = pv * (1e3 if unit == "K" else 1e6 if unit == "M" else 1)
            ratio = ours / paper if paper else None
            cells.append((ours, paper, ratio))
            csv_rows.append({"row": key, "subdivision": n, "ours": ours,
                             "paper": "" if paper is None else (round(paper, 4) if unit == "" else int(paper)),
                             "ratio": "" if ratio is None else round(ratio, 3)})
        out.append((key, label, unit, cells))
    return out, csv_rows


def _label(label: str) -> str:
    return "&nbsp;&nbsp;" + label.strip() if label.startswith("  ") else label.strip()


def tables_markdown(title, table, trace_rows, subdivisions) -> str:
    header = ["balls"]
    for n in subdivisions:
        header += [f"ours {n}", f"paper {n}", "ratio"]
    rows = []
    for _, label, unit, cells in table:
        r = [_label(label)]
        for ours, paper, ratio in cells:
            r += [fmt_unit(ours, unit), "" if paper is None else fmt_unit(paper, unit),
                  "" if ratio is None else f"{ratio:.2f}"]
        rows.append(r)
    md = [f"# {title}\n", "## balls: ours and the paper's (thousands; voxels and tests in millions)\n",
          md_table(header, rows)]
    for name in SCENES:
        rs = {r["subdivision"]: r for r in trace_rows if r["scene"] == name}
        md.append(f"\n## {name}\n")
        md.append(md_table([name] + [str(n) for n in subdivisions],
                           [[_label(lab)] + [fmt_unit(rs[n][key], unit) for n in subdivisions]
                            for key, lab, unit in ROWS]))
    return "\n".join(md)


def comparison_text(table, subdivisions) -> str:
    w = max(len(lab) for _, lab, _, _ in table)
    head = f"{'balls (K; voxels, tests M)':<{w}}" + "".join(f" | {'ours ' + str(n):>9} {'paper':>7} {'ratio':>5}"
                                                            for n in subdivisions)
    lines = [head, "-" * len(head)]
    for _, label, unit, cells in table:
        s = f"{label:<{w}}"
        for ours, paper, ratio in cells:
            s += f" | {fmt_unit(ours, unit):>9} {'' if paper is None else fmt_unit(paper, unit):>7} " \
                 f"{'' if ratio is None else f'{ratio:.2f}':>5}"
        lines.append(s)
    return "\n".join(lines)


def plot(trace_rows, subdivisions, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    keys = ("voxels_traversed", "tests", "returns_per_ray")
    scale = (1e6, 1e6, 1)
    for name in SCENES:
        rs = [r for r in trace_rows if r["scene"] == name]
        ns = [r["subdivision"] for r in rs]
        line, = axes[0].plot(ns, [r[keys[0]] / scale[0] for r in rs], "o-", label=name)
        for ax, key, s in zip(axes[1:], keys[1:], scale[1:]):
            ax.plot(ns, [r[key] / s for r in rs], "o-", color=line.get_color(), label=name)
    for ax, key in zip(axes, keys):
        ax.plot(PAPER_SUBDIVISIONS, PAPER_BALLS[key], "k*--", ms=11, label="balls, paper")
        ax.set_xlabel("subdivision per axis")
        ax.set_xticks(subdivisions)
    axes[0].set_ylabel("voxels traversed (millions)")
    axes[1].set_ylabel("intersection tests (millions)")
    axes[1].set_yscale("log")
    axes[2].set_ylabel("IC -> OS returns per ray from outside")
    for ax, title in zip(axes, ("OS work", "IC work", "Returns per ray")):
        ax.set_title(title)
    axes[0].legend(fontsize=8)
    fig.suptitle("3MPRT counts, 512x512, paper rules, threshold 1/512 (ours: lines; paper's balls: stars)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    a, out = study_args(__file__, "our 3MPRT counts in the layout of the paper's tables",
                        "64x64, subdivisions 8 and 16, scenes at size 2, no plot", argv)
    t_start = time.perf_counter()
    res, size, subdivisions = quick_or_full(a.quick)
    progress = not a.quick
    trace_rows = []
    for name in SCENES:
        scene = mprt.Scene.spd(name, size)
        for n in subdivisions:
            t0 = time.perf_counter()
            row = trace_row(scene, n, res, a.threads, progress)
            trace_rows.append({"scene": name, "subdivision": n, **row})
            log(f"traced {name:5s} at {n:3d}^3: {row['rays']:,} rays, {row['visits']:,} visits, "
                f"{row['tests']:,} tests ({time.perf_counter() - t0:.1f} s)")
    write_csv(os.path.join(out, "paper_rows.csv"), trace_rows)
    balls = {r["subdivision"]: r for r in trace_rows if r["scene"] == "balls"}
    table, cmp_csv = balls_comparison(balls, subdivisions)
    write_csv(os.path.join(out, "balls_vs_paper.csv"), cmp_csv)
    write_checks(os.path.join(out, "checks.csv"), {"counts_not_describing_the_grid_are_grid_independent":
                                                   grid_independent(trace_rows)})
    title = (f"Paper tables ({'quick: ' if a.quick else ''}{res}x{res}, paper rules, threshold 1/512"
             f"{', SPD size 2' if a.quick else ', SPD default sizes'})")
    with open(os.path.join(out, "tables.md"), "w") as f:
        f.write(tables_markdown(title, table, trace_rows, subdivisions))
    log("\n" + comparison_text(table, subdivisions))
    if not a.quick:
        plot(trace_rows, subdivisions, os.path.join(out, "paper_tables.png"))
    log(f"\nwrote {os.path.relpath(out)}/ in {time.perf_counter() - t_start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
