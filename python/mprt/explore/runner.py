"""Where the explorer's evaluations run: this process, a pool of local worker processes, or a
Dask cluster, with every result kept in an optional disk cache.

An evaluation task is one scene at one resolution, subdivision and level, and a batch of
machines (designs or machine configurations) to replay on that trace.  Its result depends
only on the task, so the answer is the same wherever and however many times it runs:

- ``workers <= 1``: in this process, in order;
- ``workers = N``: N processes forked from this one after the scenes are loaded; a task goes to
  the worker that already holds its trace where it can (each worker traces a grid once and keeps
  it), and a worker that dies has its tasks run again by the others, with one line saying so;
- ``scheduler``: tasks on a Dask cluster (Dask runs a dead worker's tasks again).  The workers
  load the scenes themselves: an NFF path must be readable there.

``cache`` (``DiskCache``): each machine's result on a trace is kept under a key of what makes
it: the mprt version, the scene's content hash and trace settings, the resolution,
subdivision and level, the unit costs and the machine; a run that finds it there does not run
it again (a killed exploration resumes), and an entry made by another version is never used.
"""
from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass

import numpy as np

from .evaluate import Result

_SCENES: dict = {}          # scene hash -> Scene (set before the fork; loaded on demand in a Dask worker)
_HELD: dict = {}            # in a worker: evaluator key -> SceneEvaluator (most recent last)
HELD_EVALUATORS = 64
HELD_VISITS = 24_000_000    # visits of the traces the evaluators of a process hold, at most (the latest kept)


@dataclass(frozen=True)
class Task:
    """One scene's trace at one setting and the machines to replay on it."""
    entry: object              # workload.SceneEntry
    scene_hash: str
    width: int
    height: int
    dims: tuple
    level: int
    machines: tuple            # Design or SystemConfig, each
    unit_costs: object = None  # hwcost.UnitCosts
    max_visits: int = 8_000_000
    sample: str | None = None  # trace only these tiles and scale (``SceneEvaluator``'s sample)

    def trace_key(self) -> tuple:
        return (self.scene_hash, repr(self.entry.trace_options()), self.width, self.height, tuple(self.dims),
                self.sample)


def register_scene(scene_hash: str, scene) -> None:
    """A scene this process loaded, for the tasks (and forked workers) that name its hash."""
    _SCENES[scene_hash] = scene


def _scene(task: Task):
    s = _SCENES.get(task.scene_hash)
    if s is None:                       # a Dask worker: load it, and check it is the scene meant
        s = task.entry.load()
        if s.content_hash() != task.scene_hash:
            from ..errors import MprtError
            raise MprtError(f"{task.entry.name}: the scene read on this worker differs from the one explored "
                            f"(content hash {s.content_hash()[:12]} against {task.scene_hash[:12]})")
        _SCENES[task.scene_hash] = s
    return s


def _evaluator(task: Task):
    from .evaluate import SceneEvaluator

    opts = task.entry.trace_options()
    key = (task.scene_hash, repr(opts), task.width, task.height, repr(task.unit_costs), task.max_visits, task.sample)
    ev = _HELD.pop(key, None)
    if ev is None:
        while len(_HELD) >= HELD_EVALUATORS:
            _HELD.pop(next(iter(_HELD)))
        ev = SceneEvaluator(_scene(task), task.width, task.height, level=task.level, shape="cube",
                            unit_costs=task.unit_costs, max_visits=task.max_visits, sample=task.sample, **opts)
    _HELD[key] = ev
    return ev


def portable(task: Task) -> Task:
    """The task as it crosses to another process: a machine configuration as its machine file's
    text (a configuration holds read-only mappings, which do not pickle), a design as it is."""
    from ..machine.config import SystemConfig, config_toml

    ms = tuple(("machine file", config_toml(m)) if isinstance(m, SystemConfig) else m for m in task.machines)
    return Task(**{**task.__dict__, "machines": ms})


def _machine(m):
    if isinstance(m, tuple) and len(m) == 2 and m[0] == "machine file":
        return config_of_text(m[1])
    return m


def config_of_text(text: str):
    """The SystemConfig of a machine file's text (the last few read, kept)."""
    import tomllib

    from ..machine.config import config_from_dict

    got = _CONFIGS.get(text)
    if got is None:
        if len(_CONFIGS) > 256:
            _CONFIGS.clear()
        got = _CONFIGS[text] = config_from_dict(tomllib.loads(text), source="machine")
    return got


_CONFIGS: dict = {}


def run_task(task: Task) -> list:
    """The task's results (``Result.to_dict()`` each, in the order of its machines)."""
    from .space import Point

    ev = _evaluator(task)
    t0, traced = time.perf_counter(), ev.trace_seconds
    rows = [ev.run(Point(tuple(task.dims), _machine(m)), task.level).to_dict() for m in task.machines]
    _trim()
    spent = ev.trace_seconds - traced
    held = ev._held.get(tuple(task.dims))
    return {"rows": rows, "trace_seconds": spent, "traced": spent > 0,
            "replay_seconds": time.perf_counter() - t0 - spent, "visits": held[0].visits if held else 0}


