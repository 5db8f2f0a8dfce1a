"""The whole `mprt explore SCENE --res RES --budget BUDGET --threads 2` command's wall time
(fresh process, from its start to its end) against one whole `mprt trace` of the same frame
at the subdivision it chose, in the same run: issue 18's yardstick (an exploration within
10 traces).  With ``--before DIR`` (a checkout's Python package directory, e.g. a build of
an older commit made as `make bench` makes it), that build's command runs first, alternated
with this checkout's scene by scene, and both answers are compared.

    .venv/bin/python studies/20_design_space/explore_wall.py [--rounds N] [--res 512]
        [--budget 800] [--before DIR] [SCENE ...]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import mprt

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _common import command_env  # noqa: E402


def _explore(scene, res, budget, out, path=None):
    env = command_env(path)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mprt", "explore", scene, "--res", f"{res}x{res}", "--budget", str(budget),
                    "--threads", "2", "--json", out], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=env)
    s = time.perf_counter() - t0
    with open(out) as f:
        return s, json.load(f)


def _trace(scene, res, grid, out):
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mprt", "trace", scene, "--grid", ",".join(map(str, grid)),
                    "--res", f"{res}x{res}", "--threads", "2", "-o", out], check=True, stdout=subprocess.DEVNULL,
                   env=command_env())
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", default=list(mprt.SPD_SCENES))
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--budget", type=float, default=800.0)
    ap.add_argument("--before", help="the build to compare with (a directory put on PYTHONPATH)")
    a = ap.parse_args(argv)
    rows = {}
    with tempfile.TemporaryDirectory() as d:
        for r in range(1, a.rounds + 1):
            for name in a.scenes:
                got = {}
                for build, path in ([("before", a.before)] if a.before else []) + [("after", None)]:
                    s, rep = _explore(name, a.res, a.budget, os.path.join(d, f"{build}.json"), path)
                    got[build] = (s, rep)
                    print(f"{r} {name} {build} {s:.2f} s, {rep['per_scene'][0]['cycles']:.4g} cycles, "
                          f"{'x'.join(map(str, rep['per_scene'][0]['subdivision']))}", flush=True)
                after = got["after"][1]
                if a.before and (got["before"][1]["best"] != after["best"]):
                    print(f"{r} {name}: the answers differ", flush=True)
                t = _trace(name, a.res, after["per_scene"][0]["subdivision"], os.path.join(d, "t.npz"))
                print(f"{r} {name} trace {t:.2f} s", flush=True)
                rows.setdefault(name, []).append({k: v[0] for k, v in got.items()} | {"trace": t})
    builds = (["before"] if a.before else []) + ["after"]
    print("\n| scene | " + " | ".join(f"seconds {b}" for b in builds) + " | trace s | "
          + " | ".join(f"x trace {b}" for b in builds) + " |")
    print("|---" * (2 + 2 * len(builds)) + "|")
    for name, rs in rows.items():
        def col(f):
            return ", ".join(f"{f(x):.1f}" for x in rs)
        seconds = " | ".join(col(lambda x, b=b: x[b]) for b in builds)
        ratios = " | ".join(col(lambda x, b=b: x[b] / x["trace"]) for b in builds)
        print(f"| {name} | {seconds} | {col(lambda x: x['trace'])} | {ratios} |")


if __name__ == "__main__":
    main()
