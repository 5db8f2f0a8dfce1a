"""Which NLopt algorithm and which polish: measured against exhaustive enumeration.

On the small space tests/data/explore/small_space.toml and the level-1 (or --level N)
objective of the golden traces (grid 9), every (global algorithm, polish)
pair searches with a fixed budget of distinct evaluations for the global
phase; the polish runs to its local optimum.  Printed per pair: how often the
optimum found equals exhaustive enumeration's (over scenes x objectives x
seeds) and the mean number of distinct designs evaluated.

    .venv/bin/python studies/20_design_space/search_methods.py [--level N] [GLOBAL_EVALS ...]

Then the same methods on the built-in space, where only the best of all runs
is known.
"""
import sys
from pathlib import Path

import mprt
from mprt.explore import load_space
from mprt.explore.evaluate import TraceEvaluator
from mprt.explore.search import Problem, exhaustive, search

ROOT = Path(__file__).resolve().parents[2]
SCENES = ["balls", "gears", "mount", "rings", "tetra", "tree"]
OBJECTIVES = [("time", 300.0), ("time", 500.0), ("time*cost", None), ("time", None)]
GLOBALS = ["direct-l", "crs2", "isres", "esch", "random"]
POLISHES = ["lattice", "sbplx", "neldermead", "none"]
SEEDS = [1, 2, 3]


LEVEL = 1          # the compiled replay; --level N for another (the explorer's level on SPD scenes is 3)

def main(budgets):
    space = load_space(ROOT / "tests/data/explore/small_space.toml")
    cases = []
    for name in SCENES:
        ev = TraceEvaluator(mprt.load_trace(ROOT / f"tests/data/golden/{name}-g9.npz"))
        f = _memo(lambda d, ev=ev: ev.run(d, LEVEL))
        for obj, budget in OBJECTIVES:
            ex = exhaustive(Problem(space, f, obj, budget))
            cases.append((f, obj, budget, ex))
    print(f"space: {space.count()} index vectors, {cases[0][3].evaluations} distinct designs; "
          f"{len(cases)} cases (6 scenes x 4 objectives) x {len(SEEDS)} seeds")
    print(f"{'global evals':>12} {'global':>14} {'polish':>11} {'optimum found':>14} {'mean evals':>11}")
    for g in budgets:
        for alg in GLOBALS:
            for pol in POLISHES:
                hit = runs = evals = 0
                for f, obj, budget, ex in cases:
                    for seed in SEEDS:
                        p = Problem(space, f, obj, budget)
                        r = search(p, alg, pol, max_evals=g, seed=seed, polish_evals=1000)
                        hit += p.f(r.best) <= p.f(ex.best) + 1e-12
                        runs += 1
                        evals += r.evaluations
                print(f"{g:12d} {alg:>14} {pol:>11} {hit:>8}/{runs:<5} {evals / runs:11.1f}")


def _memo(run):
    """Each design replayed once per case: the runs of every method ask for the same designs."""
    seen = {}

    def f(pts):
        return [seen[p.design] if p.design in seen else seen.setdefault(p.design, run(p.design)) for p in pts]
    return f


def large(evals=(100, 300), scenes=("balls", "mount", "tree"), res=32, budget=800.0):
    """On the built-in space (about 10^8 designs) no enumeration: each method's
    best against the best any run found, per scene, budget 800 kGE."""
    from mprt.explore import default_space
    from mprt.explore.evaluate import SceneEvaluator

    space = default_space()
    print(f"\nbuilt-in space, {res}x{res}, budget {budget:g} kGE: best cycles over the best of all runs "
          f"(1.000 = found it), mean of {len(SEEDS)} seeds; distinct designs evaluated")
    print(f"{'scene':>6} {'evals':>5} " + " ".join(f"{a + '+' + p:>22}" for a in GLOBALS for p in ("lattice",)))
    for name in scenes:
        ev = SceneEvaluator(mprt.Scene.spd(name), res, res, level=LEVEL, shape=space.shape)
        for g in evals:
            runs = {}
            for alg in GLOBALS:
                out = []
                for seed in SEEDS:
                    p = Problem(space, ev, "time", budget)
                    r = search(p, alg, "lattice", max_evals=g, seed=seed)
                    out.append((r.best.cycles, r.evaluations))
                runs[alg] = out
            top = min(c for out in runs.values() for c, _ in out)
            print(f"{name:>6} {g:5d} " + " ".join(
                f"{sum(c for c, _ in out) / len(out) / top:12.3f} ({sum(n for _, n in out) / len(out):5.0f})"
                for out in runs.values()), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    if args[:1] == ["--level"]:
        LEVEL, args = int(args[1]), args[2:]
    main([int(a) for a in args] or [20, 40, 80])
    large()
