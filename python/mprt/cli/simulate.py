"""``mprt simulate``: replay a trace (or trace a scene first) on a machine.

    mprt simulate TRACE.npz|SCENE [--grid N] [--res WxH] [--model S|M|3mppe]
                  [--config FILE.toml] [--pes N] [--json OUT.json] [--plot OUT.png]

Wire into the main parser with ``add_parser(subparsers)``; ``run(args)``
returns the exit status (2 for an invalid configuration).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from .. import memory_estimate
from . import options as opt
from ..machine.config import BUILTIN, resolve
from ..machine.errors import ConfigError, DeadlockError


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = subparsers.add_parser(
        "simulate", help="replay a trace on a machine model (S, M, 3mppe or a TOML configuration)",
        description="Replay a trace on the machine model (SimPy).  A SCENE (SPD name or NFF file) is traced "
                    "first with the tracing options.  Its peak memory is estimated before any work; a run that "
                    "would need more than is available (MemAvailable, or MPRT_MEMORY_LIMIT, e.g. 8G) is refused "
                    "with the figures (exit 2).",
        epilog=opt.EXIT_STATUS + "; 3 with --baseline: the cycles moved beyond --tolerance")
    s.add_argument("source", metavar="TRACE.npz|SCENE", help="a trace file, or a scene to trace first")
    opt.add_skip_unknown(s)
    g = s.add_argument_group("tracing (when SOURCE is a scene)")
    opt.add_grid(g)
    opt.add_res(g)
    opt.add_rules(g, sentinel=True)
    opt.add_threshold(g)
    opt.add_threads(g, sentinel=True)
    opt.add_tile(g)
    opt.add_trace_limits(g)
    m = s.add_argument_group("machine")
    m.add_argument("--model", choices=tuple(BUILTIN), default=None,
                   help="built-in configuration (default: M, or the --config file's)")
    m.add_argument("--config", metavar="FILE.toml", default=None,
                   help="machine configuration file (default: none, the --model)")
    m.add_argument("--pes", type=opt.int_range_arg("PEs", 1, 1 << 20), default=None, metavar="N",
                   help="number of PEs, 1..2^20 and at most the pixels (overrides the configuration) "
                        "(default: the configuration's)")
    o = s.add_argument_group("output")
    opt.add_json(o)
    o.add_argument("--plot", metavar="OUT.png", default=None,
                   help="write per-stage load bars, utilisation and FIFO occupancy over time (PNG) (default: none)")
    o.add_argument("--report", metavar="OUT.html", default=None,
                   help="write one self-contained HTML page: the answer, the stages, the plots and the command "
                        "(default: none)")
    s.set_defaults(func=run)
    return s


def _wants_memory_keys(a) -> bool:
    """Whether the run reads level 3's memory keys of the whole trace (its plan has modelled
    memories and no sample is taken): then they are made while the records are checked."""
    plan = getattr(a, "memory_plan", None)
    cfg = getattr(a, "machine_config", None)
    if plan is None or cfg is None or getattr(a, "sample", None) is not None:
        return False
    p = plan(a, cfg)
    return p is not None and (p[0].ic_memory is not None or p[0].sc_memory is not None)


def _load_source(a):
    """(trace, settings) from a trace file or a scene traced now."""
    from ..trace import load_trace
    from ..trace.tracing import trace as trace_grid

    src = a.source
    if src.endswith(".npz"):
        # schema, ranges and invariants: before any engine (level 3's memory keys in the same pass)
        trace = load_trace(src, invariants=True, memory_keys=_wants_memory_keys(a))
        how = f"trace   {src}"
    else:
        scene, _ = opt.load_scene(src, skip_unknown=a.skip_unknown)
        grid = scene.grid(a.grid)
        w, h = a.res or (0, 0)
        if getattr(a, "memory_plan", None) is not None:      # the least the frame holds, before tracing
            rw, rh = a.res or scene.info()["resolution"]
            memory_estimate.check_simulate(memory_estimate.frame_counts(rw, rh, grid.n, scene.info()["prims"]),
                                           a.memory_plan(a, a.machine_config), _timeline(a))
        t0 = time.perf_counter()
        _, trace = trace_grid(grid, w, h, rules=a.rules or "paper", threshold=a.threshold,
                              threads=a.threads or os.cpu_count() or 1, tile=a.tile or 16,
                              progress=sys.stderr.isatty(), **opt.trace_limits(a))
        how = (f"traced  {scene.name}, grid {'x'.join(map(str, grid.n))}, {trace.meta['width']}x"
               f"{trace.meta['height']} {trace.meta['rules']} in {time.perf_counter() - t0:.2f} s")
    settings = source_settings(a, trace)
    return trace, settings, how


def source_settings(a, trace) -> dict:
    """The JSON ``settings`` describing where a trace came from."""
    m = trace.meta
    src = a.source
    return {"source": src, "scene": m.get("scene"), "scene_sha256": m.get("scene_sha256"),
            "grid": m.get("grid"), "resolution": [m.get("width"), m.get("height")], "rules": m.get("rules"),
            "threshold": m.get("threshold"), "max_depth": m.get("max_depth"), "max_rays": m.get("max_rays"),
            "tiles": len(m.get("tiles", [])),
            "tiles_total": m.get("tiles_total"), "tile": m.get("tile"),
            "threads": None if src.endswith(".npz") else a.threads or os.cpu_count() or 1}


def _simpy_plan(a, cfg, trace=None):
    """What this command runs, for its memory estimate: the configuration, on SimPy (its caches'
    data not counted: the fidelity ladder's plan knows it)."""
    return cfg, "simpy", None


def _timeline(a) -> bool:
    return bool(getattr(a, "plot", None) or getattr(a, "report", None))


def run(a, load=None, replay=None, plan=None) -> int:
    """``load(a)`` -> (trace, settings, how) and ``replay(trace, cfg, a)`` -> (SimResult, JSON
    fields to add) replace the defaults (tracing/reading SOURCE; the SimPy replay), so the
    fidelity ladder's options can reuse this command (mprt.fidelity.cli); ``plan(a, cfg,
    trace=None)`` -> (configuration at the level run, engine, figures of its memories' data) or
    None, for the memory estimate (``memory_estimate.check_simulate``) before the trace is read
    and again with it."""
    from .._lowlevel import EXT_VERSION
    from ..errors import MprtError
    from ..machine.system import System

    if a.source.endswith(".npz"):
        given = [f"--{k.replace('_', '-')}" for k in ("grid", "res", "rules", "threshold", "threads", "tile",
                                                       "max_rays", "max_depth")
                 if getattr(a, k, None) is not None]
        if given:
            print(f"mprt simulate: {', '.join(given)} set how a scene is traced; {a.source} was traced with "
                  "its own settings (see 'mprt stats')", file=sys.stderr)
            return 2
    try:
        opt.check_outputs(("--json", a.json, "json"), ("--plot", a.plot, "png"), ("--report", a.report, "html"))
        if a.source.endswith(".npz"):
            opt.check_input("TRACE", a.source)
        if a.threshold is not None:
            opt.check_render_options(argparse.Namespace(threshold=a.threshold, rules=a.rules or "paper"))
        cfg = resolve(a.model, a.config, a.pes)
        t0 = time.perf_counter()
        level = getattr(a, "level", None)
        print(f"simulate {a.source}: {'read the trace' if a.source.endswith('.npz') else 'trace the scene'}, then "
              f"replay it on {cfg.name}"
              + (f" at level {level}" if level not in (None, "auto") else " (level auto: measured first)"
                 if level == "auto" else "")
              + (f", {a.sample} of it" if getattr(a, "sample", None) else "")
              + (f", against the baseline {a.baseline}" if getattr(a, "baseline", None) else ""), flush=True)
        a.machine_config, a.memory_plan = cfg, plan or _simpy_plan
        if a.source.endswith(".npz"):       # from the file's headers, before its records are read
            memory_estimate.check_simulate(memory_estimate.file_counts(a.source), a.memory_plan(a, cfg),
                                           _timeline(a))
        trace, settings, how = (load or _load_source)(a)
        print(how)
        memory_estimate.check_simulate(memory_estimate.trace_counts(trace), a.memory_plan(a, cfg, trace),
                                       _timeline(a), loaded=True)
        if replay is None:
            res, extra = System(trace, cfg, timeline=bool(a.plot or a.report)).run(progress=sys.stderr.isatty()), {}
        else:
            res, extra = replay(trace, cfg, a)
    except ConfigError as e:
        print(f"mprt simulate: invalid configuration: {e}", file=sys.stderr)
        return 2
    except opt.UsageError as e:
        print(f"mprt simulate: error: {e}", file=sys.stderr)
        return 2
    except DeadlockError as e:
        print(f"mprt simulate: {e}", file=sys.stderr)
        return 1
    except (MprtError, OSError, ValueError, MemoryError) as e:
        print(f"mprt simulate: error: {e}", file=sys.stderr)
        return 1
    wall = time.perf_counter() - t0
    print(res.report())
    print(f"time    {res.wall_seconds:.2f} s replay ({res.visits / max(res.wall_seconds, 1e-9):,.0f} visits/s), "
          f"{wall:.2f} s in all")
    a.run_settings = {**settings, "model": cfg.name, "config_file": cfg.source, "pes": cfg.pes,
                      "mprt_version": EXT_VERSION, "cost_model": "default"}
    out = res.to_dict()
    out.update(extra)
    out["wall_seconds"] = wall
    out["replay_seconds"] = res.wall_seconds
    out["settings"] = a.run_settings
    if a.json:
        opt.write_json(a.json, out)
        print(f"wrote   {a.json}")
    grid = settings.get("grid")
    title = (f"{settings['scene']}, grid {'x'.join(map(str, grid)) if isinstance(grid, (list, tuple)) else grid}: "
             f"model {cfg.name}, {res.cycles:,} cycles")
    if a.plot:
        res.plot(a.plot, title=title)
        print(f"wrote   {a.plot}")
    if a.report:
        import tempfile

        from . import report
        with tempfile.TemporaryDirectory() as d:
            png = a.plot or os.path.join(d, "simulate.png")
            if not a.plot:
                res.plot(png, title=title)
            report.write(a.report, report.simulate_html(out, getattr(a, "argv", None), png))
        print(f"wrote   {a.report}")
    return 0


def main(argv=None, add=None) -> int:
    """Run ``simulate`` alone (until it is wired into the ``mprt`` command); ``add``: the
    add_parser to use (default this module's)."""
    p = argparse.ArgumentParser(prog="mprt")
    sub = p.add_subparsers(dest="cmd", required=True)
    (add or add_parser)(sub)
    args = p.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
