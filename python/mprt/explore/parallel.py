"""Evaluations that do not depend on each other, on the machine's cores.

``Pool(scene, workers)`` runs batches of points (a polish neighbourhood, the
references, the full-resolution checks), the ladder's designs and the global
phase's starts in worker processes.  The workers are forked from the explorer
after the scene is loaded (a Scene holds C objects and does not pickle), so
they share it; each worker keeps its own ``SceneEvaluator`` per set of
evaluator settings (resolution, sample, unit costs, ...) and traces the grids
it is asked about itself.  Tracing, costing and replaying are deterministic,
and every result depends only on its point, its level and those settings, so
the answer is the same for any number of workers (a test compares 1 and 2).

A batch goes to the pool only when one of its evaluations runs on SimPy (the
engine ``fidelity.engine_for`` picks with "auto"): a compiled evaluation takes
milliseconds, less than sending it to a worker that may first have to trace
the grid.  The global phase's starts, each a search of its own, always go.
``workers`` <= 1 runs everything in this process, in the same order.

Ctrl-C at a terminal goes to every process of the foreground group: the workers are forked
with SIGINT blocked and then ignore it, so that only this process hears it; it ends the
workers at once (their tasks are not waited for) and the command says "interrupted" in one
line, with no worker's traceback.
"""
from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
from concurrent.futures import ProcessPoolExecutor, as_completed

_SHARED: dict = {}          # set before the fork: the scene every worker evaluates
_HELD: dict = {}            # in a worker: SceneEvaluator by its settings


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


