"""Replay speed of the SimPy machine model: stage visits per second for models
S, M and the full machine (3mppe), beside a bare SimPy loop doing the same
number of get / timeout / put events, measured side by side in one run
(best of --repeat, interleaved), and cProfile's top entries of model M.
With --frame TRACE.npz it also replays a whole frame under model M from the
file (memory-mapped, pages of visits loaded and dropped as rays go through).

    python studies/11_replay_speed/run.py [--scene balls] [--res 128] [--grid 20] [--repeat 3]
                                          [--frame balls512-g50.npz]
    python studies/11_replay_speed/run.py --quick     # balls:1, 24x24, grid 9: work figures to ref/

Writes replay_speed.csv, profile.txt (and frame.csv) to studies/out/11_replay_speed/;
--quick writes only the figures that do not depend on timing (visits, cycles) and checks.
"""
from __future__ import annotations

import cProfile
import io
import os
import pstats
import sys
import threading
import time

import simpy

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import log, study_args, write_checks, write_csv, write_table  # noqa: E402
from mprt.machine import builtin  # noqa: E402
from mprt.machine.system import System  # noqa: E402
from mprt.trace import load_trace  # noqa: E402
from mprt.tracing import trace as trace_grid  # noqa: E402

MODELS = ("S", "M", "3mppe")


def bare_simpy(visits: int, stages: int = 3, tokens: int = 64) -> float:
    """Seconds for a bare SimPy pipeline doing `visits` rounds of get / timeout / put:
    `stages` processes in a ring joined by simpy.Store, `tokens` items circulating."""
    env = simpy.Environment()
    stores = [simpy.Store(env) for _ in range(stages)]
    left = [visits]

    def stage(i):
        inp, out = stores[i], stores[(i + 1) % stages]
        while left[0] > 0:
            x = yield inp.get()
            left[0] -= 1
            yield env.timeout(1 + (x & 3))
            yield out.put(x)

    for i in range(tokens):
        stores[0].put(i)
    for i in range(stages):
        env.process(stage(i))
    t = time.perf_counter()
    env.run()
    return time.perf_counter() - t


def replay(trace, model: str):
    """(seconds to build the machine and cost the trace, seconds to run, result)."""
    t0 = time.perf_counter()
    sysm = System(trace, builtin(model))
    t1 = time.perf_counter()
    res = sysm.run()
    return t1 - t0, time.perf_counter() - t1, res


def profile_m(trace, top: int = 15) -> str:
    sysm = System(trace, builtin("M"))
    pr = cProfile.Profile()
    pr.enable()
    sysm.run()
    pr.disable()
    s = io.StringIO()
    pstats.Stats(pr, stream=s).sort_stats("tottime").print_stats(top)
    return s.getvalue()


def rss_anon_mb() -> float:
    """Resident anonymous memory (MB): the process's own data, not the file pages it maps."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("RssAnon:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def frame(path: str) -> dict:
    """Model M on a whole traced frame read from its file (memory-mapped), with the
    peak of anonymous memory sampled every 0.2 s while it runs."""
    peak = [rss_anon_mb()]
    base = peak[0]
    stop = threading.Event()

    def sample():
        while not stop.wait(0.2):
            peak[0] = max(peak[0], rss_anon_mb())

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    t0 = time.perf_counter()
    tr = load_trace(path, mmap=True)
    sysm = System(tr, builtin("M"))
    t1 = time.perf_counter()
    res = sysm.run(progress=sys.stderr.isatty())
    t2 = time.perf_counter()
    stop.set()
    th.join()
    rp = sysm.replay
    return {"trace": os.path.basename(path), "scene": tr.meta["scene"], "grid": "x".join(map(str, tr.meta["grid"])),
            "resolution": f"{tr.meta['width']}x{tr.meta['height']}", "visits": res.visits,
            "rays": sum(res.rays.values()), "cycles": res.cycles, "setup_s": t1 - t0, "replay_s": t2 - t1,
            "visits_per_s": res.visits / (t2 - t1), "pages": rp.pages_loaded, "max_pages_held": rp.max_pages_held,
            "anon_memory_before_MB": base, "anon_memory_peak_MB": peak[0]}


def main(argv=None) -> int:
    def extra(ap):
        ap.add_argument("--scene", default="balls")
        ap.add_argument("--res", type=int, default=128)
        ap.add_argument("--grid", type=int, default=20)
        ap.add_argument("--repeat", type=int, default=3)
        ap.add_argument("--frame", default=None, help="a trace file to replay whole under model M")

    a, out = study_args(__file__, "SimPy replay throughput against a bare SimPy loop", "balls:1, 24x24, grid 9",
                        argv, extra)
    scene = mprt.Scene.load("balls:1" if a.quick else a.scene)
    res, n = (24, 9) if a.quick else (a.res, a.grid)
    _, tr = trace_grid(scene.grid(n), res, res, threads=a.threads)
    visits = len(tr.visits)
    log(f"{scene.name}, grid {n}, {res}x{res}: {len(tr.rays):,} rays, {visits:,} visits")
    repeat = 1 if a.quick else a.repeat
    best = {m: (float("inf"), float("inf"), None) for m in MODELS}
    bare = float("inf")
    for _ in range(repeat):          # interleaved, so a busy moment hurts all alike
        bare = min(bare, bare_simpy(visits))
        for m in MODELS:
            b, r, result = replay(tr, m)
            best[m] = (min(best[m][0], b), min(best[m][1], r), result)
    rows, work = [], []
    for m in MODELS:
        b, r, result = best[m]
        work.append({"model": m, "visits": result.visits, "cycles": result.cycles,
                     "level": result.level})
        rows.append({**work[-1], "setup_s": b, "replay_s": r, "visits_per_s": visits / r,
                     "bare_simpy_visits_per_s": visits / bare, "ratio_to_bare": bare / r,
                     "visits_per_s_with_setup": visits / (b + r)})
    s, m = best["S"][2], best["M"][2]
    checks = {
        "S time is its processing plus communication": s.cycles == sum(
            s.stages[t]["processing"] + s.stages[t]["communication"] for t in ("OS", "IC", "SC")),
        "M is never slower than S": m.cycles <= s.cycles,
        "M time is at least its largest stage load": m.cycles >= max(m.stage_load(t) for t in ("OS", "IC", "SC")),
        "every model replays every visit": all(best[x][2].visits == visits for x in MODELS),
    }
    if a.quick:
        write_table(out, "replay.csv", work)
        write_checks(os.path.join(out, "checks.csv"), checks)
        log(md_speed(rows))
        return 0 if all(checks.values()) else 1
    write_table(out, "replay_speed.csv", rows)
    prof = profile_m(tr)
    with open(os.path.join(out, "profile.txt"), "w") as f:
        f.write(prof)
    log("\n".join(prof.splitlines()[:30]))
    write_checks(os.path.join(out, "checks.csv"), checks)
    if a.frame:
        row = frame(a.frame)
        write_csv(os.path.join(out, "frame.csv"), [row])
        log(md_speed([row]))
    return 0 if all(checks.values()) else 1


def md_speed(rows) -> str:
    from _common import md_rows

    return md_rows(rows)


if __name__ == "__main__":
    sys.exit(main())
