"""The design space per SPD scene: best machines at three budgets beside the
paper's 3MPPE and models S and M; whether SC should keep its own processor;
how the best subdivision moves with the machine.

    .venv/bin/python studies/20_design_space/run.py [--res RES] [--out DIR] [--scenes a,b] [--quick]
Writes DIR/design_space.{csv,md} (default studies/out) and prints the Markdown.  The full run
explores, and runs the prepass, at level auto (1% tolerance: level 3 on every SPD scene);
--prepass-from CSV: only the prepass table, for the best designs of an earlier run's CSV
(DIR/prepass.md); --quick: tetra at SPD size 1, 32x32, one budget, level 1
and 300 global evaluations (the committed ref/; the full run's results are in ref/full/).
"""
import argparse
import csv
import sys
import time
from pathlib import Path

import mprt
from mprt.explore import model_m, model_s
from mprt.explore.explorer import FidelitySettings, SearchSettings, explore
from mprt.explore.workload import SceneEntry, Workload
from mprt.explore.prepass import prepass
from mprt.explore.space import DEFAULT_SPACE_TOML, parse_space

OUT = Path(__file__).resolve().parents[1] / "out"
BUDGETS = (400.0, 800.0, 1600.0)       # kGE


def mapping_space(mapping: str):
    text = DEFAULT_SPACE_TOML.replace(
        'mapping = { choices = ["OS|IC|SC", "OS+SC|IC", "OS|IC+SC", "OS+IC+SC"] }', f'mapping = "{mapping}"')
    return parse_space(text, f"<default space, mapping {mapping}>")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--prepass-from", type=Path, metavar="CSV",
                    help="only the prepass table, for the best designs in this earlier run's design_space.csv")
    ap.add_argument("--scenes", default=",".join(mprt.SPD_SCENES),
                    help="comma-separated SPD scenes (default: all six)")
    a = ap.parse_args(argv)
    names = [n.strip() for n in a.scenes.split(",") if n.strip()]
    bad = [n for n in names if n not in mprt.SPD_SCENES]
    if bad or not names:
        ap.error(f"--scenes: {', '.join(bad) or 'none given'}: not SPD scenes ({', '.join(mprt.SPD_SCENES)})")
    scenes = [("tetra", 1)] if a.quick else [(n, None) for n in names]
    budgets = BUDGETS[1:2] if a.quick else BUDGETS
    if a.prepass_from:
        rows = _read_rows(a.prepass_from)
        subs = [(n, _subdivisions(n, mprt.Scene.spd(n, s), rows, a.res, a.threads, "auto")) for n, s in scenes]
        md = ["| scene | model S | model M | 3MPPE | best design at 800 kGE | level |", "|---|---|---|---|---|---|"]
        md += [f"| {n} | " + " | ".join(v for k, v in sb.items() if k != "level") + f" | {sb['level']} |"
               for n, sb in subs]
        a.out.mkdir(parents=True, exist_ok=True)
        (a.out / "prepass.md").write_text("\n".join(md) + "\n")
        print("\n".join(md))
        return 0
    run(32 if a.quick else a.res, a.out, scenes, budgets, a.threads, 1 if a.quick else "auto",
        300 if a.quick else 1000)
    return 0


