"""The explorer's estimates of its phases' times, before each phase starts, from what its runner
has timed so far (``Runner.trace_time``: a trace's seconds fitted on its grid's voxels and its
visits; ``Runner.replay_time``: a replay's seconds per visit at a level).  None before anything
ran.  The explorer tells them with each phase's line (``mprt.cli.progress.Phases``); the study
``studies/21_workload`` (part ``estimates``) sets each against the time the phase took."""
from __future__ import annotations

import numpy as np

DESCENT_EVALS = 16         # grids a subdivision's descent tries, about
TYPICAL_SEARCH = 180       # machines DIRECT-L and the polish replay at the level on the built-in space


class Estimates:
    """The estimates, mixed into the explorer (they read its scenes, settings and runner)."""

    def _est_descents(self, lv: int, scale: float = 1.0, traces: int = DESCENT_EVALS) -> float | None:
        """Descents of every scene's subdivision: ``traces`` grids each, traced and replayed, at
        ``scale`` times the low resolution's pixels."""
        t, r = self.runner.per_trace(), self.runner.per_replay(lv)
        if t is None or r is None:
            return None
        return len(self.scenes) * traces * (t * scale + r * scale)

    def _est_ladder(self, trace: float, per_design: float, starts, designs: int) -> float:
        """The ladder: each scene's trace at its start (the first scene's ``trace`` seconds, scaled
        by the square root of each one's pixels or voxels over the first's) and its designs at
        every level (``per_design`` seconds, the first design's on the first scene, so scaled)."""
        s0 = self.scenes[0]
        out = 0.0
        for k, (s, st) in enumerate(zip(self.scenes, starts)):
            size = (s.low[0] * s.low[1]) / (s0.low[0] * s0.low[1])
            grid = float(np.prod(st)) / max(float(np.prod(starts[0])), 1.0)
            scale = max(size, grid) ** 0.5
            out += (trace * scale if k else 0.0) + designs * per_design * size
        return out

    def _est_search(self, hw, lv: int) -> float | None:
        """The search (every machine of a small space, else about TYPICAL_SEARCH: DIRECT-L stops once
        idle long before ``max_evals`` on a lattice), each on every scene, the scenes spread over
        the workers; then each scene's subdivision again and a short polish."""
        r = self.runner.per_replay(lv)
        if r is None:
            return None
        n = self.distinct(hw)
        free = sum(v.size > 1 for v in hw.variables)
        machines = n if n is not None and n <= self.opts.exhaustive else min(self.opts.max_evals, TYPICAL_SEARCH)
        parallel = min(max(self.runner.workers, 1), len(self.scenes))
        search = (machines + 4 * free) * len(self.scenes) * r / parallel
        return search + (self._est_descents(lv, traces=DESCENT_EVALS // 2) or 0.0)

    def _frame(self, s, dims=None) -> tuple:
        """(voxels, visits of the whole frame, of a probe) of scene ``s`` at ``dims`` (default its
        search's): the low-resolution trace's visits scaled by the pixels."""
        dims = tuple(dims or s.dims)
        low = self.runner.visits.get((s.hash, repr(s.entry.trace_options()), s.low[0], s.low[1], dims, None))
        if low is None:
            low = max([v for k, v in self.runner.visits.items() if k[0] == s.hash and k[2:4] == s.low] or [0])
        full = low * s.full[0] * s.full[1] / (s.low[0] * s.low[1])
        probe = full / 16 if s.full[0] * s.full[1] > self.PROBE_PIXELS else full
        return float(np.prod(dims)), full, probe

    def _est_full(self, lv: int, pilot: float | None = None) -> float | None:
        """References, checks and the answer on the full frames: per scene three whole frames
        traced (the references', the checks', the answer's), their replays (3 references, the
        verify machines, the answer), and two descents of about DESCENT_EVALS / 3 probes each.
        ``pilot``: the seconds of the first scene's whole frame traced and replayed once (the
        whole frames' traces are scaled from it by their visits; the low-resolution traces alone
        tell the visits poorly); else each trace and replay from the runner's models."""
        if self.runner.trace_time(1, 1) is None or self.runner.replay_time(lv, 1) is None:
            return None
        out = 0.0
        any_full = any(s.full != s.low for s in self.scenes)     # (else no checks and no descents there)
        probes = DESCENT_EVALS // 3 if self.grid is None and any_full else 0
        wholes, replays = (3, 3 + self.opts.verify + 1) if any_full else (2, 4)
        rate = None
        if pilot is not None:
            _, full0, _ = self._frame(self.scenes[0], self.scenes[0].ref_dims)
            if full0:
                rate = max(pilot - self.runner.replay_time(lv, full0), 0.1 * pilot) / full0
        for k, s in enumerate(self.scenes):
            vox, full, probe = self._frame(s)
            whole = self.runner.trace_time(vox, full) if rate is None else rate * full
            part = self.runner.trace_time(vox, probe) if rate is None else \
                min(max(self.runner.trace_time(vox, probe), rate * probe), whole)
            out += (wholes - (k == 0 and pilot is not None)) * whole + 2 * probes * part
            out += self.runner.replay_time(lv, full) * replays + self.runner.replay_time(lv, probe) * 2 * probes
        return out

    def _est_own(self, lv: int, free: int) -> float | None:
        """Each scene's own best: a short walk at low resolution, then its frame traced and replayed."""
        if self.runner.trace_time(1, 1) is None or self.runner.replay_time(lv, 1) is None:
            return None
        out = 0.0
        any_full = any(s.full != s.low for s in self.scenes)   # (else each frame's trace is still held)
        for s in self.scenes:
            vox, full, _ = self._frame(s)
            low = full * s.low[0] * s.low[1] / (s.full[0] * s.full[1])
            out += free * self.runner.replay_time(lv, low) + self.runner.replay_time(lv, full) + \
                (self.runner.trace_time(vox, full) if any_full else 0.0)
        return out


__all__ = ["DESCENT_EVALS", "Estimates", "TYPICAL_SEARCH"]
