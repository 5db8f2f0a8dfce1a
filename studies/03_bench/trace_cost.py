"""What a trace costs over a render of the same frame, side by side in one run (issue 21, item 1).

For each SPD scene at its default size and grid, at RESxRES, paper rules:

- whole commands: ``mprt render SCENE --res RxR --threads T -o F.png`` against ``mprt trace SCENE
  --res RxR --threads T -o F.npz``, alternated, best of N wall-clock and CPU (user + system of the
  child) times; the output file is removed before each run, outside the timing;
- in one process: ``Grid.render`` against ``Grid.trace`` (in memory), alternated, best of N process
  CPU and wall-clock times (the first trace of the process, which touches its record arrays'
  pages for the first time, is printed apart: later traces reuse them).

With ``--before PYTHON`` (the python of another build, for example main's venv) every figure is also
made with that build, alternated scene by scene and run by run, so before and after come from one
run.  Prints one table; the ratios are what to compare (the machine may be shared).

    python studies/03_bench/trace_cost.py --repeat 3 --before /tmp/main/.venv/bin/python
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _common import command_env  # noqa: E402

SCENES = ("balls", "gears", "mount", "rings", "tetra", "tree")


def in_process(scene: str, res: int, repeat: int, threads: int) -> dict:
    """Worker: render and trace alternated in this process; best times and the first trace's."""
    import mprt
    grid = mprt.Scene.load(scene).grid(None)
    out = {"render_cpu": [], "render_wall": [], "trace_cpu": [], "trace_wall": []}
    for _ in range(repeat):
        for what in ("render", "trace"):
            fn = getattr(grid, what)
            c, w = time.process_time(), time.perf_counter()
            result = fn(res, res, threads=threads)
            out[what + "_wall"].append(time.perf_counter() - w)
            out[what + "_cpu"].append(time.process_time() - c)
            del result
    return out


def run_worker(python: str, scene: str, res: int, repeat: int, threads: int) -> dict:
    cmd = [python, os.path.abspath(__file__), "--worker", scene, "--res", str(res), "--repeat", str(repeat),
           "--threads", str(threads)]
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True,
                                     env=command_env()).stdout.splitlines()[-1])


def whole_command(python: str, what: str, scene: str, res: int, threads: int, out_dir: str):
    """(wall, CPU) seconds of one mprt render or mprt trace command writing its file."""
    path = os.path.join(out_dir, f"{scene}.{'png' if what == 'render' else 'npz'}")
    if os.path.exists(path):
        os.unlink(path)
    cmd = [python, "-m", "mprt", what, scene, "--res", f"{res}x{res}", "--threads", str(threads), "-o", path]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, env=command_env())
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    os.unlink(path)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=3, help="runs of each measure (best is kept)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--before", help="python of the build to compare with (its mprt is imported)")
    ap.add_argument("--out-dir", help="where the commands write their files (default: a temporary folder)")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        print(json.dumps(in_process(a.worker, a.res, a.repeat, a.threads)))
        return 0
    builds = {"after": sys.executable}
    if a.before:
        builds = {"before": a.before, **builds}
    out_dir = a.out_dir or tempfile.mkdtemp(prefix="trace_cost-")
    os.makedirs(out_dir, exist_ok=True)
    print(f"{a.res}x{a.res} paper rules, default grids, {a.threads} thread(s), best of {a.repeat}; "
          f"builds: {', '.join(f'{k} {v}' for k, v in builds.items())}; load {os.getloadavg()[0]:.1f}", flush=True)
    head = ("scene", "build", "cmd render s", "cmd trace s", "cmd wall x", "cmd CPU x", "render s", "trace s",
            "in-proc CPU x", "in-proc wall x", "first trace x")
    print(" | ".join(head))
    rows = []
    for n, scene in enumerate(a.scenes.split(",")):
        cmd = {b: {"render": [], "trace": []} for b in builds}
        for _ in range(a.repeat):
            for b, py in builds.items():
                for what in ("render", "trace"):
                    cmd[b][what].append(whole_command(py, what, scene, a.res, a.threads, out_dir))
        # the in-process workers in turns, the first one changing from scene to scene: the first
        # process after the commands pays for the memory they left the system to reclaim
        order = list(builds.items())[::-1 if n % 2 else 1]
        worker = {b: run_worker(py, scene, a.res, a.repeat, a.threads) for b, py in order}
        for b, py in builds.items():
            w = worker[b]
            r_wall, r_cpu = min(x[0] for x in cmd[b]["render"]), min(x[1] for x in cmd[b]["render"])
            t_wall, t_cpu = min(x[0] for x in cmd[b]["trace"]), min(x[1] for x in cmd[b]["trace"])
            row = {"scene": scene, "build": b, "cmd_render_wall": r_wall, "cmd_trace_wall": t_wall,
                   "cmd_wall_ratio": t_wall / r_wall, "cmd_cpu_ratio": t_cpu / r_cpu,
                   "render_cpu": min(w["render_cpu"]), "trace_cpu": min(w["trace_cpu"]),
                   "inproc_cpu_ratio": min(w["trace_cpu"]) / min(w["render_cpu"]),
                   "inproc_wall_ratio": min(w["trace_wall"]) / min(w["render_wall"]),
                   "first_trace_ratio": w["trace_cpu"][0] / min(w["render_cpu"])}
            rows.append(row)
            print(f"{scene} | {b} | {r_wall:.2f} | {t_wall:.2f} | {row['cmd_wall_ratio']:.2f} | "
                  f"{row['cmd_cpu_ratio']:.2f} | {row['render_cpu']:.3f} | {row['trace_cpu']:.3f} | "
                  f"{row['inproc_cpu_ratio']:.2f} | {row['inproc_wall_ratio']:.2f} | {row['first_trace_ratio']:.2f}",
                  flush=True)
    if not a.out_dir:
        os.rmdir(out_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
