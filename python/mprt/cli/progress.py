"""No silent long work: phase lines and clock-driven progress on stderr.

A long step that is one call (a compiled replay, a batch of evaluations in worker
processes, a task on a Dask scheduler) cannot count its own progress, so its bar
follows the clock against an estimate made before it starts; without an estimate,
a spinner shows the time spent.  On a terminal the bar (tqdm, the project's
progress library) is redrawn in place; elsewhere (a log, a pipe, a test) only one
line starts each phase and one ends it, so logs stay short::

    from mprt.progress import Phases
    phases = Phases(3, "explore")                 # numbered "phase k/3"
    with phases.step("search", estimate=12.0):    # "phase 1/3: search, about 12 s"
        ...                                       # bar or spinner on a terminal
                                                  # "phase 1/3: search: done in 11.4 s"

``step`` without ``Phases`` (``clock_step``) prints the same lines, unnumbered.
"""
from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

BAR_AFTER = 1.0          # seconds: a step estimated (or running) longer than this gets a bar
TICK = 0.2               # seconds between redraws


def eta_text(seconds) -> str:
    """'about 12 s', 'about 3.5 min', or '' without an estimate."""
    if seconds is None:
        return ""
    if seconds < 90:
        return f"about {seconds:.0f} s" if seconds >= 1 else "under a second"
    return f"about {seconds / 60:.1f} min"


def _is_tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


@contextmanager
def clock_step(label: str, estimate: float | None = None, stream=None, clock=time.perf_counter, tty=None):
    """A step of unknown inner progress: its start line (with the estimate), a tqdm bar of
    seconds against ``estimate`` (a spinner of elapsed seconds without one) redrawn on a
    terminal, and its end line with the time taken.  The step's work runs in the caller's
    thread; a daemon thread only redraws."""
    stream = stream or sys.stderr
    tty = _is_tty(stream) if tty is None else tty
    eta = eta_text(estimate)
    print(f"{label}" + (f", {eta}" if eta else ""), file=stream, flush=True)
    t0 = clock()
    stop = threading.Event()
    drawer = None
    if tty:
        from tqdm import tqdm

        total = round(estimate, 1) if estimate and estimate >= BAR_AFTER else None
        desc = label if len(label) <= 48 else label[:47] + "…"
        bar = tqdm(total=total, unit="s", desc=desc, leave=False, file=stream,
                   bar_format=("{desc} {bar:24} {n:.0f} of about {total:.0f} s" if total else
                               "{desc}: {n:.0f} s elapsed"))

        def draw():
            while not stop.wait(TICK):
                spent = clock() - t0
                bar.n = min(spent, total) if total else spent
                if total and spent > total:
                    bar.total = round(spent + 1)
                bar.refresh()
            bar.close()

        drawer = threading.Thread(target=draw, daemon=True)
        drawer.start()
    ok = False
    try:
        yield
        ok = True
    finally:
        stop.set()
        if drawer is not None:
            drawer.join()
        spent = clock() - t0
        print(f"{label}: {'done' if ok else 'stopped'} in {spent:.1f} s", file=stream, flush=True)


class Phases:
    """Numbered phases of one command: ``step(name, estimate)`` as ``clock_step`` with
    "phase k/n" in front, ``line(text)`` a numbered line for a phase that draws its own
    progress (a count of evaluations)."""

    def __init__(self, n: int, stream=None, clock=time.perf_counter, tty=None):
        self.n, self.k = n, 0
        self.stream, self.clock, self.tty = stream or sys.stderr, clock, tty

    def _next(self, name: str) -> str:
        self.k += 1
        return f"phase {self.k}/{max(self.n, self.k)}: {name}"

    def step(self, name: str, estimate: float | None = None):
        return clock_step(self._next(name), estimate, self.stream, self.clock, self.tty)

    def line(self, name: str, estimate: float | None = None) -> None:
        eta = eta_text(estimate)
        print(self._next(name) + (f", {eta}" if eta else ""), file=self.stream, flush=True)


def rate_estimate(seconds: float, done: float, total: float) -> float | None:
    """The time ``total`` units take at the rate of ``done`` units in ``seconds``."""
    if done <= 0 or seconds <= 0:
        return None
    return seconds / done * total
