"""Speed against error: the fidelity ladder's levels and sampling rates, per SPD scene.

    python studies/13_speed_vs_error/run.py [--res 512] [--seeds 50] [--ladder-res 128]
    python studies/13_speed_vs_error/run.py --quick      # balls and tetra at size 1, 32x32: ref/

Three parts (output in studies/out/13_speed_vs_error/, or ref/ with --quick):
1. throughput.csv: visits/s of level 0, the compiled replay and the SimPy model on
   the same replay (model M, costs given to all three), side by side, best of --repeat;
   what is done once per costed trace (load) and per design apart.
2. sampled.csv: sampled replay of model M at --res (default grid) against the full
   replay, per scene, tile edge and sampling rate over --seeds seeds: error of the
   estimate (mean, rms, worst), how often the 95% interval covers the truth, and the
   work replayed (visits / the frame's).
3. ladder.csv and choice.csv: per scene at --ladder-res, every configuration of
   CONFIGS at every level (0 to 3) and sampling rate (whole frame, 1/4, 1/16): the
   estimate's error against level 3 on the whole frame, and seconds per design; the
   cheapest (level, rate) within 1% and 5% (worst error over the configurations).
   speed_vs_error.png plots them, with the 1% line.
The quick run writes what does not depend on timing (and no plot) and checks.csv.
"""
from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import log, study_args, write_checks, write_table  # noqa: E402
from mprt.cost import CostModel  # noqa: E402
from mprt.fidelity import Analytical, Compiled, Evaluator, sample_trace  # noqa: E402
from mprt.fidelity import sampled as S  # noqa: E402
from mprt.machine import DeadlockError, builtin, make_stage  # noqa: E402
from mprt.machine.system import System  # noqa: E402

SCENES = ("balls", "gears", "mount", "rings", "tetra", "tree")
RATES = (1, 4, 16)                 # one tile in RATE: the whole frame, a quarter, a sixteenth
LEVELS = (0, 1, 2, 3)


def configs():
    """The designs each level is measured on: model M, the paper's 3MPPE, and two variants of
    it (one PE with a small window; OS and SC on one processor)."""
    full = builtin("3mppe")
    merged = full.replace(name="3mppe-OS+SC|IC", stages=(make_stage(("OS", "SC"), "paper:OS", send_fifo=8,
                                                                     receive_fifo=48),
                                                          make_stage(("IC",), "paper", send_fifo=8, receive_fifo=48)),
                          ring=full.ring.__class__(flit_time=1, buffer_classes=2))
    return [builtin("M"), full, full.replace(name="3mppe-1pe", pes=1, window=2), merged]


def costed(trace, cfg, cm):
    return cm.visit_costs(trace, cfg.processors())


def sliced(vc, keep):
    from types import SimpleNamespace

    return SimpleNamespace(process=vc.process[keep], receive=vc.receive[keep], send=vc.send[keep],
                           flits=vc.flits[keep], inject_process=vc.inject_process, inject_send=vc.inject_send,
                           inject_flits=vc.inject_flits)


# ---- 1. throughput ------------------------------------------------------------------------

def throughput(trace, repeat: int, quick: bool) -> list:
    """Level 0, compiled and SimPy on one replay of model M, interleaved, best of repeat: the
    once-per-costed-trace part (level 0's per-tree reduction; the compiled replay's load) and
    the per-design part (level 0's estimate, the compiled replay's run to a full SimResult, and
    its run alone to the cycles) apart, each against SimPy's whole replay (a SimPy replay
    has no part to keep between designs)."""
    cfg = builtin("M")
    vc = costed(trace, cfg, CostModel.default())
    n = len(trace.visits)
    parts = (("level 0 (analytical)", "once: per-tree reduction"), ("level 0 (analytical)", "per design: estimate"),
             ("level 1 compiled (C)", "once: load"), ("level 1 compiled (C)", "per design: SimResult"),
             ("level 1 compiled (C)", "per design: cycles only"), ("level 1 SimPy", "per design"))
    best = dict.fromkeys(parts, math.inf)
    cycles = {}
    for _ in range(repeat):
        t = [time.perf_counter()]
        an = Analytical(trace, vc)
        t.append(time.perf_counter())
        c0 = an.result(cfg).cycles
        t.append(time.perf_counter())
        comp = Compiled(trace, vc)
        t.append(time.perf_counter())
        c1 = comp.result(cfg).cycles
        t.append(time.perf_counter())
        c2 = comp.cycles(cfg)
        t.append(time.perf_counter())
        c3 = System(trace, cfg, costs=vc).run().cycles
        t.append(time.perf_counter())
        del comp
        for k, a, b, c in zip(parts, t, t[1:], (c0, c0, c1, c1, c2, c3)):
            best[k] = min(best[k], b - a)
            cycles[k] = c
    rows = []
    simpy = best[parts[-1]]
    for k in parts:
        row = {"engine": k[0], "part": k[1], "visits": n, "cycles": cycles[k]}
        if not quick:
            row.update(seconds=best[k], visits_per_s=n / best[k], vs_simpy=simpy / best[k])
        rows.append(row)
    return rows


