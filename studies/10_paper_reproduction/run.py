"""Paper reproduction: the paper's Table 2 and figure 6 from our traces and machine model.

The cost model is calibrated on balls only (the digest's per-unit averages at
subdivisions 20, 50, 100).  Then balls, mount, rings, tetra and tree (SPD
default sizes, 512x512, the paper1992 workload preset: paper rules with the
conventions of study 12 that reproduce the paper's counts; --rules paper for
the clean rules) at subdivisions 20, 50 and 100 are
traced to a temporary folder one at a time, costed on the sequential
processor of models S and M, and replayed whole by the compiled engine
(exact for these ideal-network configurations); each trace is deleted after
use.  For every scene and subdivision a random sample of tiles is also
replayed by the SimPy model and compared with the compiled engine, result
and event log.  Balls is set beside the digest's figures; the best
subdivision per scene and the S/M speed-ups are tabulated; figure6.png shows
each stage's processing, communication and waiting under model M.

In the full run the balls-only calibration uses the 512x512 balls traces of
this run (the counts behind the fit are those of the frames replayed); the
quick run (64x64, scenes at size 2, subdivisions 8 and 16, no plot, to ref/)
fits on the shipped balls counts, since the paper's cells exist only at the
SPD default sizes and subdivisions 20, 50, 100.

    python studies/10_paper_reproduction/run.py [--quick] [--out DIR] [--threads 2] [--tmp DIR]
                                                [--rules paper1992|paper]

Writes calibration.csv, residuals.csv, table2.csv, balls_vs_paper.csv,
best_subdivision.csv, fidelity.csv, checks.csv, table2.md (and, in the full
run, processing_vs_paper.csv, figure6.png and timing.csv) to studies/out/10_paper_reproduction/.
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import (PAPER_BALLS, PAPER_SUBDIVISIONS, SCENES, log, md_table, quick_or_full,  # noqa: E402
                     study_args, write_checks, write_csv)
from mprt.cost import CostModel  # noqa: E402
from mprt.cost.calibrate import PAPER as PAPER_UNIT  # noqa: E402
from mprt.cost.calibrate import counts_row, residual_table, residuals_of  # noqa: E402
from mprt.fidelity.compiled import Compiled  # noqa: E402
from mprt.machine import builtin, simulate  # noqa: E402

STAGES = ("OS", "IC", "SC")
CATEGORIES = ("processing", "communication", "waiting")
MODELS = ("S", "M")
# the count each stage's per-unit average is taken over (digest, "average cycles")
UNIT_COUNT = {"OS": "voxels_traversed", "IC": "tests", "SC": "sc_input"}
UNIT_TEXT = {"OS": "per voxel", "IC": "per test", "SC": "per SC ray"}
# The digest's balls times and stage processing, millions of cycles, subdivision 20 / 50 / 100.
PAPER_BALLS_TIME = {
    "s_cycles": (35173, 11526, 7308),
    "m_cycles": (33586, 8982, 4375),
    "OS_processing": (994, 1975, 3641),
    "IC_processing": (33148, 8429, 2346),
    "SC_processing": (176, 180, 178),
}
# The digest's mount and tetra counts behind its per-unit averages: voxels and tests in millions,
# SC input in thousands, subdivision 20 / 50 / 100 (its times for these scenes are not given).
PAPER_COUNTS = {
    "mount": {"voxels_traversed": (11, 26, 52), "tests": (99, 31, 12), "sc_input": (547, 547, 545)},
    "tetra": {"voxels_traversed": (3, 9, 20), "tests": (28, 10, 6), "sc_input": (74, 74, 73)},
}
UNIT_SCALE = {"voxels_traversed": 1e6, "tests": 1e6, "sc_input": 1e3}
LARGE_WINDOW = 1 << 20      # model M with (practically) no bound on the rays in flight


# ---- tracing, costing, replaying ------------------------------------------------------------------

def trace_to(grid, res, rules, path, threads, progress):
    """A whole frame streamed to `path` (bounded memory), opened memory-mapped."""
    _, tr = grid.trace(res, res, rules=rules, threads=threads, path=path, progress=progress)
    return tr


def stage_rows(tr) -> dict:
    """The trace's counts the tables use."""
    st = tr.stats()
    keep = ("rays", "visits", "os_input", "ic_input", "sc_input", "voxels_traversed", "tests")
    return {**{k: st[k] for k in keep}, "tiles_total": tr.meta["tiles_total"]}


