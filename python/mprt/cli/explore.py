"""The ``explore``, ``prepass`` and ``sweep`` subcommands.

``mprt.cli.build_parser`` wires them with::

    from .explore import add_parsers
    add_parsers(sub)        # after the other sub.add_parser calls

Each parser's ``func`` is its ``run_*`` function, which returns the exit status.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from . import options as opt
from .progress import Phases, eta_text
from .sweep import _nonnegative_int, add_parser as add_sweep_parser
from .sweep import check_output, run_sweep, sweep_progress  # noqa: F401 (mprt.explore.cli's names, kept)


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
    from ..explore.result import OBJECTIVES
    from ..explore.search import GLOBAL_ALGORITHMS, POLISHES
    e = sub.add_parser("explore", help="one machine for a workload of scenes, and each scene's subdivision",
                       description="Search a design space (--space, or the built-in one) for the one machine that "
                                   "runs a workload of scenes best under a hardware budget; the subdivision is "
                                   "chosen per scene (software), every other variable is one for the workload "
                                   "(hardware).  Give the scenes by name (SCENE ...: weight 1 each, the options "
                                   "below) or in a workload file (--workload).",
                       epilog=opt.EXIT_STATUS)
    e.add_argument("scene", metavar="SCENE", nargs="*",
                   help="scenes of the workload: SPD names (balls, balls:2) or NFF paths; or --workload")
    opt.add_skip_unknown(e)
    e.add_argument("--workload", metavar="FILE.toml",
                   help="the workload: [[scene]] tables with name, and optionally weight, res, rules, threshold, "
                        "skip_unknown, max_rays, max_depth (the options below are the defaults of what a scene "
                        "leaves out) (default: the SCENEs given)")
    opt.add_res(e)
    opt.add_json(e)
    opt.add_threads(e)
    _tracing(e, "chosen per scene, nx, ny and nz each free (up to 512)",
             "; fixes every scene's subdivision: only the machine is searched")
    opt.add_trace_limits(e)
    e.add_argument("--space", metavar="FILE.toml", help="design space (default: the built-in space)")
    e.add_argument("--machine", metavar="FILE.toml",
                   help="a fixed machine (a machine file, as --machine-out writes and simulate --config reads): "
                        "only each scene's subdivision is chosen (default: search the space)")
    e.add_argument("--machine-out", metavar="FILE.toml",
                   help="write the answer as a machine file for simulate --config and prepass --config "
                        "(default: none)")
    e.add_argument("--objective", choices=OBJECTIVES, default="geomean",
                   help="geomean: the weighted geometric mean of the speed-ups over the paper's 3MPPE; total: the "
                        "weighted total cycles; worst: the worst scene's speed-up; pareto: the front of the "
                        "geometric mean against cost (default: geomean)")
    e.add_argument("--budget", type=_positive(float), default=None, metavar="KGE",
                   help="hardware budget in kGE; one below the space's cheapest design is refused before any "
                        "work (default: none)")
    opt.add_level(e, default="auto", default_text="auto",
                  extra="; the search and everything after it run at that level; auto measures the ladder on each "
                        "scene and takes the highest of the scenes' lowest levels within --tolerance")
    e.add_argument("--tolerance", type=_percent, default=0.01, metavar="P",
                   help="error the level may have against the most faithful one, with --level auto (default: 1%%)")
    e.add_argument("--verify", type=_positive(int), default=4, metavar="K",
                   help="best machines of the low-resolution search re-evaluated on every scene's full frame "
                        "(default: 4)")
    e.add_argument("--algorithm", choices=[a for a in GLOBAL_ALGORITHMS if a != "none"], default="direct-l",
                   help="NLopt's global search (default: direct-l)")
    e.add_argument("--polish", choices=POLISHES, default="lattice",
                   help="the local search from the global phase's best: lattice steps or an NLopt local method "
                        "(default: lattice)")
    e.add_argument("--max-evals", type=_positive(int), default=1000, metavar="N",
                   help="most distinct machines in the global phase (default: 1000)")
    e.add_argument("--exhaustive", type=_nonnegative_int, default=200, metavar="N",
                   help="a space of at most N machines is searched by evaluating every one (default: 200)")
    e.add_argument("--seed", type=int, default=1, help="seed of the randomised searches and of the ladder's "
                                                       "designs (default: 1)")
    e.add_argument("--workers", type=_nonnegative_int, default=None, metavar="N",
                   help="local processes evaluating scenes and designs in parallel; the answer is the same for "
                        "any number (default: one per core; 0 or 1: in this process)")
    e.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the evaluations as tasks on this Dask scheduler's workers (default: local)")
    e.add_argument("--cache", metavar="DIR",
                   help="keep every evaluation in DIR: a killed exploration run again resumes (default: none)")
    e.add_argument("--no-bound", dest="bound", action="store_false",
                   help="at levels 2 and 3, replay every design at the level (default: a design whose level-1 "
                        "bound is slower than the best so far, or that is over the budget, is not replayed)")
    e.add_argument("--fraction", type=_positive(int), default=None, metavar="F",
                   help="search on traces at 1/F of each scene's frame, then check at full resolution "
                        "(default: about 64 pixels across; 1: search at full resolution)")
    e.add_argument("--plot", metavar="OUT.png", help="history, cost against the objective, per-scene speed-ups "
                                                    "(default: none)")
    e.add_argument("--report", metavar="OUT.html",
                   help="write one self-contained HTML page: the answer, its per-scene table, the references, "
                        "the ladder, the search's history, the plots and the command (default: none)")
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
    opt.add_trace_limits(p)
    p.add_argument("--no-axes", dest="axes", action="store_false",
                   help="stop at the best of the rule's line (n along the longest axis, the others in "
                        "proportion) (default: then each axis on its own, x or / 1.25 a step, while the time falls)")
    p.add_argument("--refine", choices=("golden", "parabola", "none"), default="golden",
                   help="narrow the ladder's bracket by golden-section steps, by one parabola step (half the "
                        "candidates, less exact where time is jagged in n), or not at all (default: golden)")
    p.set_defaults(func=run_prepass)
    add_sweep_parser(sub)



def _progress_printer(every: int = 25, total: int | None = None, stream=None):
    """The search's progress as it happens: machines evaluated (of up to ``total`` in the global
    phase), the best figure so far, the time spent since the printer was made and the time left at
    that rate; one line rewritten on a terminal, else a line every ``every`` machines."""
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
        msg = f"\r  {n:5d} machines{of}, best {b.cost:.0f} kGE, {spent:.1f} s{left}"
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


def load_workload_arg(a):
    """The workload of the command line: --workload FILE or the SCENEs (not both), the options
    the defaults of what each scene leaves out."""
    from ..explore.workload import WorkloadError, load_workload, workload_of

    if a.workload and a.scene:
        raise opt.UsageError("give the scenes or --workload FILE.toml, not both")
    if not a.workload and not a.scene:
        raise opt.UsageError("give one or more SCENEs (SPD names or NFF paths) or --workload FILE.toml")
    try:
        wl = load_workload(a.workload) if a.workload else workload_of(a.scene)
    except WorkloadError as e:
        raise opt.UsageError(str(e)) from None
    return wl.with_defaults(res=a.res, rules=a.rules, threshold=a.threshold, skip_unknown=a.skip_unknown,
                            max_rays=a.max_rays, max_depth=a.max_depth)


def run_explore(a) -> int:
    from ..machine.config import load_config
    from ..machine.errors import ConfigError
    from ..explore.explorer import FidelitySettings, Resources, SearchSettings, explore
    from ..explore.plots import plot
    from ..explore.space import SpaceError, default_space, load_space

    opt.check_outputs(("--json", a.json, "json"), ("--plot", a.plot, "png"), ("--report", a.report, "html"),
                      ("--machine-out", a.machine_out, "toml"))
    try:
        space = load_space(a.space) if a.space else default_space()
    except SpaceError as e:
        raise opt.UsageError(str(e)) from None
    check_budget(space, a.budget, a.objective)
    opt.check_render_options(a)
    wl = load_workload_arg(a)
    machine = None
    if a.machine:
        try:
            machine = load_config(a.machine)
        except ConfigError as e:
            raise opt.UsageError(str(e)) from None
        if a.space:
            raise opt.UsageError("--machine fixes the machine: leave out --space (nothing is searched)")
    if a.workers is not None and a.workers < 0:
        raise opt.UsageError(f"--workers {a.workers}: give 0 or more processes")
    grid = None if a.grid is None else ((a.grid,) * 3 if isinstance(a.grid, int) else tuple(a.grid))
    from ..explore.runner import default_workers
    workers = default_workers() if a.workers is None else a.workers
    if not a.scheduler:     # before any work: the largest whole frame, in every process that may hold it
        from ..explore.memory import check_workload
        check_workload(wl, workers, grid)
    names = ", ".join(e.name for e in wl)
    print(f"explore {len(wl)} scene(s) ({names}), objective {a.objective}"
          + (f", budget {a.budget:g} kGE" if a.budget else "")
          + (f": the machine of {a.machine} fixed, each scene's subdivision chosen" if machine is not None else
             f": {'the ladder picks the level, ' if a.level == 'auto' else ''}each scene's subdivision, then up to "
             f"{a.max_evals} machines ({a.algorithm}, then {a.polish}) at low resolution, the best {a.verify} on "
             f"the full frames")
          + (f" (subdivision fixed at {_dims_text(grid)})" if grid is not None else "")
          + (f", evaluations on the Dask scheduler {a.scheduler}" if a.scheduler else "")
          + (f", cache {a.cache}" if a.cache else "") + "; each step is reported as it ends", flush=True)
    show = _progress_printer()       # (no "time left": how many machines DIRECT-L takes is not known ahead)
    search = SearchSettings(objective=a.objective, budget=a.budget, algorithm=a.algorithm, polish=a.polish,
                            max_evals=a.max_evals, seed=a.seed, verify=a.verify, exhaustive=a.exhaustive,
                            bound=a.bound)
    fidelity = FidelitySettings(level=a.level if a.level == "auto" else int(a.level), tolerance=a.tolerance,
                                fraction=a.fraction)
    if a.scheduler:
        from ..explore.distributed import client
        with client(a.scheduler) as c:
            res = explore(wl, space, search, fidelity, Resources(workers=1, client=c, cache=a.cache),
                          machine=machine, grid=grid, say=show.line, progress=show, phases=Phases(0))
    else:
        res = explore(wl, space, search, fidelity, Resources(workers=workers, cache=a.cache), machine=machine,
                      grid=grid, say=show.line, progress=show, phases=Phases(0))
    show.end()
    rep = res.to_json()
    rep["settings"]["command"] = getattr(a, "argv", None)
    print_report(rep)
    if a.json:
        opt.write_json(a.json, rep, indent=1)
        print(f"wrote   {a.json}")
    if a.machine_out:
        from ..util.atomic import open_replacing
        with open_replacing(a.machine_out, "w") as f:
            f.write(res.machine_toml())
        stem, ext = os.path.splitext(a.machine_out)
        for k, row in enumerate(rep["per_scene"] if res.scene_machines else []):   # (software per scene)
            path = f"{stem}.{k + 1}{ext}"
            with open_replacing(path, "w") as f:
                f.write(res.machine_toml(k))
            print(f"wrote   {path} ({row['scene']} with its software: {row['software']})")
        print(f"wrote   {a.machine_out} (mprt simulate SCENE --config {a.machine_out} --grid NX,NY,NZ --res WxH "
              f"--level {rep['per_scene'][0]['level']} gives each row's cycles)")
    if a.plot:
        plot(rep, a.plot)
        print(f"wrote   {a.plot}")
    if a.report:
        import tempfile

        from . import report
        with tempfile.TemporaryDirectory() as d:
            png = a.plot or os.path.join(d, "explore.png")
            if not a.plot:
                plot(rep, png)
            report.write(a.report, report.explore_html(rep, getattr(a, "argv", None), png))
        print(f"wrote   {a.report}")
    if not rep["best"]["feasible"]:
        print(f"mprt explore: error: the search found no machine within the budget of {rep['budget']:g} kGE "
              f"(its best costs {rep['best']['cost']:.0f} kGE); raise --budget or --max-evals", file=sys.stderr)
        return 1
    return 0


def _dims_text(grid) -> str:
    return "x".join(map(str, (grid,) * 3 if isinstance(grid, int) else grid))


def check_budget(space, budget, objective) -> None:
    """Before any work: a budget below the cheapest design of the space is refused (UsageError,
    exit 2), naming that design's cost."""
    from ..explore.hwcost import UnitCosts, cheapest_design

    if budget is None or objective == "pareto":
        return
    cost, design = cheapest_design(space, UnitCosts.from_table(space.cost))
    if cost > budget:
        raise opt.UsageError(f"--budget {budget:g} kGE: no design in the space meets it; the cheapest costs "
                             f"{cost:.1f} kGE ({design.describe()})")