# ---- 2. sampled replay -----------------------------------------------------------------------

def note(acc, sc, truth, work):
    """Add one seed's estimate to acc = (errors, covered, work, half widths)."""
    acc[0].append(sc.cycles / truth - 1)
    acc[1].append(sc.interval[0] <= truth <= sc.interval[1])
    acc[2].append(work)
    acc[3].append((sc.interval[1] - sc.interval[0]) / 2 / truth)


def sample_row(scene, edge, spec, truth, own, errs, covered, work, width):
    errs = np.array(errs)
    return {"scene": scene, "tile": edge, "sample": spec, "seeds": len(errs),
            "work": float(np.mean(work)), "truth_cycles": truth, "order_effect_pct": 100 * (own / truth - 1),
            "error_mean_pct": 100 * float(errs.mean()), "error_rms_pct": 100 * float(np.sqrt(np.mean(errs ** 2))),
            "error_worst_pct": 100 * float(np.abs(errs).max()), "half_width_pct": 100 * float(np.mean(width)),
            "coverage": float(np.mean(covered))}


def sampled(scene: str, size, res: int, edges, rates, seeds: int, threads: int, methods=("runs", "tiles"),
            trace_dir=None, run_trees=None) -> list:
    """Model M on a sample against the whole frame's replay (traced in the tracer's default
    16 x 16 tiles): runs of trees of that trace (``runs:RATE:SEED``, scaled by the whole
    frame's level 0) and stratified tiles of each edge (``stratified:RATE:SEED``, scaled by
    the sample alone).  (rows, whether sampling everything gives the whole frame's replay
    in the same order exactly)."""
    cfg, cm = builtin("M"), CostModel.default()
    g = mprt.Scene.spd(scene, size).grid()
    rows, exact, frames = [], [], {}

    def frame(edge):
        if edge not in frames:
            path = os.path.join(trace_dir, f"{scene}-{res}-t{edge}.npz") if trace_dir else None
            if path and os.path.exists(path):
                full = mprt.load_trace(path)
            else:
                full = g.trace(res, res, tile=edge, threads=threads)[1]
                if path:
                    full.save(path, compress=False)
            vc = costed(full, cfg, cm)
            frames[edge] = (full, vc, Compiled(full, vc).cycles(cfg))
        return frames[edge]

    truth = frame(16)[2]
    if "runs" in methods:
        full, vc, own = frame(16)
        whole = Analytical(full, vc)
        for rate in rates:
            acc = ([], [], [], [])
            for seed in range(seeds):
                st = sample_trace(full, f"runs:{rate}:{seed}" + (f":{run_trees}" if run_trees else ""))
                svc = sliced(vc, st.visits)
                comp = Compiled(st.trace, svc)
                cycles = comp.cycles(cfg)
                sc = S.estimate_runs(st, cycles, Analytical(st.trace, svc), whole, cfg, comp.admissions())
                note(acc, sc, truth, len(st.trace.visits) / len(full.visits))
                if rate == 1:
                    exact.append(sc.cycles == own and sc.interval == (own, own))
            rows.append(sample_row(scene, 16, f"runs:{rate}" + (f":*:{run_trees}" if run_trees else ""), truth, own,
                                   *acc))
            log(f"  {scene} runs 1/{rate}: rms {rows[-1]['error_rms_pct']:.2f}%, "
                f"coverage {rows[-1]['coverage']:.2f}")
    for edge in (edges if "tiles" in methods else ()):
        full, vc, own = frame(edge)
        for rate in rates:
            acc = ([], [], [], [])
            for seed in range(seeds):
                st = sample_trace(full, f"stratified:{rate}:{seed}")
                svc = sliced(vc, st.visits)
                e = Evaluator(st.trace, costs=svc).evaluate(cfg, 1, "compiled")
                sc = S.estimate(st, e, Analytical(st.trace, svc), cfg)
                note(acc, sc, truth, len(st.trace.visits) / len(full.visits))
                if rate == 1:
                    exact.append(sc.cycles == own and sc.interval == (own, own))
            rows.append(sample_row(scene, edge, f"stratified:{rate}", truth, own, *acc))
            log(f"  {scene} tile {edge} 1/{rate}: rms {rows[-1]['error_rms_pct']:.2f}%, "
                f"coverage {rows[-1]['coverage']:.2f}")
        frames.pop(edge) if edge != 16 else None
    return rows, all(exact)


