"""The time of one `mprt explore SCENE --res 512x512` per SPD scene (default
settings: built-in space, level auto at 1% tolerance: the ladder measured at
64x64, the search at the ladder's level, the best designs re-evaluated and
polished at 512x512 on a sample of its tiles), budget 800 kGE, tracing on 2
threads; beside it, in the same run, the time of one whole `mprt trace` command
of the same frame at the subdivision the explorer chose (the issue's yardstick:
an exploration within 10 traces).

    .venv/bin/python studies/20_design_space/explore_timing.py [RES] [BUDGET] [SCENE ...]
"""
import os
import subprocess
import sys
import tempfile
import time

import mprt
from mprt.explore.explorer import SearchSettings, explore
from mprt.explore.workload import SceneEntry, Workload


def main(res=512, budget=800.0, *names):
    print("| scene | seconds | trace s | x trace | evaluations | replayed | level | ladder s | subdivision "
          "| best design | cycles | cost kGE | x 3MPPE | x S |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in names or mprt.SPD_SCENES:
        t0 = time.perf_counter()
        r = explore(Workload((SceneEntry(name, res=(res, res)),)), None, SearchSettings(budget=float(budget)),
                    say=lambda s: print(f"  {name}: {s}", file=sys.stderr, flush=True))
        s = time.perf_counter() - t0
        (row,), b, refs, lv = r.per_scene, r.best, r.references, r.report["level"]
        with tempfile.TemporaryDirectory() as d:
            t1 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "mprt", "trace", name, "--grid", ",".join(map(str, row["subdivision"])),
                            "--res", f"{res}x{res}", "--threads", "2", "-o", os.path.join(d, "t.npz")], check=True,
                           stdout=subprocess.DEVNULL)
            tt = time.perf_counter() - t1
        ev = r.report["evaluations"]
        print(f"| {name} | {s:.0f} | {tt:.1f} | {s / tt:.1f} | {ev['machines']} | {ev['replayed']} | {lv['search']} "
              f"| {lv.get('ladder_seconds', 0):.0f} | {'x'.join(map(str, row['subdivision']))} | {b['described']} "
              f"| {row['cycles']:.3g} | {b['cost']:.0f} | {refs['3mppe']['cycles'] / row['cycles']:.2f} "
              f"| {refs['S']['cycles'] / row['cycles']:.2f} |", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(int(args[0]) if args else 512, float(args[1]) if len(args) > 1 else 800.0, *args[2:])