def _trim() -> None:
    """Let go of the least recent evaluators' traces while those held pass HELD_VISITS."""
    def visits(ev):
        return sum(e.visits for e, _ in ev._held.values())
    total = sum(visits(ev) for ev in _HELD.values())
    for key in list(_HELD)[:-1]:
        if total <= HELD_VISITS:
            break
        total -= visits(_HELD.pop(key))


def machine_key(machine) -> str:
    """A machine's identity for the cache: a design's fields, or a configuration's."""
    import json

    from .space import Design

    if isinstance(machine, Design):
        return "design:" + machine.key()
    return "config:" + json.dumps(machine.to_dict() | {"source": None}, sort_keys=True, default=str)


class Runner:
    """Runs tasks here, on local workers or on Dask, through the cache; counts what it did."""

    def __init__(self, workers: int | None = 1, client=None, cache=None, say=None):
        self.workers = 1 if client is None and (workers or 0) <= 1 else (workers or 0)
        self.client = client
        self.cache = cache
        self.say = say or (lambda text: None)
        self.pool = LocalPool(self.workers, self.say) if client is None and self.workers > 1 else None
        self.reused = 0             # machine results found in the cache (put there by an earlier run)
        self._made: set = set()     # cache keys this run put there
        self.repeated = 0           # machine results asked for again in this run (found where it put them)
        self.ran = 0                # machine results computed
        self.seconds = 0.0
        self.traces = 0             # traces made (by whichever process ran the task)
        self.trace_seconds = 0.0    # their seconds, summed over the processes
        self.replay_seconds = {}    # level -> (replays, seconds), summed over the processes
        self.replay_visits = {}     # level -> (visits replayed, seconds)
        self.trace_samples = []     # (voxels, visits, seconds) of each trace made
        self.visits = {}            # trace key -> its visits (what each trace held)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()

    def _key(self, task: Task, machine) -> str:
        from ..settings import version
        from .distributed import cache_key

        return cache_key("evaluation", version(), task.trace_key(), task.level, repr(task.unit_costs),
                         machine_key(machine))

    def run(self, tasks: list) -> list:
        """Each task's results (lists of Result, in the order of its machines)."""
        t0 = time.perf_counter()
        out = [[None] * len(t.machines) for t in tasks]
        todo = []                   # (task index, machine indices to run)
        for i, t in enumerate(tasks):
            miss = []
            for j, m in enumerate(t.machines):
                key = self._key(t, m) if self.cache is not None else None
                hit = self.cache.get(key) if key is not None else None
                if hit is not None:
                    out[i][j] = Result.from_dict(hit)
                    if key in self._made:      # (what this run put there itself, asked for again)
                        self.repeated += 1
                    else:
                        self.reused += 1
                else:
                    miss.append(j)
            if miss:
                todo.append((i, miss))
        sub = [Task(**{**tasks[i].__dict__, "machines": tuple(tasks[i].machines[j] for j in miss)})
               for i, miss in todo]
        if sub:
            if self.client is not None:
                got = self._dask(sub)
            elif self.pool is not None:
                got = self.pool.run(sub)
            else:
                got = [run_task(t) for t in sub]
            for (i, miss), done in zip(todo, got):
                rows = done["rows"]
                self.traces += bool(done["traced"])
                self.trace_seconds += done["trace_seconds"]
                n, secs = self.replay_seconds.get(tasks[i].level, (0, 0.0))
                self.replay_seconds[tasks[i].level] = (n + len(rows), secs + done["replay_seconds"])
                v = done.get("visits", 0)
                self.visits[tasks[i].trace_key()] = v
                if done["traced"]:
                    self.trace_samples.append((float(np.prod(tasks[i].dims)), float(v), done["trace_seconds"]))
                nv, sv = self.replay_visits.get(tasks[i].level, (0.0, 0.0))
                self.replay_visits[tasks[i].level] = (nv + v * len(rows), sv + done["replay_seconds"])
                for j, row in zip(miss, rows):
                    out[i][j] = Result.from_dict(row)
                    if self.cache is not None:
                        key = self._key(tasks[i], tasks[i].machines[j])
                        self.cache.put(key, row)
                        self._made.add(key)
                    self.ran += 1
        self.seconds += time.perf_counter() - t0
        return out

    def per_trace(self) -> float | None:
        """Mean seconds of a trace made so far (None: none made)."""
        return self.trace_seconds / self.traces if self.traces else None

    def trace_time(self, voxels: float, visits: float) -> float | None:
        """A trace's seconds from those made so far: a least-squares fit (non-negative) of their
        seconds on their grids' voxels (the grid's build) and their visits (the rays' walk)."""
        from scipy.optimize import nnls

        if not self.trace_samples:
            return None
        a = np.array([(vox, vis) for vox, vis, _ in self.trace_samples])
        b = np.array([t for _, _, t in self.trace_samples])
        scale = np.maximum(a.max(axis=0), 1.0)
        coef, _ = nnls(a / scale, b)
        coef = coef / scale
        if not coef.any():
            return self.per_trace()
        return float(coef[0] * voxels + coef[1] * visits)

    def replay_time(self, level: int, visits: float) -> float | None:
        """One machine's replay of ``visits`` visits at a level, at the rate measured so far."""
        nv, secs = self.replay_visits.get(level, (0.0, 0.0))
        return secs / nv * visits if nv else None

    def per_replay(self, level: int) -> float | None:
        """Mean seconds of one machine's replay at a level so far (None: none)."""
        n, secs = self.replay_seconds.get(level, (0, 0.0))
        return secs / n if n else None

    def _dask(self, tasks: list) -> list:
        futures = [self.client.submit(run_task, portable(t), pure=False) for t in tasks]
        return self.client.gather(futures)


