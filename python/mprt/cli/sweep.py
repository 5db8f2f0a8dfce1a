"""The ``sweep`` subcommand: every design of a spec on every scene at every subdivision, on Dask
(the work: ``mprt.explore.sweep``), with its progress line and its report."""
from __future__ import annotations

import argparse
import os
import sys
import time

from . import options as opt


def check_output(path) -> None:
    """Fail before any work if an output file cannot be written."""
    if path is None:
        return
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise OSError(f"{path}: directory {d} does not exist")
    if not os.access(d, os.W_OK):
        raise OSError(f"{path}: directory {d} is not writable")


def add_parser(sub) -> None:
    from ..explore.sweep import __doc__ as sweep_doc
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
    opt.add_skip_unknown(w)     # the default of the scenes whose [[scene]] table does not say
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


def run_sweep(a) -> int:
    from ..explore.space import SpaceError
    from ..explore.sweep import check_memory, load_spec, run_sweep as sweep

    try:
        spec = load_spec(a.spec, skip_unknown=a.skip_unknown)
    except SpaceError as e:
        raise opt.UsageError(str(e)) from None
    if a.report:
        opt.check_outputs(("--report", a.report, "html"))
    check_output(os.path.join(a.out, "x"))  if os.path.isdir(a.out) else check_output(a.out)
    sizes = dict.fromkeys("x".join(map(str, e.res)) for e in spec["entries"])     # (each scene's own)
    print(f"sweep   {len(spec['scenes'])} scene(s) x {len(spec['subdivisions'])} subdivision(s) x "
          f"{len(spec['designs'])} design(s) at {', '.join(sizes)}, level {spec['level']}, on "
          f"{'the Dask scheduler ' + a.scheduler if a.scheduler else 'a local Dask cluster'}; progress with an "
          "estimate of the time left below", flush=True)
    if not a.scheduler:     # before any work: every worker holds a traced frame
        check_memory(spec, a.workers)
    tick = sweep_progress()
    r = sweep(spec, a.out, scheduler=a.scheduler, workers=a.workers, progress=tick,
              note=lambda text: print(f"mprt: warning: {text}", file=sys.stderr))
    tick.end()
    print(f"sweep   {r['rows']} rows from {r['tasks']} tasks ({r['cached']} from the cache) in {r['seconds']:.1f} s")
    print(f"wrote   {r['csv']}\nwrote   {r['png']}")
    if a.report:
        from . import report
        report.write(a.report, report.sweep_html(r, getattr(a, "argv", None)))
        print(f"wrote   {a.report}")
    return 0
