"""``mprt simulate`` with the fidelity ladder's options.

    mprt simulate TRACE.npz|SCENE [machine and tracing options as mprt.machine.cli]
                  [--level 0|1|2|3|auto] [--engine auto|simpy|compiled|analytical]
                  [--sample [runs:K:SEED[:R]|K[:SEED]]]
                  [--tolerance X]

``--level`` (default: the configuration's own, the level that models all of it)
evaluates the machine as that level models it; ``auto`` measures the levels on
a sample of the frame and takes the cheapest within ``--tolerance`` (default
1%).  ``--engine`` picks the replay (default: the compiled one wherever it is
exact; naming ``compiled`` for a machine it cannot replay is an error, exit 2).
``--sample runs:K:SEED`` (or ``K[:SEED]``; alone: ``runs:16:1``) replays runs of
consecutive trees of the whole frame's trace (a scene is traced whole) holding a
K-th of its visits, scaled by the whole frame's level 0 with a 95% interval (see
sampled.py).  Samples of tiles (``random``, ``stratified``, ``regular``) are
refused before any work: their interval covered the full replay in as few as
15 of 20 seeds (``TILE_COVERAGE``).  ``--json`` gains ``level``,
``engine``, ``sampled`` (fraction of the frame's samples replayed), ``sampled_visits``
(fraction of its visits replayed, where the whole frame's trace is at hand) and
``cycles_interval``.

Wire into the main parser with ``add_parser(subparsers)`` in place of
``mprt.machine.cli.add_parser`` (this one adds to that one).
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time

import numpy as np

from ..util import pages
from ..errors import InvalidArgument
from . import simulate as machine_cli
from ..machine.errors import ConfigError
from ..trace import TraceError
from ..fidelity.analytical import Analytical
from ..fidelity.ladder import measure
from ..fidelity.levels import ENGINES, Evaluator, native_level
from ..fidelity.sampled import RUN_TREES as S_RUN
from ..fidelity.sampled import Sampling, estimate, sample_trace, scaled_result, trace_sample

AUTO_SAMPLE = "runs:16:1"            # what --level auto measures on (a sixteenth of the frame's visits)
AUTO_TILES = 32                      # frames of fewer tiles are measured whole


DEFAULT_SAMPLE = "runs:16:1"         # --sample alone
# Why a sample of tiles is refused (study 13's sample_coverage.py, this session's run): the
# tiles' work is too skewed for a 95% interval from a few dozen of them.
TILE_COVERAGE = ("over the six SPD scenes at 256x256 on model M, random:16 covered the full replay in 15 to 20 "
                 "of 20 seeds per scene (gears 15), random:64 in 17 of 20 on balls, stratified:16 in 16 of 20 on "
                 "gears")


def _sampling(text: str) -> Sampling:
    """A --sample value: runs:K:SEED[:R], or K[:SEED[:R]] for runs.  A sample of tiles (random,
    stratified, regular) is refused: its interval does not hold."""
    t = text.strip()
    if t.split(":")[0].isdigit():
        t = "runs:" + t + (":1" if t.count(":") == 0 else "")
    try:
        s = Sampling.parse(t)
    except InvalidArgument as e:
        raise argparse.ArgumentTypeError(f"{e} (or K[:SEED] for runs:K:SEED)") from None
    if s.method != "runs":
        raise argparse.ArgumentTypeError(
            f"{text}: a sample of tiles gives no trustworthy 95% interval ({TILE_COVERAGE}); use runs:K:SEED "
            f"(--sample K[:SEED]), runs of the whole frame's trees scaled by its level 0")
    return s


def _tolerance(text: str) -> float:
    t = text.strip()
    try:
        v = float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        raise argparse.ArgumentTypeError(f"tolerance must be a fraction (0.01) or a percentage (1%), not {text!r}") \
            from None
    if not 0 <= v < 1:
        raise argparse.ArgumentTypeError(f"tolerance must be in [0, 1) (or 0% to 100%), not {text!r}")
    return v


def add_parser(subparsers) -> argparse.ArgumentParser:
    s = machine_cli.add_parser(subparsers)
    f = s.add_argument_group("fidelity")
    from . import options as opt
    opt.add_level(f, default=None, default_text="the configuration's own level",
                  extra="; auto: the cheapest within --tolerance")
    f.add_argument("--engine", choices=ENGINES, default="auto",
                   help="auto: the compiled replay where exact, else SimPy (default: auto)")
    f.add_argument("--sample", type=_sampling, nargs="?", const=Sampling.parse(DEFAULT_SAMPLE), default=None,
                   metavar="SPEC",
                   help="runs:K:SEED[:R] (or K[:SEED]): replay runs of consecutive trees holding a K-th of the "
                        "frame's visits (R trees each, "
                        f"default {S_RUN}) and scale up by the whole frame's level 0, with a 95%% interval; "
                        f"--sample alone: {DEFAULT_SAMPLE}; samples of tiles (random, stratified, regular) are "
                        "refused, their interval does not hold (default: no sample, the whole frame replayed)")
    f.add_argument("--tolerance", type=_tolerance, default=None, metavar="P",
                   help="error allowed, e.g. 0.01 or 1%%: by --level auto, the level's against the top level; "
                        "with --baseline, the cycles' move from the baseline (default: 1%% for --level auto, 0 "
                        "with --baseline: a replay is deterministic)")
    f.add_argument("--baseline", metavar="FILE.json", default=None,
                   help="the JSON of an earlier 'mprt simulate --json': exit 3 when the cycles move beyond "
                        "--tolerance from its cycles, naming the stages that moved (default: no check)")
    s.set_defaults(func=run)
    return s


def _file_plan(a):
    """``_plan`` of the run of a trace file (no trace needed), or None: a scene to trace, no
    configuration, or one the run will name a fault of."""
    if not a.source.endswith(".npz") or getattr(a, "machine_config", None) is None:
        return None
    try:
        return _plan(a, a.machine_config)
    except Exception:       # (the run names it)
        return None


def _warm_cost_model(plan):
    """A thread making the cost model's table for the processors of ``plan`` (``_file_plan``;
    the kernels' list schedules: about 0.1 s of Python, memoised by ``cost.model``) while the
    trace file's records are read and checked in C, which lets go of the interpreter; None where
    there is nothing to make.  Its errors are left for the run to meet where it meets them."""
    import threading

    if plan is None:
        return None

    def warm():
        try:
            from ..cost import CostModel

            model, procs = CostModel.default(), plan[0].processors()
            model.cost_table(procs)
            model.injection(procs)
        except Exception:       # (the run names it)
            pass

    t = threading.Thread(target=warm, name="mprt-warm-costs", daemon=True)
    t.start()
    return t


def _pages_for(plan):
    """How a trace file's pages are read for the run of ``plan`` (``_file_plan``): kept mapped
    between the checksums, the check and the loading when the compiled replay loads the whole
    file next (it maps every page anyway: letting them go between the passes would only cost
    faulting them in again), else let go after each pass (``pages.release``: SimPy reads the
    trace a window at a time)."""
    return pages.kept() if plan is not None and plan[1] == "compiled" else contextlib.nullcontext()


def _load(a):
    """The trace to replay: a sample of the tiles when --sample is given."""
    if a.sample is None:
        a.sampled_trace = None
        plan = _file_plan(a)
        warm = _warm_cost_model(plan)
        try:
            with _pages_for(plan):
                return machine_cli._load_source(a)
        finally:
            if warm is not None:
                warm.join()
    a.frame_trace = None
    if a.source.endswith(".npz") or a.sample.method == "runs":
        trace, _, how = machine_cli._load_source(a)     # the whole frame
        st = sample_trace(trace, a.sample)          # in the trace's own tiles, or runs of its trees
        a.frame_trace = trace
    else:
        from ..scene import Scene

        scene = Scene.load(a.source)
        grid = scene.grid(a.grid)
        w, h = a.res or (0, 0)
        t0 = time.perf_counter()
        st = trace_sample(grid, a.sample, w, h, a.tile or 16, rules=a.rules or "paper", threshold=a.threshold,
                          threads=a.threads or os.cpu_count() or 1, progress=sys.stderr.isatty(),
                          **machine_cli.opt.trace_limits(a))
        how = (f"traced  {scene.name}, grid {'x'.join(map(str, grid.n))}, {st.trace.meta['width']}x"
               f"{st.trace.meta['height']} {st.trace.meta['rules']}, {len(st.tiles)} of {st.tiles_total} tiles in "
               f"{time.perf_counter() - t0:.2f} s")
    a.sampled_trace = st
    unit = "trees in runs" if a.sample.method == "runs" else "tiles"
    how += (f"\nsample  {a.sample}: {len(st.tiles)} runs, {100 * st.fraction:.2f}% of the trees" if unit != "tiles"
            else f"\nsample  {a.sample}: {len(st.tiles)} of {st.tiles_total} tiles ({100 * st.fraction:.2f}% of samples)")
    return st.trace, machine_cli.source_settings(a, st.trace), how


def _auto_level(trace, cfg, tolerance, sampled: bool) -> tuple:
    """(level, table) chosen by measuring levels 0..cfg's own on (a sample of) the trace."""
    levels = list(range(0, native_level(cfg) + 1))
    tiles = trace.meta.get("tiles_total") or 0
    sample = None if sampled or tiles < AUTO_TILES else AUTO_SAMPLE
    table = measure(trace, [cfg], levels=levels, sample=sample)
    return table.choose(tolerance), table


