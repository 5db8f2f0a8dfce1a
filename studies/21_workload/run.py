"""One machine for a workload (issue 35): what the explorer's answer costs, what each scene gives
up by sharing the chip, how it compares with the per-scene answers, and how it runs.

    .venv/bin/python studies/21_workload/run.py [--quick] [--part NAME ...] [--res N] [--out DIR]

Parts (each prints its table and writes DIR/<part>.md; timings vary, answers do not):
  workload   the six SPD scenes as one workload at --res under 800 kGE: the whole command's time
             beside one `mprt trace` of each scene at its chosen subdivision, in the same run; per
             scene the answer's subdivision, cycles, speed-up over the 3MPPE and sharing
  per_scene  each scene's own explore (a workload of one) at --res2; each of those six machines
             then run as a fixed machine on the whole workload (--machine): the best of them
             against the workload's answer (its geometric-mean speed-up over the 3MPPE)
  leave_out  for each scene, the machine chosen for the other five, run on it (--machine) at
             --res2, against that scene's own best machine
  workers    a workload of three scenes at --res2 with --workers 1, --workers 2 and a local Dask
             cluster of two workers: the same answer, and the times
  resume     the same run killed at about half its time and run again from --cache: the same
             answer, the time and the share of evaluations reused
  memory     explore balls at 4096x4096 and 8192x8192: the answer or the refusal, its time and
             peak memory
  kill_worker  the workers' run with one worker killed (SIGKILL) at about half its time: in the
             local pool (--workers 2) and on a local Dask cluster of two (its nanny restarts it):
             the same answer
  estimates  each phase's estimate against the time it took: `mprt explore SCENE --res 512x512
             --budget 800` for each SPD scene, and the demo's command (make demo)
--quick: tetra:1 and balls:1 at 16x16, the small test space, level 1 (the committed ref/: the
answer and its per-scene table; no timings).
"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _common import command_env, study_args  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SPD6 = ["balls", "gears", "mount", "rings", "tetra", "tree"]
PARTS = ("workload", "per_scene", "leave_out", "workers", "resume", "memory", "estimates", "kill_worker")


def mprt(*args, env=None, check=True, timeout=None):
    """Run `python -m mprt ARGS`; (seconds, completed process)."""
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "mprt", *map(str, args)], capture_output=True, text=True,
                       env=env or command_env(), timeout=timeout)
    if check and p.returncode != 0:
        raise RuntimeError(f"mprt {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr[-2000:]}")
    return time.perf_counter() - t0, p


def explore(scenes, res, out, *extra, budget=800):
    s, p = mprt("explore", *scenes, "--res", f"{res}x{res}", "--budget", budget, "--json", out, *extra)
    with open(out) as f:
        return s, json.load(f), p


def table(rows, head):
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(x) for x in r) + " |" for r in rows]
    return "\n".join(lines)


def x(v):
    return "-" if v is None else f"{v:.2f}"


def part_workload(d, res):
    s, rep, _ = explore(SPD6, res, os.path.join(d, "w.json"), "--machine-out", os.path.join(d, "w.toml"))
    rows, traced = [], 0.0
    for r in rep["per_scene"]:
        t, _ = mprt("trace", r["scene"], "--grid", ",".join(map(str, r["subdivision"])), "--res", f"{res}x{res}",
                    "--threads", "2", "-o", os.path.join(d, "t.npz"))
        traced += t
        rows.append((r["scene"], "x".join(map(str, r["subdivision"])), f"{r['cycles']:,.0f}", x(r["speedup"]),
                     f"{r['sharing']:.3f}", f"{t:.1f}"))
    b = rep["best"]
    text = (f"Six SPD scenes at {res}x{res} under 800 kGE: {b['described']} ({b['cost']:.0f} kGE); "
            f"speed-up over the 3MPPE {x(b['speedup_geomean'])} (geometric mean), sharing "
            f"{b['sharing_geomean']:.3f} (geometric mean).\n\nWhole command {s:.1f} s; one trace of each scene at "
            f"its subdivision {traced:.1f} s in all: {s / traced:.1f}x.\n\n"
            + table(rows, ("scene", "subdivision", "cycles", "x 3MPPE", "sharing", "trace s")))
    return text, rep


def part_per_scene(d, res, workload_rep=None):
    if workload_rep is None:
        _, workload_rep, _ = explore(SPD6, res, os.path.join(d, "w.json"))
    rows = []
    for name in SPD6:
        _, rep, _ = explore([name], res, os.path.join(d, f"{name}.json"), "--machine-out",
                            os.path.join(d, f"{name}.toml"))
        _, on_all, _ = explore(SPD6, res, os.path.join(d, f"{name}-all.json"), "--machine",
                               os.path.join(d, f"{name}.toml"))
        rows.append((name, rep["best"]["described"], f"{rep['best']['cost']:.0f}",
                     x(on_all["best"]["speedup_geomean"])))
    best = max(rows, key=lambda r: float(r[3]) if r[3] != "-" else 0)
    w = workload_rep["best"]
    return (f"Each scene's own answer at {res}x{res} under 800 kGE, run as a fixed machine on the six: the best "
            f"of them is {best[0]}'s, {best[3]}x the 3MPPE (geometric mean); the workload's answer "
            f"{x(w['speedup_geomean'])}x ({w['cost']:.0f} kGE).\n\n"
            + table(rows, ("own answer of", "machine", "kGE", "x 3MPPE on all six (geomean)")))


def part_leave_out(d, res):
    rows = []
    for name in SPD6:
        rest = [n for n in SPD6 if n != name]
        explore(rest, res, os.path.join(d, f"lo-{name}.json"), "--machine-out", os.path.join(d, f"lo-{name}.toml"))
        _, held, _ = explore([name], res, os.path.join(d, f"lo-{name}-on.json"), "--machine",
                             os.path.join(d, f"lo-{name}.toml"))
        _, own, _ = explore([name], res, os.path.join(d, f"own-{name}.json"))
        hc, oc = held["per_scene"][0]["cycles"], own["per_scene"][0]["cycles"]
        rows.append((name, f"{hc:,.0f}", f"{oc:,.0f}", f"{min(oc, hc) / hc:.3f}"))
    return (f"Leave one out at {res}x{res} under 800 kGE: the machine chosen for the other five scenes, on the "
            f"scene left out, against that scene's own answer.\n\n"
            + table(rows, ("scene left out", "cycles on the five's machine", "cycles on its own", "ratio")))


def part_workers(d, res):
    scenes = ["balls", "gears", "tetra"]
    got = {}
    for label, extra in (("1 worker", ("--workers", "1")), ("2 workers", ("--workers", "2"))):
        s, rep, _ = explore(scenes, res, os.path.join(d, f"{label}.json"), *extra)
        got[label] = (s, rep)
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cl:
        s, rep, _ = explore(scenes, res, os.path.join(d, "dask.json"), "--scheduler", cl.scheduler_address)
        got["Dask, 2 workers"] = (s, rep)
    ref = got["1 worker"][1]
    rows = [(k, f"{s:.1f}", _same(ref, rep)) for k, (s, rep) in got.items()]
    return (f"{', '.join(scenes)} at {res}x{res} under 800 kGE.\n\n" + table(rows, ("run", "seconds", "same answer")))


def _same(a, b) -> str:
    keys = ("best", "per_scene", "references")
    return "yes" if all(a[k] == b[k] for k in keys) else "NO"


def part_kill_worker(d, res):
    scenes = ["balls", "gears", "tetra"]
    whole, ref, _ = explore(scenes, res, os.path.join(d, "whole.json"), "--workers", "2")
    rows = []
    for how in ("local pool", "Dask"):
        cluster = None
        extra = ["--workers", "2"]
        if how == "Dask":
            from distributed import LocalCluster
            cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=None)
            extra = ["--scheduler", cluster.scheduler_address]
        out = os.path.join(d, f"kill-{how}.json")
        cmd = [sys.executable, "-m", "mprt", "explore", *scenes, "--res", f"{res}x{res}", "--budget", "800",
               "--json", out, *extra]
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=command_env())
        time.sleep(whole / 2)
        if how == "Dask":
            pids = [w.process.process.pid for w in cluster.workers.values() if getattr(w, "process", None)]
        else:
            pids = [int(x) for x in subprocess.run(["pgrep", "-P", str(p.pid)], capture_output=True,
                                                     text=True).stdout.split()]
        killed = pids[0] if pids else None
        if killed:
            os.kill(killed, signal.SIGKILL)
        _, err = p.communicate()
        s = time.perf_counter() - t0
        if cluster is not None:
            cluster.close()
        with open(out) as f:
            rep = json.load(f)
        said = [ln for ln in err.splitlines() if ln.startswith("worker")]
        rows.append((how, killed or "-", f"{s:.1f}", _same(ref, rep), said[0][:120] if said else "-"))
    return (f"{', '.join(scenes)} at {res}x{res} under 800 kGE; a run with two workers took {whole:.1f} s; one "
            f"worker killed at {whole / 2:.1f} s.\n\n"
            + table(rows, ("workers", "pid killed", "seconds", "same answer", "what it said")))


def part_resume(d, res):
    scenes = ["balls", "gears", "tetra"]
    whole, ref, _ = explore(scenes, res, os.path.join(d, "whole.json"))
    cache = os.path.join(d, "cache")
    cmd = [sys.executable, "-m", "mprt", "explore", *scenes, "--res", f"{res}x{res}", "--budget", "800", "--cache",
           cache, "--json", os.path.join(d, "killed.json")]
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=command_env(),
                         start_new_session=True)
    time.sleep(whole / 2)
    os.killpg(p.pid, signal.SIGKILL)
    p.wait()
    s, rep, _ = explore(scenes, res, os.path.join(d, "resumed.json"), "--cache", cache)
    ev = rep["evaluations"]
    share = ev["reused_from_cache"] / max(ev["reused_from_cache"] + ev["replayed"], 1)
    return (f"{', '.join(scenes)} at {res}x{res}: killed (SIGKILL) after {whole / 2:.1f} s of a {whole:.1f} s run, "
            f"then run again with the same --cache: {s:.1f} s, {100 * share:.0f}% of the evaluations from the "
            f"cache; the same answer as the run never killed: {_same(ref, rep)}.")


def part_memory(d, res=None):
    rows = []
    for r in (4096, 8192):
        t0 = time.perf_counter()
        p = subprocess.run(["/usr/bin/time", "-f", "%M", sys.executable, "-m", "mprt", "explore", "balls", "--res",
                            f"{r}x{r}", "--budget", "800"], capture_output=True, text=True, env=command_env())
        s = time.perf_counter() - t0
        peak = int(p.stderr.strip().splitlines()[-1]) / 1024
        said = [ln for ln in p.stderr.splitlines() if "error" in ln][-1:] or ["(answered)"]
        rows.append((f"{r}x{r}", p.returncode, f"{s:.1f}", f"{peak:.0f}", said[0][:200]))
    return table(rows, ("frame", "exit", "seconds", "peak MB", "what it said"))


def _phases(stderr: str) -> list:
    """(phase, estimate s or None, seconds) of each phase of an explore's stderr."""
    import re

    def secs(text):
        m = re.search(r"about ([0-9.]+) (s|min)", text)
        if m:
            return float(m.group(1)) * (60 if m.group(2) == "min" else 1)
        return 0.5 if "under a second" in text else None
    out, est, search = [], {}, None
    for ln in stderr.splitlines():
        m = re.match(r"phase \d+/\d+: (\w[\w ]*?)(:|,|$)", ln)
        if m and ": done in " not in ln and ln.startswith("phase"):
            name = m.group(1).strip()
            est[name] = secs(ln)
            if name == "search":
                search = name
            continue
        m = re.match(r"phase \d+/\d+: (\w[\w ]*?): .*: done in ([0-9.]+) s", ln)
        if m:
            out.append((m.group(1).strip(), est.get(m.group(1).strip()), float(m.group(2))))
            continue
        m = re.match(r"search  done in ([0-9.]+) s", ln)
        if m and search:
            out.append(("search", est.get("search"), float(m.group(1))))
    return out