def replay_frame(tr, cm) -> dict:
    """Models S and M (and M with no window bound) on a whole frame by the compiled engine."""
    costs = cm.visit_costs(tr, builtin("M").processors())      # S and M: the same sequential processor
    engine = Compiled(tr, costs)
    out = {m: engine.result(builtin(m)) for m in MODELS}
    out["M_open"] = engine.cycles(builtin("M").replace(window=LARGE_WINDOW))
    return out


def _comparable(result) -> dict:
    d = result.to_dict()
    d.pop("wall_seconds")
    return d


def verify_sample(grid, res, rules, cm, threads, ntiles, seed=1) -> dict:
    """SimPy against the compiled engine on a random sample of about 1/64 of the frame's `ntiles`
    tiles: same result (every figure) and same event log (start and end of every visit), for S and M."""
    k = max(2, ntiles // 64)
    _, tr = grid.trace(res, res, rules=rules, threads=threads, sample=f"random:{k}:{seed}")
    costs = cm.visit_costs(tr, builtin("M").processors())
    engine = Compiled(tr, costs)
    row = {"tiles": k, "tiles_total": ntiles, "visits": len(tr.visits)}
    for m in MODELS:
        a = simulate(tr, m, costs=costs, record=True)
        b = engine.result(builtin(m), record=True)
        row[f"{m}_cycles"] = a.cycles
        row[f"{m}_equal"] = _comparable(a) == _comparable(b) and a.log == b.log
    return row


# ---- tables ------------------------------------------------------------------------------------

def table2_row(scene, n, counts, runs) -> dict:
    """One column of the paper's Table 2: S and M times, speed-up, per stage the three categories
    of model M with their shares, rays in, and our per-unit averages."""
    s, m = runs["S"], runs["M"]
    row = {"scene": scene, "subdivision": n, "s_cycles": s.cycles, "m_cycles": m.cycles,
           "speedup": round(s.cycles / m.cycles, 4), "m_cycles_open_window": runs["M_open"],
           "s_communication": sum(s.stages[t]["communication"] for t in STAGES)}
    for t in STAGES:
        st = m.stages[t]
        for c in CATEGORIES:
            row[f"{t}_{c}"] = st[c]
        for c in CATEGORIES:
            row[f"{t}_{c}_share"] = round(st[c] / m.cycles, 4)
        row[f"{t}_rays_in"] = st["rays_in"]
    for t in STAGES:
        row[f"{t}_cycles_{UNIT_TEXT[t].replace(' ', '_').lower()}"] = round(
            m.stages[t]["processing"] / max(counts[UNIT_COUNT[t]], 1), 4)
    row.update({k: counts[k] for k in ("rays", "visits", "voxels_traversed", "tests", "sc_input")})
    row["packets"] = counts["os_input"] + counts["ic_input"] + counts["sc_input"]
    return row


def paper_balls(key: str, i: int):
    """The digest's balls figure `key` at subdivision index i, in cycles or counts."""
    if key in PAPER_BALLS_TIME:
        return PAPER_BALLS_TIME[key][i] * 1e6
    if key in ("voxels_traversed", "tests"):
        return PAPER_BALLS[key][i] * 1e6
    if key == "packets":      # every ray handed to a stage: OS, IC and SC inputs
        return (PAPER_BALLS["os_input"][i] + PAPER_BALLS["os_to_ic"][i] + PAPER_BALLS["sc_input"][i]) * 1e3
    return PAPER_BALLS[key][i] * 1e3


def balls_figures(src) -> dict:
    """The balls rows from a Table-2 row (src = our row's value) or the paper's (src = paper_balls)."""
    f = {k: src(k) for k in ("s_cycles", "m_cycles", "OS_processing", "IC_processing", "SC_processing",
                             "voxels_traversed", "tests", "sc_input", "packets")}
    f["speedup"] = f["s_cycles"] / f["m_cycles"]
    f["s_minus_processing"] = f["s_cycles"] - sum(f[f"{t}_processing"] for t in STAGES)
    f["s_minus_processing_per_packet"] = f["s_minus_processing"] / f["packets"]
    for t in STAGES:
        f[f"{t}_per_unit"] = f[f"{t}_processing"] / f[UNIT_COUNT[t]]
        f[f"{t}_processing_share"] = f[f"{t}_processing"] / f["m_cycles"]
    return f


BALLS_ROWS = [
    ("s_cycles", "model S time (M cycles)", "M"),
    ("m_cycles", "model M time (M cycles)", "M"),
    ("speedup", "speed-up S/M", "x"),
    ("OS_processing", "OS processing (M cycles)", "M"),
    ("IC_processing", "IC processing (M cycles)", "M"),
    ("SC_processing", "SC processing (M cycles)", "M"),
    ("OS_processing_share", "OS processing, share of M time", "%"),
    ("IC_processing_share", "IC processing, share of M time", "%"),
    ("SC_processing_share", "SC processing, share of M time", "%"),
    ("s_minus_processing", "S time - processing: communication in S (M cycles)", "M"),
    ("packets", "packets: OS + IC + SC input rays (K)", "K"),
    ("s_minus_processing_per_packet", "communication in S per packet (cycles)", "1"),
    ("voxels_traversed", "voxels traversed (M)", "M"),
    ("tests", "intersection tests (M)", "M"),
    ("sc_input", "SC input rays (K)", "K"),
    ("OS_per_unit", "OS cycles per voxel", "1"),
    ("IC_per_unit", "IC cycles per test", "1"),
    ("SC_per_unit", "SC cycles per SC ray", "1"),
]


def balls_vs_paper(rows, subdivisions) -> list:
    """CSV rows: each balls figure, ours and the paper's (where the subdivision is one of the
    paper's), with the ratio; the paper's speed-up, S - processing and shares are derived from
    its times, processing and counts."""
    out = []
    for n in subdivisions:
        r = next(x for x in rows if x["scene"] == "balls" and x["subdivision"] == n)
        ours = balls_figures(lambda k: r[k])
        paper = None
        if n in PAPER_SUBDIVISIONS:
            i = PAPER_SUBDIVISIONS.index(n)
            paper = balls_figures(lambda k: paper_balls(k, i))
        for key, _, _ in BALLS_ROWS:
            p = paper[key] if paper else None
            out.append({"row": key, "subdivision": n, "ours": round(float(ours[key]), 4),
                        "paper": "" if p is None else round(float(p), 4),
                        "ratio": "" if p is None else round(float(ours[key] / p), 4)})
    return out


def paper_stage(scene: str, i: int) -> dict | None:
    """The paper's {stage: (processing cycles, count)} at subdivision index i, for the scenes whose
    counts the digest gives: balls (its processing), mount and tetra (per-unit average x count);
    None for rings and tree."""
    if scene == "balls":
        return {t: (paper_balls(f"{t}_processing", i), paper_balls(UNIT_COUNT[t], i)) for t in STAGES}
    if scene not in PAPER_COUNTS:
        return None
    out = {}
    for t in STAGES:
        count = PAPER_COUNTS[scene][UNIT_COUNT[t]][i] * UNIT_SCALE[UNIT_COUNT[t]]
        out[t] = (PAPER_UNIT[scene][t][i] * count, count)
    return out


def processing_decomposition(rows, subdivisions) -> list:
    """Per scene with paper counts, subdivision and stage: ours / paper processing = (ours / paper
    count) x (ours / paper cycles per unit)."""
    out = []
    for r in rows:
        n = r["subdivision"]
        paper = paper_stage(r["scene"], PAPER_SUBDIVISIONS.index(n)) if n in PAPER_SUBDIVISIONS else None
        if paper is None:
            continue
        for t in STAGES:
            p_proc, p_count = paper[t]
            proc, count = r[f"{t}_processing"], r[UNIT_COUNT[t]]
            out.append({"scene": r["scene"], "subdivision": n, "stage": t, "processing": proc,
                        "paper_processing": round(p_proc), "processing_ratio": round(proc / p_proc, 4),
                        "count": UNIT_COUNT[t], "count_ratio": round(count / p_count, 4),
                        "per_unit": round(proc / count, 4), "paper_per_unit": round(p_proc / p_count, 4),
                        "per_unit_ratio": round((proc / count) / (p_proc / p_count), 4)})
    return out


def best_subdivisions(rows, subdivisions) -> list:
    """Per scene: S and M times and speed-up at each subdivision, our best for S and M, and the
    paper's where the digest allows (balls: its times; mount, tetra: its implied processing, the
    largest stage's for M and the sum for S, communication not included)."""
    out = []
    for name in SCENES:
        rs = {r["subdivision"]: r for r in rows if r["scene"] == name}
        row = {"scene": name}
        for n in subdivisions:
            row[f"s_cycles_{n}"] = rs[n]["s_cycles"]
        for n in subdivisions:
            row[f"m_cycles_{n}"] = rs[n]["m_cycles"]
        for n in subdivisions:
            row[f"speedup_{n}"] = rs[n]["speedup"]
        row["best_s"] = min(subdivisions, key=lambda n: rs[n]["s_cycles"])
        row["best_m"] = min(subdivisions, key=lambda n: rs[n]["m_cycles"])
        row["best_m_open_window"] = min(subdivisions, key=lambda n: rs[n]["m_cycles_open_window"])
        implied = None
        if tuple(subdivisions) == PAPER_SUBDIVISIONS and paper_stage(name, 0):
            implied = [{t: p[0] for t, p in paper_stage(name, i).items()} for i in range(3)]
        if name == "balls" and implied:
            row["paper_best_s"] = PAPER_SUBDIVISIONS[min(range(3), key=lambda i: PAPER_BALLS_TIME["s_cycles"][i])]
            row["paper_best_m"] = PAPER_SUBDIVISIONS[min(range(3), key=lambda i: PAPER_BALLS_TIME["m_cycles"][i])]
            row["paper_basis"] = "times"
        elif implied:
            row["paper_best_s"] = PAPER_SUBDIVISIONS[min(range(3), key=lambda i: sum(implied[i].values()))]
            row["paper_best_m"] = PAPER_SUBDIVISIONS[min(range(3), key=lambda i: max(implied[i].values()))]
            row["paper_basis"] = "per-unit averages x counts (processing only)"
        else:
            row["paper_best_s"] = row["paper_best_m"] = row["paper_basis"] = ""
        out.append(row)
    return out


# ---- Markdown ----------------------------------------------------------------------------------

def _mc(v) -> str:
    return f"{v / 1e6:,.0f}" if v >= 1e8 else f"{v / 1e6:,.1f}"


def _fmt(v, unit) -> str:
    if v == "" or v is None:
        return ""
    if unit == "M":
        return _mc(v)
    if unit == "K":
        return f"{v / 1e3:,.0f}"
    if unit == "%":
        return f"{100 * v:.1f}%"
    if unit == "x":
        return f"{v:.2f}"
    return f"{v:,.1f}"


def table2_markdown(name, rows, subdivisions) -> str:
    rs = {r["subdivision"]: r for r in rows if r["scene"] == name}
    body = [["model S time (M cycles)"] + [_mc(rs[n]["s_cycles"]) for n in subdivisions],
            ["model M time (M cycles)"] + [_mc(rs[n]["m_cycles"]) for n in subdivisions],
            ["speed-up S/M"] + [f"{rs[n]['speedup']:.2f}" for n in subdivisions]]
    for t in STAGES:
        for c in CATEGORIES:
            body.append([f"{t} {c} (M cycles, share)"]
                        + [f"{_mc(rs[n][f'{t}_{c}'])} ({100 * rs[n][f'{t}_{c}_share']:.1f}%)" for n in subdivisions])
    for t in STAGES:
        body.append([f"{t} input rays (K)"] + [f"{rs[n][f'{t}_rays_in'] / 1e3:,.0f}" for n in subdivisions])
    body.append(["model M time, no window bound (M cycles)"]
                + [_mc(rs[n]["m_cycles_open_window"]) for n in subdivisions])
    return md_table([name] + [str(n) for n in subdivisions], body)


def balls_markdown(cmp_rows, subdivisions) -> str:
    by = {(c["row"], c["subdivision"]): c for c in cmp_rows}
    header = ["balls"]
    for n in subdivisions:
        header += [f"ours {n}", f"paper {n}", "ratio"]
    body = []
    for key, label, unit in BALLS_ROWS:
        r = [label]
        for n in subdivisions:
            c = by[(key, n)]
            r += [_fmt(c["ours"], unit), _fmt(c["paper"], unit), "" if c["ratio"] == "" else f"{c['ratio']:.2f}"]
        body.append(r)
    return md_table(header, body)


def markdown(title, cal_rows, residuals, rows, cmp_rows, decomposition, best, fidelity, subdivisions) -> str:
    md = [f"# {title}\n", "## Calibration on balls only\n",
          md_table(["constant", "value"], [[c["constant"], c["value"]] for c in cal_rows]),
          "\nPer-unit averages (model M, sequential processors), paper against ours; scenes other than balls "
          "are predictions:\n", residual_table(residuals, ("balls",)) + "\n",
          "## balls beside the paper (derived rows: speed-up, S - processing, shares, per-unit)\n",
          balls_markdown(cmp_rows, subdivisions)]
    if decomposition:
        md += ["\n## Processing: counts or costs\n",
               "Ours / paper processing = count ratio x per-unit ratio.  balls: the paper's processing; "
               "mount and tetra: the paper's per-unit average x its count (the digest gives no times):\n",
               md_table(["scene", "subdivision", "stage", "ours (M cycles)", "paper (M cycles)", "ratio", "count",
                         "count ratio", "per-unit ours", "per-unit paper", "per-unit ratio"],
                        [[d["scene"], d["subdivision"], d["stage"], _mc(d["processing"]), _mc(d["paper_processing"]),
                          f"{d['processing_ratio']:.2f}", d["count"], f"{d['count_ratio']:.2f}",
                          f"{d['per_unit']:.1f}", f"{d['paper_per_unit']:.1f}", f"{d['per_unit_ratio']:.2f}"]
                         for d in decomposition])]
    md.append("\n## Table 2: model S and model M, per stage (model M)\n")
    for name in SCENES:
        md += [f"\n### {name}\n", table2_markdown(name, rows, subdivisions)]
    md.append("\n## Best subdivision and speed-ups\n")
    md.append(md_table(["scene"] + [f"S/M at {n}" for n in subdivisions]
                       + ["best (M)", "best (S)", "best (M, no window bound)", "paper best (M / S)", "paper basis"],
                       [[b["scene"]] + [f"{b[f'speedup_{n}']:.2f}" for n in subdivisions]
                        + [b["best_m"], b["best_s"], b["best_m_open_window"],
                           f"{b['paper_best_m']} / {b['paper_best_s']}" if b["paper_best_m"] else "",
                           b["paper_basis"]] for b in best]))
    md.append("\n## SimPy against the compiled engine on sampled tiles\n")
    md.append(md_table(["scene", "subdivision", "tiles", "visits", "S cycles", "S equal", "M cycles", "M equal"],
                       [[f["scene"], f["subdivision"], f"{f['tiles']} of {f['tiles_total']}", f"{f['visits']:,}",
                         f"{f['S_cycles']:,}", f["S_equal"], f"{f['M_cycles']:,}", f["M_equal"]]
                        for f in fidelity]))
    return "\n".join(md)


# ---- figure 6 -------------------------------------------------------------------------------------

COLOURS = {"processing": "#4878a8", "communication": "#e0a040", "waiting": "#c8c8c8"}


def figure6(rows, subdivisions, path, rules="paper1992") -> dict:
    """Per-stage load bars of model M (processing, communication, waiting), one panel per scene,
    a group of three bars (OS, IC, SC) per subdivision.  Returns {(scene, n, stage): bar length in
    cycles} as drawn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(SCENES), 1, figsize=(8, 2.1 * len(SCENES)))
    drawn = {}
    for ax, name in zip(axes, SCENES):
        rs = {r["subdivision"]: r for r in rows if r["scene"] == name}
        labels, left = [], {}
        for n in subdivisions:
            for t in STAGES:
                labels.append(f"{n}: {t}")
                left[(n, t)] = 0.0
        for c in CATEGORIES:
            vals = [rs[n][f"{t}_{c}"] for n in subdivisions for t in STAGES]
            ax.barh(labels, [v / 1e6 for v in vals], left=[left[(n, t)] / 1e6 for n in subdivisions for t in STAGES],
                    color=COLOURS[c], label=c if name == SCENES[0] else None)
            for (n, t), v in zip([(n, t) for n in subdivisions for t in STAGES], vals):
                left[(n, t)] += v
        for (n, t), v in left.items():
            drawn[(name, n, t)] = v
        ax.invert_yaxis()
        ax.tick_params(axis="y", labelsize=7)
        ax.set_title(f"{name}: model M, " + ", ".join(f"{n}: {rs[n]['m_cycles'] / 1e6:,.0f}" for n in subdivisions)
                     + " M cycles", fontsize=9)
    axes[-1].set_xlabel("million cycles")
    fig.legend(loc="lower center", fontsize=8, ncol=3)
    fig.suptitle(f"Figure 6 (ours): per-stage load under model M, 512x512, {rules} rules", fontsize=10)
    fig.tight_layout(rect=(0, 0.03, 1, 0.98))
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return drawn


# ---- checks ---------------------------------------------------------------------------------------

def cell_checks(counts, runs) -> dict:
    """Invariants of one scene and subdivision's replay."""
    s, m = runs["S"], runs["M"]
    return {
        "S time is its processing plus communication": s.cycles == sum(
            s.stages[t]["processing"] + s.stages[t]["communication"] for t in STAGES),
        "M is never slower than S": m.cycles <= s.cycles,
        "M time is at least its largest stage load": m.cycles >= max(m.stage_load(t) for t in STAGES),
        "processing + communication + waiting = M time for every stage": all(
            sum(m.stages[t][c] for c in CATEGORIES) == m.cycles for t in STAGES),
        "rays in per stage equal the trace's statistics": all(
            r.stages[t]["rays_in"] == counts[k] for r in (s, m)
            for t, k in (("OS", "os_input"), ("IC", "ic_input"), ("SC", "sc_input"))),
        "every visit replayed": s.visits == m.visits == counts["visits"],
        "M with no window bound is never slower than S": runs["M_open"] <= s.cycles,
    }


def calibration_rows(model) -> list:
    rows = [{"constant": f"latency {k}", "value": v} for k, v in model.latency.items()]
    rows += [{"constant": f"visit overhead {k}", "value": v} for k, v in model.visit_overhead.items()]
    rows += [{"constant": f"scale {k} (%)", "value": v} for k, v in model.scale.items()]
    rows.append({"constant": "fitted on", "value": " ".join(model.info.get("scenes", []))})
    rows.append({"constant": "counts at", "value": " ".join(model.info.get("resolution", []))})
    return rows


def residual_rows(residuals) -> list:
    return [{"scene": r.scene, "subdivision": r.grid, "stage": r.stage, "unit": UNIT_TEXT[r.stage],
             "paper": r.paper, "ours": round(r.ours, 4), "error": round(r.rel, 4),
             "fitted": "true" if r.scene == "balls" else "false"} for r in residuals]


# ---- main -----------------------------------------------------------------------------------------

class Study:
    """The cells' results as they come: Table-2 rows, sample checks, invariants, timings."""

    def __init__(self, res, rules, threads):
        self.res, self.rules, self.threads = res, rules, threads
        self.rows, self.fidelity, self.checks, self.timing = [], [], {}, []

    def replay(self, cell, cm) -> None:
        """Replay one traced frame whole (compiled), check it, delete its trace, check a sample of its
        tiles with SimPy."""
        name, n, grid, path, counts, t_trace = cell["name"], cell["n"], cell["grid"], cell["path"], \
            cell["counts"], cell["trace_s"]
        t1 = time.perf_counter()
        runs = replay_frame(cell.pop("trace"), cm)
        t2 = time.perf_counter()
        os.remove(path)
        self.rows.append(table2_row(name, n, counts, runs))
        for k, v in cell_checks(counts, runs).items():
            self.checks[k] = self.checks.get(k, True) and v
        fid = verify_sample(grid, self.res, self.rules, cm, self.threads, counts["tiles_total"])
        self.fidelity.append({"scene": name, "subdivision": n, **fid})
        t3 = time.perf_counter()
        self.timing.append({"scene": name, "subdivision": n, "visits": counts["visits"], "trace_s": f"{t_trace:.1f}",
                            "replay_s": f"{t2 - t1:.1f}", "verify_s": f"{t3 - t2:.1f}"})
        log(f"  {name} {n}: S {runs['S'].cycles:,}, M {runs['M'].cycles:,} cycles (replay {t2 - t1:.0f} s, "
            f"sample check {t3 - t2:.0f} s: {fid['S_equal'] and fid['M_equal']})")


def run_cells(a, tmp, res, size, subdivisions):
    """Trace, replay and check every scene and subdivision; returns (study, calibration, counts rows
    of the traces behind the calibration, or [] in quick mode)."""
    study = Study(res, a.rules, a.threads)
    cal = CostModel.calibrate(scenes=("balls",)) if a.quick else None
    calib_counts, pending = [], []
    for name in SCENES:
        scene = mprt.Scene.spd(name, size)
        for n in subdivisions:
            grid = scene.grid(n)
            t0 = time.perf_counter()
            path = os.path.join(tmp, f"{name}-{n}.npz")
            tr = trace_to(grid, res, a.rules, path, a.threads, not a.quick and sys.stderr.isatty())
            counts = stage_rows(tr)
            if not a.quick:
                calib_counts.append(counts_row(tr))
            pending.append({"name": name, "n": n, "grid": grid, "trace": tr, "path": path, "counts": counts,
                            "trace_s": time.perf_counter() - t0})
            del tr
            log(f"traced {name} at {n}^3: {counts['rays']:,} rays, {counts['visits']:,} visits "
                f"({time.perf_counter() - t0:.0f} s)")
            if cal is None:
                if name != "balls" or n != subdivisions[-1]:
                    continue          # balls' traces wait for the calibration on all three
                cal = CostModel.calibrate(calib_counts, scenes=("balls",))
                log(f"calibrated on balls: {cal.model}")
            for cell in pending:
                study.replay(cell, cal.model)
            pending.clear()
    return study, cal, calib_counts


def write_outputs(out, title, study, cal, residuals, subdivisions) -> None:
    cm, rows = cal.model, study.rows
    cal_rows = calibration_rows(cm)
    cmp_rows = balls_vs_paper(rows, subdivisions)
    decomposition = processing_decomposition(rows, subdivisions)
    best = best_subdivisions(rows, subdivisions)
    write_csv(os.path.join(out, "calibration.csv"), cal_rows)
    write_csv(os.path.join(out, "residuals.csv"), residual_rows(residuals))
    write_csv(os.path.join(out, "table2.csv"), rows)
    write_csv(os.path.join(out, "balls_vs_paper.csv"), cmp_rows)
    write_csv(os.path.join(out, "best_subdivision.csv"), best)
    if decomposition:
        write_csv(os.path.join(out, "processing_vs_paper.csv"), decomposition)
    write_csv(os.path.join(out, "fidelity.csv"), study.fidelity)
    write_checks(os.path.join(out, "checks.csv"), study.checks)
    md = markdown(title, cal_rows, residuals, rows, cmp_rows, decomposition, best, study.fidelity, subdivisions)
    with open(os.path.join(out, "table2.md"), "w") as f:
        f.write(md)
    log("\n" + md)


def per_unit_agrees(rows, residuals) -> bool:
    """The machine's processing over the paper's count is the calibration's per-unit value of the cell."""
    by = {(r.scene, r.grid, r.stage): r.ours for r in residuals}
    return all(abs(r[f"{t}_processing"] / r[UNIT_COUNT[t]] - by[(r["scene"], r["subdivision"], t)]) < 1e-6
               for r in rows for t in STAGES)


def main(argv=None) -> int:
    def extra(ap):
        ap.add_argument("--tmp", default=None, help="folder for the temporary traces (default: the system's)")
        ap.add_argument("--rules", choices=("paper1992", "paper"), default="paper1992",
                        help="workload: the paper1992 preset (paper rules with the conventions that reproduce "
                             "the paper's counts, docs/workload.md; default) or the clean paper rules")

    a, out = study_args(__file__, "the paper's Table 2 and figure 6 from a cost model calibrated on balls only",
                        "64x64, scenes at size 2, subdivisions 8 and 16, shipped balls counts, no plot", argv, extra)
    t_start = time.perf_counter()
    res, size, subdivisions = quick_or_full(a.quick)
    tmp = tempfile.mkdtemp(prefix="mprt-repro-", dir=a.tmp)
    try:
        study, cal, calib_counts = run_cells(a, tmp, res, size, subdivisions)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    residuals = cal.residuals if a.quick else residuals_of(cal.model, calib_counts)
    study.checks["SimPy equals the compiled engine on the sampled tiles of every scene and subdivision"] = all(
        f["S_equal"] and f["M_equal"] for f in study.fidelity)
    if not a.quick:
        study.checks["per-unit cycles of the replay equal the calibration's"] = per_unit_agrees(study.rows, residuals)
    title = (f"Paper reproduction ({'quick: ' if a.quick else ''}{res}x{res}, {a.rules} rules, "
             f"{'SPD size 2' if a.quick else 'SPD default sizes'})")
    write_outputs(out, title, study, cal, residuals, subdivisions)
    if not a.quick:
        figure6(study.rows, subdivisions, os.path.join(out, "figure6.png"), a.rules)
        write_csv(os.path.join(out, "timing.csv"), study.timing + [
            {"scene": "all", "visits": sum(t["visits"] for t in study.timing),
             "wall_s": f"{time.perf_counter() - t_start:.1f}"}])
    log(f"\nwrote {os.path.relpath(out)}/ in {time.perf_counter() - t_start:.0f} s")
    return 0 if all(study.checks.values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
