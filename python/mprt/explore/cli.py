"""The ``explore``, ``prepass`` and ``sweep`` subcommands.

``mprt/cli.py`` wires them with::

    from .explore import cli as explore_cli
    explore_cli.add_parsers(sub)        # after the other sub.add_parser calls

Each parser's ``func`` is its ``run_*`` function, which returns the exit status.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from .. import options as opt
from ..progress import Phases, clock_step, eta_text


def _positive(kind):
    def parse(text):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a {kind.__name__}") from None
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{text!r} must be positive")
        return v
    return parse


def _percent(text: str) -> float:
    t = text.strip()
    try:
        v = float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        raise argparse.ArgumentTypeError(f"tolerance must be like 1% or 0.01, not {text!r}") from None
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"tolerance {text!r} must be between 0 and 100%")
    return v


def _candidates(text: str):
    out = []
    for part in text.replace("/", ",").split(","):
        try:
            vals = tuple(int(v) for v in part.lower().split("x"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"candidate {part!r} is not N or NXxNYxNZ") from None
        if len(vals) not in (1, 3) or min(vals) < 1:
            raise argparse.ArgumentTypeError(f"candidate {part!r} is not N or NXxNYxNZ of positive integers")
        out.append(vals)
    return out


def _range(text: str):
    try:
        lo, hi = (int(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"range must be LO:HI, not {text!r}") from None
    if not 1 <= lo <= hi:
        raise argparse.ArgumentTypeError(f"range {text!r} must have 1 <= LO <= HI")
    return lo, hi


def _sample(text: str):
    if text in ("auto", "none"):
        return None if text == "none" else text
    from ..fidelity import Sampling
    from ..errors import InvalidArgument
    try:
        return str(Sampling.parse(text))
    except InvalidArgument as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def check_output(path) -> None:
    """Fail before any work if an output file cannot be written."""
    if path is None:
        return
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise OSError(f"{path}: directory {d} does not exist")
    if not os.access(d, os.W_OK):
        raise OSError(f"{path}: directory {d} is not writable")


def _common(p):
    opt.add_scene_argument(p)
    opt.add_res(p)
    opt.add_json(p)
    opt.add_threads(p)


def _tracing(p, grid_default: str, grid_extra: str) -> None:
    """--grid, --rules and --threshold as every command that traces has them (``mprt.options``)."""
    opt.add_grid(p, grid_default, grid_extra)
    opt.add_rules(p)
    opt.add_threshold(p)


def add_parsers(sub) -> None:
    from ..machine.config import BUILTIN
    from .search import GLOBAL_ALGORITHMS, OBJECTIVES, POLISHES, STARTS

    e = sub.add_parser("explore", help="search the design space for the fastest machine (and subdivision)",
                       description="Search a design space (--space, or the built-in one) with NLopt for the "
                                   "machine that renders SCENE fastest under a hardware budget.",
                       epilog=opt.EXIT_STATUS)
    _common(e)
    _tracing(e, "searched over the space's subdivision variables",
             "; fixes the subdivision: the space's subdivision variables are held at N per axis (or NX,NY,NZ) "
             "and only the machine is searched")
    e.add_argument("--space", metavar="FILE.toml", help="design space (default: the built-in space)")
    e.add_argument("--objective", choices=OBJECTIVES, default="time",
                   help="time: cycles (under --budget); time*cost; pareto: the front by a sweep of budgets "
                        "(default: time)")
    e.add_argument("--budget", type=_positive(float), default=None, metavar="KGE",
                   help="hardware budget in kGE; one below the space's cheapest design is refused before any "
                        "work (default: none)")
    opt.add_level(e, default="auto", default_text="auto",
                  extra="; the search and everything after it run at that level; auto measures the ladder on this "
                        "scene and takes the lowest within --tolerance")
    e.add_argument("--tolerance", type=_percent, default=0.01, metavar="P",
                   help="error the level may have against the most faithful one, with --level auto (default: 1%%)")
    e.add_argument("--sample", type=_sample, default="auto", metavar="SPEC",
                   help="trace only these tiles of the full-resolution frame for the final polish and scale up "
                        "(stratified:K:SEED, random:N:SEED, regular:K, or none) (default: auto, stratified:16:1 "
                        "above 256x256)")
    e.add_argument("--verify", type=_positive(int), default=4, metavar="K",
                   help="best designs of the low-resolution search re-evaluated at --res (with the best of each "
                        "stage mapping) before the full-resolution polish (default: 4)")
    e.add_argument("--algorithm", choices=[a for a in GLOBAL_ALGORITHMS if a != "none"], default="direct-l",
                   help="NLopt's global search (default: direct-l)")
    e.add_argument("--polish", choices=POLISHES, default="lattice",
                   help="the local search from the global phase's best: lattice steps or an NLopt local method "
                        "(default: lattice)")
    e.add_argument("--max-evals", type=_positive(int), default=1000, metavar="N",
                   help="most distinct designs in the global phase (default: 1000)")
    e.add_argument("--seed", type=int, default=1, help="seed of the randomised searches and of the ladder's "
                                                       "designs (default: 1)")
    e.add_argument("--starts", choices=STARTS, default="whole",
                   help="the global phase: one start over the whole space, or one per stage mapping (run in "
                        "parallel, each with a share of --max-evals) (default: whole)")
    e.add_argument("--workers", type=_nonnegative_int, default=None, metavar="N",
                   help="processes evaluating independent designs in parallel; the answer is the same for any "
                        "number (default: one per core; 0 or 1: in this process)")
    e.add_argument("--no-bound", dest="bound", action="store_false",
                   help="at levels 2 and 3, replay every design at the level (default: a design whose bound "
                        "is slower than the best so far, or that is over the budget, is not replayed: its level-1 "
                        "replay in the global phase, from the polish on its stages' work over their processors; "
                        "in the full-resolution polish, nor one whose estimate from the search's figures is)")
    e.add_argument("--fraction", type=_positive(int), default=None, metavar="F",
                   help="search on traces at 1/F of --res, then polish the best at --res "
                        "(default: about 64 pixels across; 1: search at --res)")
    e.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the search on this Dask scheduler (default: in this process)")
    e.add_argument("--plot", metavar="OUT.png", help="history, cost against cycles, utilisation (default: none)")
    e.add_argument("--report", metavar="OUT.html",
                   help="write one self-contained HTML page: the answer, the references, the ladder (speed "
                        "against error), the search's history, the plots and the command that reproduces it "
                        "(default: none)")
    e.set_defaults(func=run_explore)

    p = sub.add_parser("prepass", help="choose the voxel subdivision from low-resolution traces",
                       description="Trace SCENE at a fraction of --res over candidate subdivisions (searched over "
                                   "--range, or the --candidates given), predict each one's full-resolution "
                                   "cycles on the machine named (default: the paper's 3MPPE) at the level the "
                                   "fidelity ladder trusts for it, and print the best.",
                       epilog=opt.EXIT_STATUS)
    _common(p)
    _tracing(p, "searched over --range, or the --candidates",
             "; the only candidate: its full-resolution cycles are predicted as any other's (not with "
             "--candidates or --range)")
    p.add_argument("--model", choices=tuple(BUILTIN), default=None,
                   help="built-in machine to choose the subdivision for (default: 3mppe)")
    p.add_argument("--config", metavar="FILE.toml", default=None,
                   help="machine configuration file (default: none, the --model)")
    opt.add_level(p, default="auto", default_text="auto",
                  extra="; of the candidates' replays: auto measures the ladder for the machine on the middle "
                        "candidate's trace and takes the lowest within --tolerance")
    p.add_argument("--tolerance", type=_percent, default=0.01, metavar="P",
                   help="error the level may have against the machine's own level, with --level auto "
                        "(default: 1%%)")
    p.add_argument("--candidates", type=_candidates, default=None, metavar="N,...|NXxNYxNZ,...",
                   help="subdivisions to try, e.g. 20,50,100 or 20,50,100/8x8x2 (default: searched)")
    p.add_argument("--range", type=_range, default=None, dest="n_range", metavar="LO:HI",
                   help="voxels along the longest axis to search, LO:HI (default: 1 to 32 times the cube root "
                        "of the primitive count)")
    p.add_argument("--shape", choices=("proportional", "cube"), default="proportional",
                   help="one n as n along the longest axis, others in proportion, or n per axis "
                        "(default: proportional)")
    p.add_argument("--fraction", type=_positive(int), default=16, metavar="F",
                   help="trace at 1/F of --res, at least 32 pixels per axis (the whole frame where smaller) "
                        "(default: 16)")
    p.add_argument("--verify", "--check", type=_nonnegative_int, default=0, metavar="K", dest="check",
                   help="trace the K best predictions at --res on about 16 of its 16x16 tiles (stratified; a "
                        "sixty-fourth of 512x512) and choose among them by that (default: 0, the "
                        "low-resolution prediction alone; --check K is the old spelling)")
    p.add_argument("--refine", choices=("golden", "parabola", "none"), default="golden",
                   help="narrow the ladder's bracket by golden-section steps, by one parabola step (half the "
                        "candidates, less exact where time is jagged in n), or not at all (default: golden)")
    p.set_defaults(func=run_prepass)

    from .sweep import __doc__ as sweep_doc
    w = sub.add_parser("sweep", help="scenes x subdivisions x designs on Dask, to a CSV and plots",
                       description="Replay every design of SPEC.toml on every scene at every subdivision, on Dask "
                                   "(a local cluster, or --scheduler), to DIR/sweep.csv and DIR/sweep.png; tasks "
                                   "already in DIR's cache are not run again.",
                       epilog=sweep_doc.split("\n\n", 1)[1].split("\nwrites")[0].strip("\n").replace(
                           "The spec file::", "the spec file (TOML):") + "\n\n" + opt.EXIT_STATUS,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    w.add_argument("spec", metavar="SPEC.toml", help="the sweep: scenes, res, subdivisions, designs (below)")
    w.add_argument("--out", required=True, metavar="DIR",
                   help="directory for sweep.csv, sweep.png and the cache, made if missing (required)")
    w.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler (default: a LocalCluster)")
    w.add_argument("--report", metavar="OUT.html",
                   help="also write one self-contained HTML page: the rows, the plot and the command "
                        "(default: none)")
    w.add_argument("--workers", type=_nonnegative_int, default=None, metavar="N",
                   help="LocalCluster worker processes (default: one per core; 0: run in this process)")
    w.set_defaults(func=run_sweep)


def sweep_progress(stream=None, clock=time.perf_counter):
    """The sweep's progress: "done/total tasks" with the time left (from the mean time of the
    tasks done so far), on one line rewritten on a terminal, else a line at each tenth."""
    stream = stream or sys.stderr
    tty = stream.isatty()
    state = {"start": None, "shown": -1, "open": False}

    def tick(done: int, total: int):
        if state["start"] is None:
            state["start"] = clock()
            if total == 0:
                print("  every task is in the cache", file=stream, flush=True)
                return
        if total == 0:
            return
        spent = clock() - state["start"]
        left = f", about {spent / done * (total - done):.0f} s left" if 0 < done < total else ""
        text = f"  {done}/{total} tasks done, {spent:.0f} s{left}"
        if tty:
            print("\r" + text + " " * 8, end="", file=stream, flush=True)
            state["open"] = True
        elif done == total or done * 10 // total != state["shown"]:
            state["shown"] = done * 10 // total
            print(text, file=stream, flush=True)

    def end():
        if state["open"]:
            print(file=stream, flush=True)
            state["open"] = False

    tick.end = end
    return tick


def _nonnegative_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be 0 or more")
    return v


def _progress_printer(every: int = 25, total: int | None = None, stream=None):
    """The search's progress: evaluations (of up to ``total`` in the global phase), the best so
    far, the time spent since the printer was made (the exploration's start) and the time left
    at that rate; one line rewritten on a terminal, else a line every ``every`` evaluations.
    (The global phase and the mappings' walks report their evaluations when they end, in a
    burst: timing from the first report made the rate of the first burst meaningless.)"""
    stream = stream or sys.stderr
    tty = stream.isatty()
    start = [time.perf_counter()]
    open_line = [False]

    def show(problem):
        n = len(problem.memo)
        if n % every and not tty:
            return
        b = problem.best()
        spent = time.perf_counter() - start[0]
        left = (f", {eta_text(spent / n * (total - n))} left" if total and 0 < n < total and spent > 0
                else ", polishing" if total and n > total else "")
        of = f" of up to {total}" if total and n <= total else ""
        msg = (f"\r  {n:5d} evaluations{of}, best {b.cycles:,.0f} cycles at cost "
               f"{b.cost:.0f} kGE, {spent:.1f} s{left}")
        print(msg if tty else msg[1:], end="" if tty else "\n", file=stream, flush=True)
        open_line[0] = tty

    def end():
        if open_line[0]:
            print(file=stream)
        open_line[0] = False

    def line(text):
        end()
        print(text, file=stream, flush=True)

    show.end, show.line = end, line
    return show


def run_explore(a) -> int:
    from .explorer import explore, plot
    from .space import SpaceError, default_space, load_space

    opt.check_outputs(("--json", a.json, "json"), ("--plot", a.plot, "png"), ("--report", a.report, "html"))
    try:
        space = load_space(a.space) if a.space else default_space()
    except SpaceError as e:
        raise opt.UsageError(str(e)) from None
    check_budget(space, a.budget, a.objective)
    opt.check_render_options(a)
    scene = opt.load_scene(a.scene, skip_unknown=a.skip_unknown)[0]
    w, h = a.res or scene.info()["resolution"]
    kw = dict(width=w, height=h, space=space, objective=a.objective, budget=a.budget,
              level=a.level if a.level == "auto" else int(a.level), tolerance=a.tolerance, algorithm=a.algorithm,
              polish=a.polish, max_evals=a.max_evals, seed=a.seed, threads=a.threads, fraction=a.fraction,
              sample=a.sample, verify=a.verify, starts=a.starts, rules=a.rules, threshold=a.threshold, grid=a.grid,
              bound=a.bound)
    if a.workers is not None and a.workers < 0:
        raise opt.UsageError(f"--workers {a.workers}: give 0 or more processes")
    if not a.scheduler:     # before any work: the frames the processes hold must fit
        from .memory import check_explore
        from .parallel import default_workers
        check_explore(scene, w, h, space, a.grid, a.fraction, a.sample,
                      default_workers() if a.workers is None else a.workers)
    print(f"explore {scene.name} at {w}x{h}: "
          + ("measure the fidelity ladder on a low-resolution trace, " if a.level == "auto" else "")
          + f"search up to {a.max_evals} designs ({a.algorithm}, then {a.polish}) at the level chosen, "
            f"re-evaluate the best {a.verify} at {w}x{h} and polish them"
          + (f" (subdivision fixed at {_dims_text(a.grid)})" if a.grid is not None else "")
          + (f", on the Dask scheduler {a.scheduler}" if a.scheduler else "")
          + "; each phase reports its progress and time", flush=True)
    if a.scheduler:
        from .distributed import run_remote
        with clock_step(f"remote  the search on the Dask scheduler {a.scheduler} (one task; its phases run there)"):
            rep = run_remote(a.scheduler, explore_spec, a.scene, kw)
    else:
        show = _progress_printer(total=a.max_evals)
        rep = explore(scene, progress=show, log=show.line, workers=a.workers, phases=Phases(0), **kw)
        show.end()
    mark_feasible(rep)
    print_report(rep)
    if a.json:
        opt.write_json(a.json, rep, indent=1)
        print(f"wrote   {a.json}")
    if a.plot:
        plot(rep, a.plot)
        print(f"wrote   {a.plot}")
    if a.report:
        import tempfile

        from .. import report
        with tempfile.TemporaryDirectory() as d:
            png = a.plot or os.path.join(d, "explore.png")
            if not a.plot:
                plot(rep, png)
            report.write(a.report, report.explore_html(rep, getattr(a, "argv", None), png))
        print(f"wrote   {a.report}")
    if not rep["feasible"]:
        print(f"mprt explore: error: the search found no design within the budget of {rep['budget']:g} kGE "
              f"(its best costs {rep['best']['cost']:.0f} kGE); raise --budget or --max-evals", file=sys.stderr)
        return 1
    return 0


def _dims_text(grid) -> str:
    return "x".join(map(str, (grid,) * 3 if isinstance(grid, int) else grid))


def check_budget(space, budget, objective) -> None:
    """Before any work: a budget below the cheapest design of the space is refused (UsageError,
    exit 2), naming that design's cost."""
    from .hwcost import UnitCosts, cheapest_design

    if budget is None or objective == "pareto":
        return
    cost, design = cheapest_design(space, UnitCosts.from_table(space.cost))
    if cost > budget:
        raise opt.UsageError(f"--budget {budget:g} kGE: no design in the space meets it; the cheapest costs "
                             f"{cost:.1f} kGE ({design.describe()})")


def mark_feasible(rep: dict) -> None:
    """The report says whether its best meets the budget: ``feasible`` at the top and in ``best``
    (always true without a budget)."""
    budget = rep.get("budget")
    ok = budget is None or rep["objective"] == "pareto" or rep["best"]["cost"] <= budget * (1 + 1e-12)
    rep["feasible"] = rep["best"]["feasible"] = bool(ok)


def explore_spec(scene_spec, kw):
    """Runs on a Dask worker: load the scene there and explore (in that process: a Dask
    worker is a daemon process and may not start a pool)."""
    from .explorer import explore
    return explore(opt.load_scene(scene_spec)[0], workers=1, **kw)


def print_report(rep: dict) -> None:
    b = rep["best"]
    refs = rep["references"]
    print(f"explore {rep['scene']} at {rep['width']}x{rep['height']}, objective {rep['objective']}"
          + (f", budget {rep['budget']:g} kGE" if rep.get("budget") else "")
          + f": {rep['evaluations']} designs evaluated in {rep['seconds']:.1f} s")
    lv = rep["level"]
    print(f"level   {lv['search']}: search, full-resolution polish and references"
          + (f" (the ladder's choice within {100 * rep['tolerance']:g}%)" if lv["asked"] == "auto" else ""))
    print(f"best    {b['described']}" + ("" if rep.get("feasible", True) else "  (OVER THE BUDGET)"))
    over_s = "model S deadlocks" if b["speedup_over_S"] is None else f"{b['speedup_over_S']:.2f}x model S"
    print(f"        subdivision {'x'.join(map(str, b['subdivision']))}; {b['cycles']:,.0f} cycles; "
          f"cost {b['cost']:.0f} kGE; {over_s}; bottleneck {b['bottleneck']}")
    print("        utilisation " + ", ".join(f"{k} {v:.0%}" for k, v in b["utilisation"].items()))
    for name, title in (("3mppe", "paper 3MPPE"), ("M", "model M"), ("S", "model S")):
        r = refs[name]
        if r["cycles"] is None:
            held = "FIFOs and ring" if lv["verify"] >= 2 else "FIFOs"
            print(f"        {title:12s} {'deadlocks':>14s}        cost {r['cost']:5.0f} kGE (at level {lv['verify']}, "
                  f"even with one ray tree in flight: its {held} cannot hold this scene's largest ray tree)")
            continue
        print(f"        {title:12s} {r['cycles']:14,.0f} cycles, cost {r['cost']:5.0f} kGE, "
              + ", ".join(f"{k} {v:.0%}" for k, v in r["utilisation"].items()))
    if "front" in rep:
        print(f"front   {len(rep['front'])} designs:")
        for f in rep["front"]:
            print(f"        {f['cost']:7.0f} kGE {f['cycles']:14,.0f} cycles  {f['design']['mapping']}, "
                  f"{f['design']['pes']} PE(s), subdivision {'x'.join(map(str, f['subdivision']))}")


def run_prepass(a) -> int:
    from .prepass import prepass

    opt.check_outputs(("--json", a.json, "json"))
    opt.check_render_options(a)
    candidates = a.candidates
    if a.grid is not None:
        if a.candidates or a.n_range:
            raise opt.UsageError(f"--grid fixes the one subdivision to predict; leave out "
                                 f"{'--candidates' if a.candidates else '--range'} (or --grid, to search)")
        candidates = [(a.grid,) * 3 if isinstance(a.grid, int) else tuple(a.grid)]
    scene = opt.load_scene(a.scene, skip_unknown=a.skip_unknown)[0]
    w, h = a.res or scene.info()["resolution"]
    from ..machine.config import resolve
    machine = resolve(a.model or (None if a.config else "3mppe"), a.config, None)
    r = prepass(scene, w, h, candidates=candidates, n_range=a.n_range, fraction=a.fraction, shape=a.shape,
                threads=a.threads, check=a.check, refine=a.refine, design=machine,
                level=a.level if a.level == "auto" else int(a.level), tolerance=a.tolerance, rules=a.rules,
                threshold=a.threshold)
    lw, lh = r["low_resolution"]
    print(f"prepass {scene.name}: {len(r['candidates'])} subdivisions traced at {lw}x{lh} in {r['seconds']:.2f} s; "
          f"cycles predicted for {w}x{h} on {r['machine']} at level {r['level']}"
          + (f" (the ladder's choice within {100 * a.tolerance:g}%)" if a.level == "auto" else "")
          + (f"; the best {a.check} checked on {r['check_sample']} at {w}x{h}" if r["check_sample"] else ""))
    best = r["subdivision"]
    for c in r["candidates"]:
        mark = "  <- best" if c["subdivision"] == best else ""
        checked = "" if "sampled_cycles" not in c else (f" {'deadlocks':>16s} sampled" if c["sampled_deadlock"]
                                                        else f" {c['sampled_cycles']:16,.0f} sampled")
        pred = f"{'deadlocks':>16s}" if c["deadlock"] else f"{c['predicted_cycles']:16,.0f}"
        print(f"  {'x'.join(map(str, c['subdivision'])):>12s} {pred}{checked}{mark}")
    print(f"best    subdivision {'x'.join(map(str, best))}")
    if a.json:
        opt.write_json(a.json, r, indent=1)
        print(f"wrote   {a.json}")
    return 0


def run_sweep(a) -> int:
    from .space import SpaceError
    from .sweep import load_spec, run_sweep as sweep

    try:
        spec = load_spec(a.spec)
    except SpaceError as e:
        raise opt.UsageError(str(e)) from None
    if a.report:
        opt.check_outputs(("--report", a.report, "html"))
    check_output(os.path.join(a.out, "x"))  if os.path.isdir(a.out) else check_output(a.out)
    print(f"sweep   {len(spec['scenes'])} scene(s) x {len(spec['subdivisions'])} subdivision(s) x "
          f"{len(spec['designs'])} design(s) at {spec['width']}x{spec['height']}, level {spec['level']}, on "
          f"{'the Dask scheduler ' + a.scheduler if a.scheduler else 'a local Dask cluster'}; progress with an "
          "estimate of the time left below", flush=True)
    if not a.scheduler:     # before any work: every worker holds a traced frame
        from .memory import check_sweep
        check_sweep(spec, a.workers)
    tick = sweep_progress()
    r = sweep(spec, a.out, scheduler=a.scheduler, workers=a.workers, progress=tick)
    tick.end()
    print(f"sweep   {r['rows']} rows from {r['tasks']} tasks ({r['cached']} from the cache) in {r['seconds']:.1f} s")
    print(f"wrote   {r['csv']}\nwrote   {r['png']}")
    if a.report:
        from .. import report
        report.write(a.report, report.sweep_html(r, getattr(a, "argv", None)))
        print(f"wrote   {a.report}")
    return 0
