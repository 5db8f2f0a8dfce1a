"""Running evaluations on Dask, with results cached on disk.

A batch of designs on one trace is one task (a Dask task costs about a
millisecond of overhead, a level-0 evaluation less).  The cache key of a
batch is a hash of what made its trace (scene content, grid, resolution,
rules) and of the designs and level, so a finished batch is never run again:
an interrupted sweep resumes, a repeated one is instant.  Each batch's result
depends only on its inputs, so the table is the same whatever the number of
workers.

Ctrl-C at a terminal goes to every process of the foreground group: a local cluster's
processes are started with SIGINT blocked (they inherit the mask: ``sigint_blocked``),
so that only this process hears it, and it then closes the cluster with Dask's logging
silenced: one line ("interrupted", from the command), no worker's traceback.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import signal

from ..util.atomic import open_replacing

CACHE_VERSION = 1


@contextlib.contextmanager
def sigint_blocked(spawn: bool = False):
    """SIGINT blocked in this thread for the block (where the platform can): processes forked or
    spawned and threads started meanwhile inherit the mask, so a Ctrl-C at the terminal does
    not reach them; one that comes during the block is delivered at its end.  ``spawn``: the
    processes are spawned (multiprocessing's resource tracker, started by the first of them,
    would unblock SIGINT in this thread: it is started first)."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    if spawn:
        from multiprocessing import resource_tracker

        resource_tracker.ensure_running()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def cache_key(*parts) -> str:
    text = json.dumps([CACHE_VERSION, *parts], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


class DiskCache:
    """JSON values in files named by key; writes are atomic (rename), so a
    run stopped mid-write leaves no partial entry."""

    def __init__(self, directory):
        self.dir = os.fspath(directory)
        os.makedirs(self.dir, exist_ok=True)

    def _path(self, key):
        return os.path.join(self.dir, key[:2], key + ".json")

    def get(self, key):
        try:
            with open(self._path(key)) as f:
                return json.load(f)
        except (OSError, ValueError):
            return None

    def put(self, key, value) -> None:
        p = self._path(key)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open_replacing(p) as f:
            json.dump(value, f)


QUIET = logging.CRITICAL + 1


def silence_dask() -> None:
    """No more of Dask's logging in this process (its cancellations and closing connections,
    logged while a cluster is shut down after an interrupt)."""
    for name in ("distributed", "tornado", "asyncio"):
        logging.getLogger(name).setLevel(QUIET)


@contextlib.contextmanager
def client(scheduler: str | None = None, workers: int | None = None):
    """A Dask client: of the scheduler at ``scheduler``, or of a LocalCluster
    of ``workers`` processes (default one per core) listening on 127.0.0.1
    only.  ``workers=0`` yields None: run in this process."""
    if scheduler is None and workers == 0:
        yield None
        return
    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    cl = c = None
    try:
        if scheduler:
            c = Client(scheduler, timeout="20s")
        else:
            n = workers or os.cpu_count() or 1
            with sigint_blocked(spawn=True):    # the cluster's processes and threads: deaf to Ctrl-C
                cl = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None, silence_logs=logging.ERROR)
            c = Client(cl)
        yield c
    except KeyboardInterrupt:
        silence_dask()
        raise
    finally:
        with contextlib.ExitStack() as closing:    # the client first, then the cluster, each whatever the other does
            if cl is not None:
                closing.callback(cl.close)
            if c is not None:
                closing.callback(c.close)


def run_remote(scheduler: str, fn, *args):
    """Run ``fn(*args)`` as one task on the scheduler's cluster."""
    with client(scheduler) as c:
        return c.submit(fn, *args, pure=False).result()


def map_cached(tasks, fn, cache: DiskCache | None, dask_client=None, on_done=None) -> list:
    """``fn(*args)`` for each (key, args) in ``tasks``, in order; results
    already in ``cache`` are not recomputed, new ones are stored as each
    task finishes.  Returns the results and how many came from the cache.
    ``on_done(done, total)`` is called once before the first task (done 0) and
    after each: ``total`` is the tasks to run (those not in the cache)."""
    out = [None] * len(tasks)
    todo = []
    for i, (key, args) in enumerate(tasks):
        hit = cache.get(key) if cache else None
        if hit is not None:
            out[i] = hit
        else:
            todo.append(i)
    cached = len(tasks) - len(todo)
    done = 0
    if on_done:
        on_done(0, len(todo))
    if dask_client is None:
        for i in todo:
            out[i] = fn(*tasks[i][1])
            if cache:
                cache.put(tasks[i][0], out[i])
            done += 1
            if on_done:
                on_done(done, len(todo))
    elif todo:
        from distributed import as_completed

        futs = {dask_client.submit(fn, *tasks[i][1], key=f"mprt-{tasks[i][0][:24]}", pure=False): i for i in todo}
        for fut in as_completed(futs):
            i = futs[fut]
            out[i] = fut.result()
            if cache:
                cache.put(tasks[i][0], out[i])
            done += 1
            if on_done:
                on_done(done, len(todo))
    return out, cached