def _estimate_runs(st, e, an, cfg1, frame, ev):
    """A sample of runs scaled by the whole frame's level 0 (its costs the frame's, which
    the sample's are a slice of), the interval from a compiled level-1 replay's admissions."""
    from ..fidelity.compiled import Compiled

    fcosts = Evaluator(frame, ev.cost_model).costed(cfg1)["costs"]
    c1 = ev.costed(cfg1)
    comp = c1.get("compiled") or Compiled(st.trace, c1["costs"])
    comp.cycles(cfg1)
    return estimate(st, e, an, cfg1, frame=Analytical(frame, fcosts), admitted=comp.admissions())


PHASE_VISITS = 1 << 18      # traces of this many visits or more get phase lines (costing, loading, replaying)
PROBE_RUNS = 64             # the estimate replays runs of trees holding 1/PROBE_RUNS of the visits first


PROBE_SLICES = 4            # ... in this many stretches spread over the trace
# Phase rates (visits/s) for the estimate without a probe, about half those measured on balls
# 512x512 (fidelity README, "The whole command"): costing, loading, replaying at levels 0-1 and 2-3.
RATES = {"costing": 25e6, "loading": 20e6, "replaying": 20e6}
RATE_RING_MEMORIES = 4e6    # replaying at levels 2 and 3
PROBE_FROM = 30.0           # seconds: a run these rates put under this is not probed (a probe costs ~5%)