def _deaf() -> None:
    """A worker's initializer: Ctrl-C is for the explorer's process, which ends the workers."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def default_workers() -> int:
    """One worker per core."""
    return max(os.cpu_count() or 1, 1)


def _evaluator(settings: dict):
    from .evaluate import SceneEvaluator

    key = repr(sorted((k, v) for k, v in settings.items() if k != "level"))   # run() is told the level
    if key not in _HELD:
        while len(_HELD) >= 2:                     # the search's resolution and the full one
            _HELD.pop(next(iter(_HELD)))
        _HELD[key] = SceneEvaluator(_SHARED["scene"], **settings)
    return _HELD[key]


def _run_points(settings: dict, points, level) -> list:
    ev = _evaluator(settings)
    return [ev.run(p, level) for p in points]


def _call(fn, settings: dict, args):
    return fn(_evaluator(settings), *args)


def _call_forked(fn, args):
    return fn(_SHARED["ev"], *args)


def uses_simpy(points, level: int, leaves: int = 1) -> bool:
    """Whether any of the points is evaluated on SimPy at the level (engine "auto")."""
    from ..fidelity import engine_for
    from .evaluate import machine_config
    from .space import Design

    if level == 0:
        return False
    for p in points:
        cfg = machine_config(p.design, leaves) if isinstance(p.design, Design) else p.design
        if engine_for(cfg, level) == "simpy":
            return True
    return False


def _order(ev, points) -> list:
    """Points grouped by grid, then by processors (each trace made and costed once)."""
    from .evaluate import grid_dims
    from .space import Design

    def key(i):
        p = points[i]
        return (grid_dims(ev.scene, p.subdivision, ev.shape), p.design.key() if isinstance(p.design, Design) else "")
    return sorted(range(len(points)), key=key)


class Pool:
    """Worker processes for one scene (``workers`` <= 1: none, everything here)."""

    def __init__(self, scene, workers: int | None = None):
        self.scene = scene
        self.workers = default_workers() if workers is None else max(int(workers), 1)
        self._pool = None
        self.before_fork = None     # called before the workers may fork (ends threads: SceneEvaluator.prefetch)

    def _executor(self) -> ProcessPoolExecutor:
        if self.before_fork is not None:
            self.before_fork()
        if self._pool is None:
            _SHARED["scene"] = self.scene
            ctx = multiprocessing.get_context("fork")
            self._pool = ProcessPoolExecutor(self.workers, mp_context=ctx, initializer=_deaf)
        return self._pool

    def _submit(self, fn, args_list) -> list:
        """The futures of ``fn(*args)`` for each args (the workers forked by the first, with
        SIGINT blocked: see ``sigint_blocked``)."""
        ex = self._executor()
        with sigint_blocked():
            return [ex.submit(fn, *args) for args in args_list]

    def run(self, ev, points, level: int | None = None) -> list:
        """``ev.run(p, level)`` for each point, in order (``ev`` a SceneEvaluator)."""
        points = list(points)
        level = ev.level if level is None else level
        order = _order(ev, points)
        out = [None] * len(points)
        if self.workers <= 1 or len(points) <= 1 or not uses_simpy(points, level):
            for i in order:
                out[i] = ev.run(points[i], level)
            return out
        # contiguous chunks of the grouped order: each worker sees few grids
        n = min(self.workers, len(points))
        chunks = [order[k * len(order) // n:(k + 1) * len(order) // n] for k in range(n)]
        futs = self._submit(_run_points, [(ev.settings(), [points[i] for i in c], level) for c in chunks])
        with self._ending_on_interrupt():
            for c, f in zip(chunks, futs):
                for i, r in zip(c, f.result()):
                    out[i] = r
        return out

    def map(self, fn, ev, args_list) -> list:
        """``fn(evaluator, *args)`` for each args, in order: in the workers (each on its own
        evaluator with ``ev``'s settings) or, with one worker, here on ``ev`` itself.
        ``fn`` must be a module-level function (it is pickled by name)."""
        args_list = list(args_list)
        if self.workers <= 1 or len(args_list) <= 1:
            return [fn(ev, *a) for a in args_list]
        futs = self._submit(_call, [(fn, ev.settings(), a) for a in args_list])
        with self._ending_on_interrupt():
            return [f.result() for f in futs]

    def map_forked(self, fn, ev, args_list, idle=None) -> list:
        """``map``, but on workers forked now from this process that evaluate on ``ev`` itself
        as it stands (its traces made, their costs and memory data computed: copies, not an
        evaluator of their own to build again from its settings); for long tasks on an
        evaluator that has done most of its work (the polish's walks on the search's traces).
        The workers are shut down after, so the next batch forks its own.  ``idle`` (called
        here, in this process's thread, after the fork): told the results so far ({index:
        result}) whenever a worker has no task left to take, i.e. once at the start where there
        are fewer tasks than workers, then at each task's end while fewer are left than
        workers: this process may use that core meanwhile (``SceneEvaluator.prefetch``); it
        must not fork, and it changes no result."""
        args_list = list(args_list)
        if self.workers <= 1 or len(args_list) <= 1:
            return [fn(ev, *a) for a in args_list]
        self.close()
        _SHARED["ev"] = ev
        try:
            futs = self._submit(_call_forked, [(fn, a) for a in args_list])
            with self._ending_on_interrupt():
                if idle is not None:
                    where, got = {f: i for i, f in enumerate(futs)}, {}
                    if len(futs) < self.workers:
                        idle({})
                    for f in as_completed(futs):
                        got[where[f]] = f.result()
                        if len(futs) - len(got) < self.workers:
                            idle(dict(got))
                return [f.result() for f in futs]
        finally:
            self.close()

    @contextlib.contextmanager
    def _ending_on_interrupt(self):
        """Ctrl-C (KeyboardInterrupt) in the block ends the workers at once (``stop``)."""
        try:
            yield
        except KeyboardInterrupt:
            self.stop()
            raise

    def stop(self) -> None:
        """End the workers now, their tasks not waited for (after Ctrl-C), then ``close``."""
        if self._pool is not None:
            for proc in list((getattr(self._pool, "_processes", None) or {}).values()):
                with contextlib.suppress(OSError, ValueError, AttributeError):
                    proc.terminate()
        self.close()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None
            _SHARED.pop("scene", None)
            _SHARED.pop("ev", None)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
