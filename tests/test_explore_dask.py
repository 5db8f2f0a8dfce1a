"""Sweeps on Dask: a scheduler and two workers started as separate processes on 127.0.0.1."""
import csv
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mprt.explore.cli import add_parsers

SPEC = Path(__file__).parent / "data" / "explore" / "sweep.toml"


def _run(*argv):
    import argparse
    p = argparse.ArgumentParser(prog="mprt")
    add_parsers(p.add_subparsers(dest="cmd", required=True))
    a = p.parse_args(list(argv))
    return a.func(a)


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory):
    d = tmp_path_factory.mktemp("dask")
    sfile = d / "scheduler.json"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(sfile)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)]
    try:
        t0 = time.time()
        while not sfile.exists() and time.time() - t0 < 30:
            time.sleep(0.1)
        assert sfile.exists(), "the scheduler did not start"
        for _ in range(2):
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(sfile),
                 "--nworkers", "1", "--nthreads", "1", "--host", "127.0.0.1", "--no-dashboard"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env))
        from distributed import Client
        with Client(scheduler_file=str(sfile), timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
            assert len(c.scheduler_info()["workers"]) == 2
            address = c.scheduler.address
        assert address.startswith("tcp://127.0.0.1:")
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_sweep_two_workers_equals_in_process_and_resumes(scheduler, tmp_path, capsys):
    remote, local = tmp_path / "remote", tmp_path / "local"
    assert _run("sweep", str(SPEC), "--out", str(remote), "--scheduler", scheduler) == 0
    assert _run("sweep", str(SPEC), "--out", str(local), "--workers", "0") == 0
    a, b = _rows(remote / "sweep.csv"), _rows(local / "sweep.csv")
    assert len(a) == 2 * 2 * 3 and a == b                    # same table whatever ran it
    assert (remote / "sweep.png").stat().st_size > 0
    # a repeated run takes everything from the cache
    capsys.readouterr()
    assert _run("sweep", str(SPEC), "--out", str(remote), "--scheduler", scheduler) == 0
    assert "(8 from the cache)" in capsys.readouterr().out
    # an interrupted run (here: two finished batches lost) recomputes only what is missing
    files = sorted((remote / "cache").rglob("*.json"))
    assert len(files) == 8
    for f in files[:2]:
        f.unlink()
    assert _run("sweep", str(SPEC), "--out", str(remote), "--scheduler", scheduler) == 0
    assert "(6 from the cache)" in capsys.readouterr().out
    assert _rows(remote / "sweep.csv") == b


def test_explore_through_scheduler(scheduler, tmp_path):
    out = tmp_path / "e.json"
    small = Path(__file__).parent / "data" / "explore" / "small_space.toml"
    assert _run("explore", "tetra:1", "--res", "16x16", "--space", str(small), "--budget", "400",
                "--json", str(out), "--scheduler", scheduler, "--max-evals", "30") == 0
    import json
    remote = json.loads(out.read_text())
    assert _run("explore", "tetra:1", "--res", "16x16", "--space", str(small), "--budget", "400",
                "--json", str(out), "--max-evals", "30") == 0
    here = json.loads(out.read_text())
    assert remote["best"] == here["best"] and remote["history"] == here["history"]