def _rough(visits: int, level: int) -> dict:
    """Seconds each phase of a compiled replay should take at the typical rates (no probe)."""
    est = {k: visits / r for k, r in RATES.items()}
    rate = RATES["replaying"] if level <= 1 else RATE_RING_MEMORIES
    est["replaying"] = visits / rate
    est["rate"] = rate
    return est


def _probe_sample(trace):
    """The probe's sample without reading the whole trace: PROBE_SLICES stretches of consecutive
    visits spread over it (1/PROBE_RUNS of them in all), each cut to the whole trees whose rays
    it holds (a tracer writes a tree's rays and visits together), renumbered; None when that
    leaves nothing.  Only a time estimate rests on it: a trace in another order gives a sample
    the replay refuses (then the runs of ``sample_trace`` are taken)."""
    from ..trace import ARRAYS, PRIMARY, Trace

    rays, visits = trace.rays, trace.visits
    nv, nr = len(visits), len(rays)
    per = nv // (PROBE_RUNS * PROBE_SLICES)
    if per < 1 or nr < 2:
        return None
    rs, vs, base = [], [], 0
    for i in range(PROBE_SLICES):
        a = (2 * i + 1) * nv // (2 * PROBE_SLICES)
        v = np.array(visits[a:a + per])
        lo, hi = int(v["ray"][0]), int(v["ray"][-1])     # (the trees of these two may be cut)
        if hi <= lo + 1:
            continue
        kind = np.asarray(rays["kind"][lo + 1:hi + 1])
        prim = np.flatnonzero(kind == PRIMARY) + lo + 1
        if len(prim) < 2:
            continue
        r0, r1 = int(prim[0]), int(prim[-1])        # whole trees: from the first primary after lo to hi's
        v = v[(v["ray"] >= r0) & (v["ray"] < r1)]
        r = np.array(rays[r0:r1])
        v["ray"] += base - r0
        r["id"] += base - r0
        r["parent"] = np.where(r["parent"] >= 0, r["parent"] + (base - r0), -1)
        rs.append(r)
        vs.append(v)
        base += r1 - r0
    if not base:
        return None
    arrays = {k: getattr(trace, k) for k in ARRAYS}
    arrays["rays"], arrays["visits"] = np.concatenate(rs), np.concatenate(vs)
    return Trace.from_arrays(dict(trace.meta), arrays)