def _x(v) -> str:
    return "-" if v is None else f"{v:.2f}x"


def print_report(rep: dict) -> None:
    """The answer for people: the machine (a table of its processors and what each part costs), the
    per-scene table and the references; every line is explained in the explorer's README."""
    b = rep["best"]
    lv = rep["level"]
    ev = rep["evaluations"]
    print(f"answer  {b['described']}" + ("" if b["feasible"] else "  (OVER THE BUDGET)"))
    print(f"        cost {b['cost']:,.0f} kGE: " + ", ".join(f"{k} {v:,.0f}" for k, v in b["cost_breakdown"].items()
                                                            if v))
    pes = b["machine"]["pes"]
    print(f"        {sum(r['processors'] for r in b['processors'])} processors in {pes} PE(s):")
    for r in b["processors"]:
        units = " + ".join(f"{n} {k}" for k, n in r["units"].items())
        fifo = "" if r["send_fifo"] is None else f", FIFOs {r['send_fifo']}/{r['receive_fifo']} packets"
        mem = f", {r['memories']}" if r["memories"] else ""
        print(f"          {r['stage']:9s} {r['copies_per_pe']} per PE x {pes} PE(s) = {r['processors']}, "
              f"units {units}{fifo}{mem}")
    print(f"level   {lv['search']}" + (f" (the ladder's choice within {100 * rep['tolerance']:g}%)"
                                       if lv["asked"] == "auto" else " (as asked)"))
    geo = b["speedup_geomean"]
    print(f"speedup {_x(geo)} over the paper's 3MPPE (weighted geometric mean), worst scene "
          f"{_x(b['speedup_worst'])}; sharing {b['sharing_geomean']:.3f} (geometric mean)")
    print(f"{'scene':16s} {'weight':>6s} {'subdivision':>12s} {'cycles':>16s} {'speedup':>8s} {'sharing':>8s}  "
          f"bottleneck")
    for r in rep["per_scene"]:
        iv = r.get("cycles_interval")
        cyc = f"{r['cycles']:16,.0f}" + (f" ({iv[0]:,.0f}..{iv[1]:,.0f})" if iv else "")
        print(f"{r['scene'][:16]:16s} {r['weight']:6g} {'x'.join(map(str, r['subdivision'])):>12s} {cyc} "
              f"{_x(r['speedup']):>8s} {r['sharing']:8.3f}  {r['bottleneck']}")
    for name, title in (("3mppe", "paper 3MPPE"), ("M", "model M"), ("S", "model S")):
        ref = rep["references"][name]
        cyc = ", ".join("deadlocks" if r["cycles"] is None else f"{r['cycles']:,.0f}" for r in ref["per_scene"])
        print(f"ref     {title:12s} cost {ref['cost']:6,.0f} kGE; cycles {cyc}")
    if rep.get("front"):
        print(f"front   {len(rep['front'])} machines, cheapest first (cost, geometric mean of cycles, what differs; "
              f"* the knee, where the figure stops falling fast for the cost added" + ("; + the best within the budget" if rep.get("budget") else "") + "):")
        for f in rep["front"]:
            mark = ("*" if f["knee"] else " ") + ("+" if f["budget_best"] else " ")
            print(f"     {mark} {f['cost']:7,.0f} kGE {f['objective']:14,.0f}  "
                  + ", ".join(f"{k} {v}" for k, v in f["differs"].items()))
    print(f"search  {ev['machines']} machines; {ev['replayed']:,} scene replays, {ev['reused_from_cache']:,} "
          f"from the cache; {rep['seconds']:.1f} s")


def run_prepass(a) -> int:
    from ..explore.prepass import prepass

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
                threshold=a.threshold, axes=a.axes, limits=opt.trace_limits(a))
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