# ---- 3. the ladder --------------------------------------------------------------------------

def ladder(scene: str, size, res: int, tile: int, rates, threads: int, quick: bool) -> list:
    """Every configuration at every level and sampling rate against level 3 on the whole frame."""
    g = mprt.Scene.spd(scene, size).grid()
    _, full = g.trace(res, res, tile=tile, threads=threads)
    cm = CostModel.default()
    rows = []
    for cfg in configs():
        vc = costed(full, cfg, cm)
        whole = Evaluator(full, costs=vc)
        try:
            truth = whole.evaluate(cfg, 3).cycles
        except DeadlockError:
            truth = None
        for rate in rates:
            if rate == 1:
                ev, st, svc = whole, None, vc
            else:
                st = sample_trace(full, f"stratified:{rate}:1")
                svc = sliced(vc, st.visits)
                ev = Evaluator(st.trace, costs=svc)
            for level in LEVELS:
                try:
                    e = ev.evaluate(cfg, level)
                    est = e.cycles if st is None else S.estimate(st, e, Analytical(st.trace, svc), cfg).cycles
                    err = abs(est - truth) / truth if truth else math.inf
                except DeadlockError:
                    e, est, err = None, None, math.inf
                row = {"scene": scene, "config": cfg.name, "level": level, "rate": rate, "cycles": est,
                       "truth": truth, "error_pct": 100 * err, "engine": e.engine if e else "deadlock"}
                if not quick:
                    row["seconds"] = e.seconds if e else math.nan
                rows.append(row)
    return rows


def choices(rows: list, tolerances=(0.01, 0.05), quick: bool = False) -> list:
    """Per scene and tolerance: the cheapest (level, rate) whose worst error over the
    configurations is within it (quick: the lowest level, then the sparsest sample)."""
    out = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        combos = {}
        for r in rows:
            if r["scene"] == scene:
                c = combos.setdefault((r["level"], r["rate"]), {"worst": 0.0, "seconds": 0.0})
                c["worst"] = max(c["worst"], r["error_pct"] / 100)
                c["seconds"] = max(c["seconds"], r.get("seconds", 0.0))
        for tol in tolerances:
            ok = [(k, v) for k, v in combos.items() if v["worst"] <= tol]
            if ok:
                key = (lambda kv: (kv[0][0], -kv[0][1])) if quick else (lambda kv: (kv[1]["seconds"], kv[0][0]))
                (level, rate), v = min(ok, key=key)
                out.append({"scene": scene, "tolerance_pct": 100 * tol, "level": level, "rate": rate,
                            "worst_error_pct": 100 * v["worst"]})
            else:
                out.append({"scene": scene, "tolerance_pct": 100 * tol, "level": 3, "rate": 1,
                            "worst_error_pct": 0.0})
    return out