def run(res, out, scenes, budgets, threads, level, max_evals):
    out.mkdir(parents=True, exist_ok=True)
    rows, md = [], []
    md.append(f"Level {level}, {res}x{res} (search at {res // 2}x{res // 2}), built-in space, default unit costs.\n")
    md.append("| scene | budget kGE | best design | subdivision | cycles | cost | x 3MPPE | x M | x S |")
    md.append("|---|---|---|---|---|---|---|---|---|")
    sc_rows, sub_rows = [], []
    for name, size in scenes:
        scene = mprt.Scene.spd(name, size)
        for b in budgets:
            t0 = time.perf_counter()
            r = _explore(name, size, res, level, max_evals, b)
            best, (ps,), refs = r.best, r.per_scene, r.references
            row = {"scene": name, "budget": b, "mapping": best["design"]["mapping"], "pes": best["design"]["pes"],
                   "subdivision": "x".join(map(str, ps["subdivision"])), "cycles": ps["cycles"],
                   "cost": best["cost"], "evaluations": r.report["evaluations"]["machines"],
                   "described": best["described"], "design": best["design"]}
            for k in ("3mppe", "M", "S"):
                row[f"{k}_cycles"] = refs[k]["cycles"]
            rows.append(row)
            md.append(f"| {name} | {b:.0f} | {best['described']} | {row['subdivision']} | {ps['cycles']:.3g} "
                      f"| {best['cost']:.0f} | {refs['3mppe']['cycles'] / ps['cycles']:.2f} "
                      f"| {refs['M']['cycles'] / ps['cycles']:.2f} | {refs['S']['cycles'] / ps['cycles']:.2f} |")
            print(row, f"{time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
        # SC on its own processor or shared, at the middle budget
        per = {}
        for mapping in ("OS|IC|SC", "OS+SC|IC", "OS|IC+SC", "OS+IC+SC"):
            r = _explore(name, size, res, level, max_evals, BUDGETS[1], mapping_space(mapping))
            per[mapping] = r.per_scene[0]["cycles"]
        sc_rows.append((name, per))
        # the best subdivision per machine (prepass at this resolution)
        subs = _subdivisions(name, scene, rows, res, threads, level)
        subs.pop("level")
        sub_rows.append((name, subs))
        _write(out, md, rows, sc_rows, sub_rows, final=False)
    _write(out, md, rows, sc_rows, sub_rows)


def _explore(name, size, res, level, max_evals, budget, space=None):
    """One scene's explore (a workload of one) at res x res, searched at half of it."""
    entry = SceneEntry(f"{name}:{size}" if size else name, res=(res, res))
    return explore(Workload((entry,)), space, SearchSettings(budget=budget, max_evals=max_evals),
                   FidelitySettings(level=level, fraction=2))


def _write(out, md, rows, sc_rows, sub_rows, final=True):
    """The tables so far (after each scene, so a stopped run keeps what it finished)."""
    md = list(md)
    md.append(f"\nSC's processor, best design per stage mapping at {BUDGETS[1]:.0f} kGE (cycles; "
              "lower is better):\n")
    md.append("| scene | OS\\|IC\\|SC | OS+SC\\|IC | OS\\|IC+SC | OS+IC+SC (one processor type) | best |")
    md.append("|---|---|---|---|---|---|")
    for name, per in sc_rows:
        bestm = min(per, key=per.get).replace("|", "\\|")
        md.append(f"| {name} | " + " | ".join(f"{per[m]:.3g}" for m in per) + f" | {bestm} |")
    md.append("\nBest subdivision (prepass) per machine:\n")
    md.append("| scene | model S | model M | 3MPPE | best design at 800 kGE |")
    md.append("|---|---|---|---|---|")
    for name, subs in sub_rows:
        md.append(f"| {name} | " + " | ".join(subs.values()) + " |")
    with open(out / "design_space.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    text = "\n".join(md) + "\n"
    (out / "design_space.md").write_text(text)
    if final:
        print(text)


def _subdivisions(name, scene, rows, res, threads, level) -> dict:
    """The prepass's subdivision (at ``level``) for models S and M, the 3MPPE and the best design
    at the middle budget in ``rows``; "level": the levels the prepass used."""
    subs, levels = {}, []
    from mprt.machine import builtin
    for label, d in (("S", model_s()), ("M", model_m()), ("3MPPE", builtin("3mppe")),
                     ("best@800", _design(rows, name, BUDGETS[1]))):
        pre = prepass(scene, res, res, design=d, fraction=2, threads=threads, level=level)
        subs[label] = "x".join(map(str, pre["subdivision"]))
        levels.append(str(pre["level"]))
        print(name, label, subs[label], "level", pre["level"], file=sys.stderr, flush=True)
    subs["level"] = "/".join(levels)
    return subs


def _read_rows(path) -> list:
    import ast
    with open(path, newline="") as f:
        return [dict(r, budget=float(r["budget"]), design=ast.literal_eval(r["design"])) for r in csv.DictReader(f)]


def _design(rows, name, budget):
    from mprt.explore import Design
    return Design.from_dict(next(r for r in rows if r["scene"] == name and r["budget"] == budget)["design"])


if __name__ == "__main__":
    sys.exit(main())