def part_estimates(d, res=512):
    runs = [(f"explore {n} --res 512x512 --budget 800", [n, "--res", "512x512", "--budget", "800"]) for n in SPD6]
    runs.append(("make demo's command (six scenes at 32x32)", SPD6 + ["--res", "32x32", "--budget", "800"]))
    rows, worst = [], 1.0
    for label, args in runs:
        _, p = mprt("explore", *args)
        for name, est, took in _phases(p.stderr):
            ratio = None if est is None else max(est / max(took, 0.05), max(took, 0.05) / est)
            if ratio is not None and took >= 1.0:
                worst = max(worst, ratio)
            rows.append((label, name, "-" if est is None else f"{est:.0f}", f"{took:.1f}",
                         "-" if ratio is None else f"{ratio:.1f}"))
    return (f"Each phase's estimate against its time (the larger over the smaller; phases under a second "
            f"aside): at most {worst:.1f}x.\n\n" + table(rows, ("run", "phase", "estimate s", "took s", "ratio")))


def quick(out):
    """A small workload, answered at level 1 on the test space: the answer and its table."""
    from mprt.explore.explorer import FidelitySettings, SearchSettings, explore as run
    from mprt.explore.space import load_space
    from mprt.explore.workload import workload_of

    sp = load_space(os.path.join(ROOT, "tests", "data", "explore", "small_space.toml"))
    res = run(workload_of(["tetra:1", "balls:1"]).with_defaults(res=(16, 16)), sp,
              SearchSettings(budget=400, max_evals=40), FidelitySettings(level=1))
    rows = [(r["scene"], "x".join(map(str, r["subdivision"])), f"{r['cycles']:,.0f}", x(r["speedup"]),
             f"{r['sharing']:.3f}") for r in res.per_scene]
    text = (f"{res.best['described']} ({res.best['cost']:.0f} kGE)\n\n"
            + table(rows, ("scene", "subdivision", "cycles", "x 3MPPE", "sharing")) + "\n")
    with open(os.path.join(out, "quick.md"), "w") as f:
        f.write(text)
    print(text)


def main(argv=None):
    a, out = study_args(__file__, __doc__.split("\n\n")[0], "tetra:1 and balls:1 at 16x16, level 1", argv,
                        extra=lambda ap: (ap.add_argument("--part", nargs="*", choices=PARTS, default=list(PARTS)),
                                          ap.add_argument("--res", type=int, default=512),
                                          ap.add_argument("--res2", type=int, default=256)))
    if a.quick:
        quick(out)
        return 0
    with tempfile.TemporaryDirectory() as d:
        wrep = None
        for part in a.part:
            t0 = time.perf_counter()
            if part == "workload":
                text, wrep = part_workload(d, a.res)
            elif part == "per_scene":
                text = part_per_scene(d, a.res2)
            else:
                text = globals()[f"part_{part}"](d, a.res2)
            text += f"\n\n({part}: {time.perf_counter() - t0:.0f} s)\n"
            print(f"## {part}\n\n{text}", flush=True)
            with open(os.path.join(out, f"{part}.md"), "w") as f:
                f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