def _probe(trace, cfg, level: int) -> dict:
    """Seconds each phase of a compiled replay of ``trace`` should take: the same phases timed on
    runs of its trees holding 1/PROBE_RUNS of its visits (sample_trace), scaled by the visits."""
    from ..fidelity.compiled import Compiled, costs_for
    from ..fidelity.levels import at_level

    sample = _probe_sample(trace)
    cfg_l = at_level(cfg, level)
    try:
        if sample is not None:
            costs = costs_for(sample, cfg_l)        # (a trace not in tree order may not load: then runs)
            Compiled(sample, costs)
    except (TraceError, ValueError):
        sample = None
    if sample is None:
        sample = sample_trace(trace, f"runs:{PROBE_RUNS}:1").trace
    n = len(sample.visits)
    if not n:
        return {}
    scale = len(trace.visits) / n
    costs_for(sample, cfg_l)        # the first costing also builds the cost model: not the visits' time
    t0 = time.perf_counter()
    costs = costs_for(sample, cfg_l)
    t1 = time.perf_counter()
    comp = Compiled(sample, costs)
    t2 = time.perf_counter()
    try:
        comp.cycles(cfg_l)
    except Exception:           # a deadlock or a limit on the sample says nothing about the time
        return {"costing": (t1 - t0) * scale, "loading": (t2 - t1) * scale}
    t3 = time.perf_counter()
    return {"costing": (t1 - t0) * scale, "loading": (t2 - t1) * scale, "replaying": (t3 - t2) * scale,
            "rate": n / max(t3 - t2, 1e-9)}


def _phased_replay(ev, trace, cfg, level: int, engine: str, timeline: bool):
    """The replay of a large trace in phases, each with a line on stderr (a bar against its
    estimate on a terminal): costing the visits, loading them into the engine, replaying (on the
    compiled engine the visits are priced as they load: two phases)."""
    from .progress import Phases
    from ..fidelity.levels import at_level

    eng = ev.engine_for(cfg, level, engine)
    visits = len(trace.visits)
    est, how = {}, ""
    if eng == "compiled":
        est = _rough(visits, level)
        how = f"at a typical {est['rate'] / 1e6:.0f} M visits/s"
        if sum(v for k, v in est.items() if k != "rate") >= PROBE_FROM:      # long: worth a probe
            est = _probe(trace, cfg, level)
            how = f"a 1/{PROBE_RUNS} sample of its trees replayed at {est.get('rate', 0) / 1e6:.2f} M visits/s"
    total = sum(v for k, v in est.items() if k != "rate") if "replaying" in est else None
    print(f"replay  {visits:,} visits at level {level} on the {eng} engine"
          + (f": estimated {total:.1f} s ({how})" if total else ""), file=sys.stderr, flush=True)
    if eng == "compiled":       # the visits priced in C as they load: one phase
        ph = Phases(2)
        loading = est.get("loading", 0.0) + est.get("costing", 0.0) if est else None
        with ph.step(f"costing and loading {visits:,} visits into the compiled engine", loading):
            ev.prepare(cfg, level, engine)
        with ph.step(f"replaying at level {level}", est.get("replaying")):
            return ev.evaluate(cfg, level, engine, timeline=timeline, progress=sys.stderr.isatty())
    ph = Phases(3)
    with ph.step(f"costing {visits:,} visits", est.get("costing")):
        ev.costed(at_level(cfg, level))
    with ph.step(f"loading into the {eng} engine", est.get("loading")):
        ev.prepare(cfg, level, engine)
    if eng == "simpy":          # SimPy counts its rays itself (a tqdm bar on a terminal)
        ph.line(f"replaying {len(trace.rays):,} rays on SimPy")
        return ev.evaluate(cfg, level, engine, timeline=timeline, progress=sys.stderr.isatty())
    with ph.step(f"replaying at level {level}", est.get("replaying")):
        return ev.evaluate(cfg, level, engine, timeline=timeline, progress=sys.stderr.isatty())


def _replay(trace, cfg, a):
    from ..machine.config import halved_window, with_window_for
    from ..machine.errors import DeadlockError
    from ..machine.replay import max_leaves

    if cfg.window_rule == "auto":          # the machine file's rule, as the explorer applies it
        frame = getattr(a, "frame_trace", None)
        leaves = max_leaves(trace if frame is None else frame)
        cfg = with_window_for(cfg, leaves)
        print(f"window  {cfg.window} (window = \"auto\": trees of up to {leaves} leaf" + ("" if leaves == 1 else "s") + ")")
    while True:
        try:
            return _replay_at(trace, cfg, a)
        except DeadlockError:
            smaller = halved_window(cfg)
            if smaller is None:
                raise
            print(f"window  {cfg.window} deadlocks; the rule halves it to {smaller.window}")
            cfg = smaller