def _worker_main(conn) -> None:
    """A forked worker: run tasks from ``conn`` until it closes; Ctrl-C is the parent's to handle."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        n, task = msg
        try:
            conn.send((n, True, run_task(task)))
        except BaseException as e:          # (sent back: the parent raises it)
            try:
                conn.send((n, False, e))
            except Exception:
                conn.send((n, False, RuntimeError(f"{type(e).__name__}: {e}")))


class WorkerDied(RuntimeError):
    pass


class LocalPool:
    """``n`` forked worker processes, each fed over a pipe.  A task goes to an idle worker that
    holds its trace (one that ran a task of the same trace before), else to any idle one; a
    worker that dies is replaced and its task given to another, with one line said."""

    def __init__(self, n: int, say):
        self.n, self.say = n, say
        self.procs: list = []
        self.holds: list = []       # per worker: the trace keys it has been given
        self.restarts = 0

    def _start(self, k: int | None = None):
        import multiprocessing

        ctx = multiprocessing.get_context("fork")
        parent, child = ctx.Pipe()
        from .distributed import sigint_blocked

        p = ctx.Process(target=_worker_main, args=(child,), daemon=True, name="mprt-explore-worker")
        with sigint_blocked():          # (until the worker ignores it: Ctrl-C is the explorer's)
            p.start()
        child.close()
        if k is None:
            self.procs.append((p, parent))
            self.holds.append(set())
        else:
            self.procs[k] = (p, parent)
            self.holds[k] = set()

    def run(self, tasks: list) -> list:
        from multiprocessing.connection import wait

        while len(self.procs) < min(self.n, max(len(tasks), 1)):
            self._start()
        out = [None] * len(tasks)
        pending = list(range(len(tasks)))
        busy: dict = {}              # worker -> task index
        while pending or busy:
            for k in range(len(self.procs)):
                if k in busy or not pending:
                    continue
                tk = [tasks[i].trace_key() for i in pending]
                pick = next((j for j, key in enumerate(tk) if key in self.holds[k]), None)
                if pick is None:      # a trace no idle worker holds, or the first pending
                    free_holds = set().union(*(self.holds[w] for w in range(len(self.procs)) if w not in busy
                                               and w != k))
                    pick = next((j for j, key in enumerate(tk) if key not in free_holds), 0)
                i = pending.pop(pick)
                self.holds[k].add(tasks[i].trace_key())
                busy[k] = i
                self.procs[k][1].send((i, portable(tasks[i])))
            conns = {self.procs[k][1]: k for k in busy}
            sentinels = {self.procs[k][0].sentinel: k for k in busy}
            for ready in wait(list(conns) + list(sentinels)):
                k = conns.get(ready, sentinels.get(ready))
                if k not in busy:
                    continue
                p, conn = self.procs[k]
                try:
                    if ready is p.sentinel and not conn.poll():
                        raise EOFError
                    n, ok, value = conn.recv()
                except (EOFError, OSError):
                    i = busy.pop(k)
                    code = p.exitcode if p.exitcode is not None else p.join(1) or p.exitcode
                    self.restarts += 1
                    if self.restarts > 4 * self.n + 8:
                        raise WorkerDied(f"explore: local workers keep dying ({self.restarts} so far; the last "
                                         f"exit status {code}): is the machine out of memory?") from None
                    self.say(f"worker  process {p.pid} ended (exit status {code}) with a task of "
                             f"{tasks[i].entry.name} at {'x'.join(map(str, tasks[i].dims))}; it runs again on "
                             f"a new worker")
                    self._start(k)
                    pending.insert(0, i)
                    continue
                busy.pop(k)
                if not ok:
                    raise value
                out[n] = value
        return out

    def close(self) -> None:
        for p, conn in self.procs:
            try:
                conn.send(None)
            except (OSError, ValueError):
                pass
        for p, conn in self.procs:
            p.join(2)
            if p.is_alive():
                p.terminate()
                p.join(2)
            conn.close()
        self.procs.clear()


def default_workers() -> int:
    """One worker per core."""
    return max(os.cpu_count() or 1, 1)


__all__ = ["LocalPool", "Runner", "Task", "config_of_text", "default_workers", "machine_key", "register_scene", "run_task"]