def plot(rows: list, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(2, (len(scenes) + 1) // 2, figsize=(5 * ((len(scenes) + 1) // 2), 8), squeeze=False)
    colours = {0: "#c04040", 1: "#4878a8", 2: "#40a060", 3: "#a060c0"}
    markers = {1: "o", 4: "s", 16: "^"}
    for ax, scene in zip(axes.flat, scenes):
        combos = {}
        for r in rows:
            if r["scene"] == scene:
                c = combos.setdefault((r["level"], r["rate"]), [0.0, 0.0])
                c[0] = max(c[0], r["seconds"])
                c[1] = max(c[1], r["error_pct"])
        for (level, rate), (sec, err) in combos.items():
            ax.scatter(sec, max(err, 1e-3), c=colours[level], marker=markers.get(rate, "x"), s=40,
                       label=f"level {level}, 1/{rate}")
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(scene)
        ax.set_xlabel("seconds per design")
        ax.set_ylabel("worst error (%)")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=6, fontsize=8)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv=None) -> int:
    def extra(ap):
        ap.add_argument("--res", type=int, default=512, help="sampled replay: frame size (default 512)")
        ap.add_argument("--seeds", type=int, default=50)
        ap.add_argument("--ladder-res", type=int, default=128)
        ap.add_argument("--repeat", type=int, default=3)
        ap.add_argument("--scenes", default=",".join(SCENES))
        ap.add_argument("--parts", default="throughput,sampled,ladder")
        ap.add_argument("--methods", default="runs,tiles", help="sampled: runs (of trees), tiles (stratified)")
        ap.add_argument("--trace-dir", default=None, help="sampled: keep the frames' traces here and reuse them")
        ap.add_argument("--run-trees", type=int, default=None, help="sampled: trees per run (default 1024)")

    a, out = study_args(__file__, "speed against error: the fidelity ladder", "balls and tetra at size 1, 32x32",
                        argv, extra)
    quick = a.quick
    scenes = ("balls", "tetra") if quick else tuple(a.scenes.split(","))
    size = 1 if quick else None
    parts = "throughput,sampled,ladder" if quick else a.parts
    checks = {}
    if "throughput" in parts:
        res = 32 if quick else a.res
        _, tr = mprt.Scene.spd("balls", size).grid().trace(res, res, threads=a.threads)
        rows = throughput(tr, 1 if quick else a.repeat, quick)
        write_table(out, "throughput.csv", rows)
        checks["engines_agree_on_cycles"] = rows[3]["cycles"] == rows[4]["cycles"] == rows[5]["cycles"]
        checks["level0_at_most_a_few_percent_off"] = abs(rows[1]["cycles"] / rows[5]["cycles"] - 1) < 0.1
    if "sampled" in parts:
        rows, exact = [], True
        for sc in scenes:
            r, ok = sampled(sc, size, 32 if quick else a.res, (8,) if quick else (16, 8),
                            (1, 4) if quick else (4, 16), 5 if quick else a.seeds, a.threads,
                            tuple(a.methods.split(",")), a.trace_dir, a.run_trees)
            rows += r
            exact = exact and ok
        write_table(out, "sampled.csv", rows)
        checks["every_tile_sampled_gives_the_whole_replay"] = exact
    if "ladder" in parts:
        rows = []
        for sc in scenes:
            log(f"ladder: {sc}")
            rows += ladder(sc, size, 32 if quick else a.ladder_res, 8, (1, 4) if quick else RATES, a.threads,
                           quick)
        write_table(out, "ladder.csv", rows)
        write_table(out, "choice.csv", choices(rows, quick=quick))
        whole = [r for r in rows if r["rate"] == 1]
        checks["level3_whole_frame_is_the_truth"] = all(r["error_pct"] == 0 for r in whole if r["level"] == 3)
        checks["M_same_at_levels_1_to_3"] = all(r["error_pct"] == 0 for r in whole
                                                if r["config"] == "M" and r["level"] >= 1)
        if not quick:
            plot(rows, os.path.join(out, "speed_vs_error.png"))
    write_checks(os.path.join(out, "checks.csv"), checks)
    return 0


if __name__ == "__main__":
    sys.exit(main())