def _replay_at(trace, cfg, a):
    tolerance = 0.01 if a.tolerance is None else a.tolerance
    st = getattr(a, "sampled_trace", None)
    if a.level == "auto" or (a.level is None and a.tolerance is not None and not getattr(a, "baseline", None)):
        level, table = _auto_level(trace, cfg, tolerance, st is not None)
        print(f"levels  measured on {100 * table.sampled:.1f}% of the samples:\n" + table.text())
        print(f"level   {level}: the cheapest within {100 * tolerance:g}%")
    else:
        level = native_level(cfg) if a.level is None else int(a.level)
    ev = Evaluator(trace)
    timeline = bool(a.plot or getattr(a, "report", None))
    if len(trace.visits) < PHASE_VISITS:       # well under a second: no phase lines
        e = ev.evaluate(cfg, level, a.engine, timeline=timeline, progress=sys.stderr.isatty())
    else:
        e = _phased_replay(ev, trace, cfg, level, a.engine, timeline)
    res = e.result
    extra = {"level": level, "engine": e.engine, "sampled": 1.0, "cycles_interval": [res.cycles, res.cycles]}
    line = f"level {level} on the {e.engine} engine"
    if st is not None:
        from ..fidelity.levels import at_level

        c = ev.costed(at_level(cfg, level))
        an = c.get("analytical") or Analytical(trace, c["costs"])
        if st.sampling.method == "runs":
            sc = _estimate_runs(st, e, an, at_level(cfg, 1), a.frame_trace, ev)
        else:
            sc = estimate(st, e, an, at_level(cfg, 1))
        res = scaled_result(res, sc)
        extra.update(sampled=sc.fraction, cycles_interval=list(sc.interval), sample_cycles=sc.sample_cycles,
                     sample=str(st.sampling), tiles=[len(st.tiles), st.tiles_total])
        if st.visits is not None:       # the work: visits replayed / the frame's
            extra["sampled_visits"] = float(st.visits.mean()) if len(st.visits) else 0.0
        line += (f"; the sample took {sc.sample_cycles:,} cycles, the frame an estimated {sc.cycles:,} "
                 f"(95%: {sc.interval[0]:,} to {sc.interval[1]:,})")
    print(line)
    a.replayed = (res, extra)
    return res, extra


def _plan(a, cfg, trace=None):
    """(configuration at the level run, engine, its memories' figures) for the memory estimate
    (``memory_estimate.check_simulate``): --level (auto: the configuration's own, the most it may
    take), --engine, with ``auto`` SimPy where the compiled replay refuses the caches (as
    ``Evaluator.engine_for``); None where the run will name a fault itself."""
    from .. import memory_estimate as me
    from ..fidelity.levels import at_level, engine_for
    from ..fidelity.memdata import MemoryData

    level = native_level(cfg) if a.level in (None, "auto") else int(a.level)
    try:
        engine = engine_for(cfg, level, a.engine)
    except ConfigError:
        return None
    c = at_level(cfg, level)
    if trace is None or (c.ic_memory is None and c.sc_memory is None):
        return c, engine, None
    a.memory_data = MemoryData.of(trace)        # held for the run's Evaluator: computed once
    figures = lambda tag, mc: me.memory_figures(a.memory_data, tag, mc)  # noqa: E731
    if engine == "compiled" and a.engine == "auto" and me.compiled_cache_overflow(c, figures):
        engine = "simpy"
    return c, engine, figures


def run(a) -> int:
    from ..fidelity import baseline
    from .options import UsageError

    try:
        if a.engine != "auto" and a.level == "auto":
            raise ConfigError("--level auto chooses the engine with the level; leave --engine out")
        base = baseline.load(a.baseline) if a.baseline else None
    except ConfigError as e:
        print(f"mprt simulate: invalid configuration: {e}", file=sys.stderr)
        return 2
    except UsageError as e:
        print(f"mprt simulate: error: {e}", file=sys.stderr)
        return 2
    a.replayed = None
    rc = machine_cli.run(a, load=_load, replay=_replay, plan=_plan)
    if rc != 0 or base is None or a.replayed is None:
        return rc
    res, extra = a.replayed
    now = dict(res.to_dict(), **extra)
    now["settings"] = getattr(a, "run_settings", None) or {}
    tol = 0.0 if a.tolerance is None else a.tolerance
    moved, lines = baseline.compare(now, base, tol, a.baseline)
    for ln in lines:
        print(ln, file=sys.stderr if moved else sys.stdout)
    return baseline.EXIT_MOVED if moved else 0


def main(argv=None) -> int:
    """Run ``simulate`` alone (until it is wired into the ``mprt`` command)."""
    return machine_cli.main(argv, add_parser)


if __name__ == "__main__":
    sys.exit(main())
