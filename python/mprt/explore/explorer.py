"""``explore()``: one machine for a workload of scenes, and each scene's subdivision.

A chip is built once and must run every scene; the voxel subdivision is software, chosen per
scene.  So the machine (every design variable of the space) is one for the workload and the
subdivision (nx, ny, nz) is free per scene.  The search is a block coordinate descent:

1. **level** (``ladder``): the fidelity ladder on each scene's low-resolution trace;
2. **subdivisions**: each scene's (nx, ny, nz) for the paper's 3MPPE (``subdivision.descend``);
3. **search**: the machine, every scene at its subdivision, at low resolution: NLopt's global
   phase and the lattice polish (``search.search``), or every design where the space has at
   most ``SearchSettings.exhaustive`` of them; a design's figure is the workload objective;
4. **subdivisions again** for the best machine, and where one moved, the polish again;
5. **full resolution**: the ``verify`` best machines on every scene at its full frame, the best
   of them kept; each scene's subdivision descended again there, for it and for the 3MPPE;
6. **per scene**: the answer's figures on each full frame at the level, its speed-up over the
   3MPPE (at the 3MPPE's own best subdivision), and the scene's own best machine under the same
   budget (``own_best``) with ``sharing``, what the scene gives up by sharing the chip.

Objectives (all under ``budget``): ``geomean`` (default) the weighted geometric mean of the
speed-ups over the 3MPPE (ranked as the weighted geometric mean of cycles), ``total`` the
weighted total cycles, ``worst`` the worst scene's speed-up, ``pareto`` the front of the
geometric mean against cost.  A machine that deadlocks on any scene is infeasible.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass

import numpy as np

from .evaluate import Result, is_deadlock
from .hwcost import UnitCosts, hardware_cost, machine_breakdown
from .problem import Problem
from .runner import Runner, Task, register_scene
from .search import compass, cost_range, exhaustive, search as run_search
from .space import Design, Point, Space, default_space
from . import subdivision as subdiv
from .compare import Compare
from .software import Software, with_software  # noqa: F401 (with_software: a public name here too)
from .estimates import Estimates
from .result import (BOUND_LEVEL, BOUND_SLACK, OBJECTIVES, ExploreResult, FidelitySettings,  # noqa: F401
                     NoLiveDesignError, Resources, SearchSettings, aggregate, front_rows, knee_of,
                     processor_table, settings,
                     slack_bounds, speedup)

# Above this many pixels, a subdivision is chosen at full resolution on a sample of the frame's
# tiles (PROBE_SAMPLE: one 16x16 tile in 16, stratified), and only the figures reported are the
# whole frame's
PROBE_PIXELS, PROBE_SAMPLE = 256 * 256, "stratified:16:1"
SEARCH_POLISH = 4          # the polish after a subdivision moved: this many x 8 steps a free variable


@dataclass
class SceneState:
    """What the explorer knows of one scene."""
    index: int
    entry: object
    scene: object
    hash: str
    full: tuple
    low: tuple
    extent: tuple
    dims: tuple = None               # the search's subdivision (low resolution)
    ref_low: float = None            # the 3MPPE at its own best subdivision, low resolution
    ref_dims: tuple = None           # that subdivision
    ref_full: float = None           # the 3MPPE at its own best subdivision, full resolution


class _Explorer(Estimates, Compare, Software):
    """One exploration's state (``explore`` is its front door)."""
    PROBE_PIXELS = PROBE_PIXELS
    distinct = staticmethod(lambda space: _distinct(space))

    def __init__(self, workload, space, search, fidelity, resources, machine, grid, say, progress, phases=None):
        self.workload, self.space, self.opts, self.fid, self.res = workload, space, search, fidelity, resources
        self.fixed, self.grid = machine, grid
        self.say, self.progress = say, progress
        self.phases = phases or _Silent()
        self.unit_costs = UnitCosts.from_table(space.cost)
        self.t0 = time.perf_counter()
        self.scenes: list[SceneState] = []
        for k, e in enumerate(workload):
            sc = e.load()
            info = sc.info()
            full = tuple(e.res or info["resolution"])
            frac = fidelity.fraction or max(1, min(full) // 64)
            from .prepass import low_resolution
            low = full if frac == 1 else tuple(low_resolution(full[0], full[1], frac))
            h = sc.content_hash()
            register_scene(h, sc)
            self.scenes.append(SceneState(k, e, sc, h, full, low, tuple(np.subtract(info["hi"], info["lo"]))))
        self.runner = Runner(resources.workers, resources.client,
                             _cache(resources.cache), say=say)
        self.per_scene_memo: dict = {}      # (design key, dims of every scene) -> [Result per scene]
        self.chosen: dict = {}              # design key -> the design with each scene's software
        from ..machine.config import builtin
        self.refs = {name: builtin(name) for name in ("3mppe", "M", "S")}

    # -- evaluation -------------------------------------------------------------------------------
    def run(self, pairs, level: int, res: str = "low") -> list:
        """Results of (scene index, dims, machine) pairs at a level: at the search's low resolution
        ("low"), on each scene's whole frame ("full"), or to choose a subdivision at full
        resolution ("probe": a sample of the frame's tiles above PROBE_PIXELS, else the frame)."""
        groups: dict = {}
        for n, (k, dims, m) in enumerate(pairs):
            groups.setdefault((k, tuple(dims)), []).append(n)
        tasks, order = [], []
        for (k, dims), ns in groups.items():
            s = self.scenes[k]
            w, h = s.low if res == "low" else s.full
            sample = PROBE_SAMPLE if res == "probe" and w * h > PROBE_PIXELS else None
            tasks.append(Task(s.entry, s.hash, w, h, dims, level, tuple(pairs[n][2] for n in ns), self.unit_costs,
                              max_visits=2_000_000 if res == "low" else 1, sample=sample))
            order.append(ns)
        out = [None] * len(pairs)
        for ns, rows in zip(order, self.runner.run(tasks)):
            for n, r in zip(ns, rows):
                out[n] = r
        return out

    def cost(self, machine) -> float:
        return float(sum(self.breakdown(machine).values()))

    def breakdown(self, machine) -> dict:
        return machine_breakdown(machine, self.unit_costs)

    def descend(self, k: int, machine, level: int, start, full: bool = False) -> tuple:
        """Scene k's subdivision for a machine (``subdivision.descend``; held where --grid fixes it),
        at low resolution or, ``full``, on full-resolution probes (``run``'s "probe")."""
        res = "probe" if full else "low"
        if self.grid is not None:
            dims = tuple(self.grid)
            return dims, self.run([(k, dims, machine)], level, res)[0].cycles
        values = self.space_axis_values()
        s = self.scenes[k]
        dims, cyc, _ = subdiv.descend(
            lambda cands: [r.cycles for r in self.run([(k, c, machine) for c in cands], level, res)],
            start, s.extent, values)
        return dims, cyc

    def space_axis_values(self) -> tuple:
        """The subdivision's lattice: nx, ny and nz's values each (or the one n's, every axis)."""
        names = {v.name: v for v in self.space.variables}
        if "subdivision.nx" in names:
            return tuple(tuple(sorted(names[f"subdivision.n{a}"].values)) for a in "xyz")
        return tuple(sorted(names["subdivision.n"].values)) if "subdivision.n" in names else subdiv.AXIS_VALUES

    def start(self, k: int) -> tuple:
        if self.grid is not None:
            return tuple(self.grid)
        return subdiv.start_dims(self.scenes[k].scene, self.space_axis_values())

    def workload_points(self, points, level: int) -> list:
        """The workload figures of points (the hardware space's: each scene at its own dims and with
        its own software)."""
        dims = tuple(s.dims for s in self.scenes)
        pairs = [(s.index, s.dims, p.design) for p in points for s in self.scenes]
        got = self.per_scene(pairs, level)
        out = []
        n = len(self.scenes)
        for i, p in enumerate(points):
            rows = [r for r, _ in got[i * n:(i + 1) * n]]
            self.per_scene_memo[(p.design.key(), dims)] = rows
            self.chosen[p.design.key()] = [v for _, v in got[i * n:(i + 1) * n]]
            agg = aggregate(self.opts.objective, [r.cycles for r in rows], self.workload.weights,
                            [s.ref_low for s in self.scenes])
            dead = [self.scenes[j].entry.name for j, r in enumerate(rows) if r.deadlocked]
            out.append(Result(cycles=agg, level=level, cost=self.cost(p.design),
                              bottleneck="deadlock" if dead else rows[0].bottleneck,
                              engine=rows[0].engine, utilisation=rows[0].utilisation if n == 1 else {},
                              loads=rows[0].loads if n == 1 else {}))
        return out

    def bounds(self, points) -> list:
        """Level-1 bounds of points (``slack_bounds``)."""
        return slack_bounds(self.workload_points(points, BOUND_LEVEL))

    # -- the phases ---------------------------------------------------------------------------------
    def explore(self) -> ExploreResult:
        from .ladder import LADDER_LEVELS, choose_level, ladder_designs

        ph = self.phases
        names = [s.entry.name for s in self.scenes]
        hw = self.space.hardware()
        lv_level = self.fid.level
        starts = [self.start(s.index) for s in self.scenes]
        multi = len(self.scenes) > 1 and self.fixed is None
        ph.n = (lv_level == "auto") + 1 + (self.fixed is None) + 1 + multi

        def ladder_run(k, designs, lv):
            t = time.perf_counter()
            got = self.run([(k, starts[k], d) for d in designs], lv)
            return got, time.perf_counter() - t
        said: list = []
        if lv_level == "auto":
            designs = ladder_designs(hw, self.opts.seed)
            t0 = time.perf_counter()
            self.run([(0, starts[0], designs[0])], 0)        # (the first trace and a design at each level,
            first = time.perf_counter() - t0                 # timed for the estimate)
            per_design = 0.0
            for lv in LADDER_LEVELS:
                t0 = time.perf_counter()
                self.run([(0, starts[0], designs[0])], lv)
                per_design += time.perf_counter() - t0
            with ph.step(f"ladder: {len(designs)} designs at levels {', '.join(map(str, LADDER_LEVELS))} on "
                         f"each scene's low-resolution trace",
                         self._est_ladder(first - per_design / len(LADDER_LEVELS), per_design, starts,
                                          len(designs))):
                levels = choose_level(lv_level, self.fid.tolerance, names, ladder_run, hw, self.opts.seed,
                                      said.append)
        else:
            levels = choose_level(lv_level, self.fid.tolerance, names, ladder_run, hw, self.opts.seed)
        for text in said:
            self.say(text)
        lv = levels["search"]
        # 2. each scene's subdivision for the 3MPPE
        ref = self.refs["3mppe"]
        if self.runner.per_trace() is None:       # (a fixed level: one trace to estimate from)
            self.run([(0, starts[0], ref)], lv)
        with ph.step(f"subdivisions: each scene's nx, ny, nz for the paper's 3MPPE at level {lv}",
                     self._est_descents(lv)):
            for s, st in zip(self.scenes, starts):
                s.dims, s.ref_low = self.descend(s.index, ref, lv, st)
                s.ref_dims = s.dims
                if is_deadlock(s.ref_low):
                    s.ref_low = self.run([(s.index, s.dims, self.refs["M"])], lv)[0].cycles
                said.append(f"subdiv  {s.entry.name}: {'x'.join(map(str, s.dims))} at {s.low[0]}x{s.low[1]}")
        for text in said[len(said) - len(self.scenes):]:
            self.say(text)
        # 3. the machine
        history: list = []
        front: list = []
        problem = None
        if self.fixed is not None:
            best_machine = self.fixed
            self.say("search  none: the machine is fixed (--machine); only each scene's subdivision is chosen")
        else:
            ph.line(f"search: the machine on {len(self.scenes)} scene(s) at level {lv}, then each scene's "
                    f"subdivision for it again", self._est_search(hw, lv))
            t = time.perf_counter()
            problem, best_machine, front = self.search(hw, lv)
            history += _rows(problem, "search", lv, [x.dims for x in self.scenes])
            # the subdivisions again for that machine; the polish again where one moved
            for _ in range(2):
                moved = False
                for s in self.scenes:
                    dims, _ = self.descend(s.index, self.machine_for(s.index, best_machine), lv, s.dims)
                    if dims != s.dims:
                        self.say(f"subdiv  {s.entry.name}: {'x'.join(map(str, s.dims))} -> "
                                 f"{'x'.join(map(str, dims))} for the search's best")
                        s.dims, moved = dims, True
                if not moved or self.opts.objective == "pareto":
                    break
                problem = self.problem(hw, lv)
                problem.progress = None         # (a short walk: its summary line says what it did)
                idx = hw.canonical(hw.index_of(Point((1, 1, 1), best_machine)))
                problem.evaluate_many([idx])
                compass(problem, idx, SEARCH_POLISH * 8 * len(problem.free))
                history += _rows(problem, "polish", lv, [x.dims for x in self.scenes])
                best_machine = problem.best().point.design
            self.say(f"search  done in {time.perf_counter() - t:.1f} s: {best_machine.describe()}, "
                     f"{self.cost(best_machine):.0f} kGE")
        # 4. full resolution: the references, the verify best, each scene's subdivision there
        pilot = None
        if any(x.full != x.low for x in self.scenes):     # one whole frame, timed for the estimate (the
            s0 = self.scenes[0]                           # references' first, which keep its trace)
            t0 = time.perf_counter()
            self.run([(0, s0.ref_dims, self.refs["3mppe"])], lv, "full")
            pilot = time.perf_counter() - t0
        with ph.step("full resolution: the references at their own subdivisions, the best machines, each "
                     "scene's subdivision there", self._est_full(lv, pilot)):
            refs = self.references(lv)
            best_machine, full_rows = self.full_resolution(problem, best_machine, lv, history)
        return self.answer(best_machine, full_rows, lv, levels, history, front, problem, refs, multi)

    def problem(self, hw: Space, lv: int) -> Problem:
        objective = "pareto" if self.opts.objective == "pareto" else "time"
        bound = self.bounds if self.opts.bound and lv > BOUND_LEVEL and objective != "pareto" else None
        return Problem(hw, lambda pts: self.workload_points(pts, lv), objective,
                       self.opts.budget if objective != "pareto" else None, progress=self.progress,
                       cost_of=lambda p: hardware_cost(p.design, self.unit_costs), bound_points=bound)

    def search(self, hw: Space, lv: int):
        problem = self.problem(hw, lv)
        n = _distinct(hw)
        t = time.perf_counter()
        front = []
        if n is not None and n <= self.opts.exhaustive:
            exhaustive(problem, batch=16)        # (batches small enough for progress to show)
            if self.opts.objective == "pareto":
                front = problem.front()
        elif self.opts.objective == "pareto":
            from .search import pareto
            lo, hi = cost_range(hw, self.unit_costs)
            budgets = np.geomspace(lo * 1.05, hi, self.opts.budgets)
            front = pareto(problem, budgets, self.opts.algorithm, self.opts.polish,
                           max(self.opts.max_evals // len(budgets), 20), self.opts.seed).front
        else:
            run_search(problem, self.opts.algorithm, self.opts.polish, self.opts.max_evals, self.opts.seed)
        if self.progress is not None and hasattr(self.progress, "end"):
            self.progress.end()
        live = [e for e in problem.memo.values() if not e.bound and not is_deadlock(e.cycles)]
        if not live:
            raise NoLiveDesignError(self._dead_message(problem, lv))
        if self.opts.objective == "pareto":
            if not front:
                raise NoLiveDesignError(self._dead_message(problem, lv))
            best = knee_of(front)
        else:
            best = problem.best()
        how = ("every machine of the space" if n is not None and n <= self.opts.exhaustive else
               f"{self.opts.algorithm}, then {self.opts.polish}")
        self.say(f"search  {len(problem.memo)} machines ({how}; {problem.runs} replayed at level {lv}) in "
                 f"{time.perf_counter() - t:.1f} s: best {best.point.design.describe()}, {best.cost:.0f} kGE")
        return problem, best.point.design, front

    def _dead_message(self, problem, lv) -> str:
        dead: dict = {}
        for key, rows in self.per_scene_memo.items():
            for s, r in zip(self.scenes, rows):
                if r.deadlocked:
                    dead[s.entry.name] = dead.get(s.entry.name, 0) + 1
        which = ", ".join(f"{n} ({c})" for n, c in dead.items()) or "none"
        return (f"explore: every machine evaluated at level {lv} deadlocks on some scene ({len(problem.memo)} "
                f"machines; deadlocks by scene: {which}): give the FIFOs more room in the space")

    def full_resolution(self, problem, best_machine, lv: int, history: list) -> tuple:
        """The ``verify`` best machines at each scene's full frame; the best, with each scene's
        subdivision descended there.  Returns (machine, [(dims, Result) per scene])."""
        cands = [best_machine]
        if problem is not None and self.opts.objective != "pareto":
            ranked = [e for e in problem.ranked() if not is_deadlock(e.cycles)][:self.opts.verify]
            cands += [e.point.design for e in ranked]
        cands = list({(d.key() if isinstance(d, Design) else repr(d)): d for d in cands}.values())
        any_full = any(s.full != s.low for s in self.scenes)
        order = list(range(len(cands)))
        if any_full and len(cands) > 1:
            pairs = [(s.index, s.dims, d) for d in cands for s in self.scenes]
            both = self.per_scene(pairs, lv, "full")
            got = [r for r, _ in both]
            n = len(self.scenes)
            scored = []
            for i, d in enumerate(cands):
                rows = got[i * n:(i + 1) * n]
                if isinstance(d, Design):       # each scene's software as its full frame chose it
                    self.chosen[d.key()] = [v for _, v in both[i * n:(i + 1) * n]]
                agg = aggregate(self.opts.objective, [r.cycles for r in rows], self.workload.weights,
                                 [s.ref_full for s in self.scenes])
                feasible = self.opts.budget is None or self.cost(d) <= self.opts.budget * (1 + 1e-12)
                scored.append((not feasible, agg, i))
                history.append({"phase": "full", "design": d.to_dict(), "cycles": None if is_deadlock(agg)
                                else agg, "cost": self.cost(d), "feasible": feasible, "level": lv,
                                "deadlock": is_deadlock(agg)})
            order = [i for _, _, i in sorted(scored)]
        dead: list = []
        for i in order:             # the best first; one that deadlocks on a whole frame gives way to the next
            machine, rows = cands[i], []
            for s in self.scenes:
                own = self.machine_for(s.index, machine)         # (with the scene's software)
                dims, _ = self.descend(s.index, own, lv, s.dims, full=any_full)
                r = self.run([(s.index, dims, own)], lv, "full")[0]
                if r.deadlocked and dims != s.dims:      # (a probe's trees are not all of the frame's)
                    dims, r = s.dims, self.run([(s.index, s.dims, own)], lv, "full")[0]
                if r.deadlocked:
                    dead.append(s.entry.name)
                    break
                rows.append((dims, r))
            else:
                return machine, rows
        raise NoLiveDesignError(f"explore: each of the {len(order)} best machines deadlocks on a whole frame at "
                                f"level {lv} (on {', '.join(dict.fromkeys(dead))}): give the FIFOs more room in "
                                f"the space")

    def answer(self, machine, full_rows, lv, levels, history, front, problem, refs, multi) -> ExploreResult:
        from .evaluate import machine_config

        own = [None] * len(self.scenes)
        if multi:
            est = self._est_own(lv, len(problem.free))
            with self.phases.step("own best: each scene's own best machine under the budget, for its sharing",
                                  est):
                own = self.own_best(problem, lv, full_rows)
        cfg = machine_config(machine) if isinstance(machine, Design) else machine
        per_scene = []
        for s, (dims, r), o, ref in zip(self.scenes, full_rows, own, refs["3mppe"]["per_scene"]):
            if self.space.software and isinstance(machine, Design):
                own = self.machine_for(s.index, machine)
                soft = {"software": {n: getattr(own, n.split(".")[-1]) for n in self.space.software},
                        "machine": machine_config(own).to_dict()}
            else:
                soft = {}
            row = {**soft, "scene": s.entry.name, "weight": s.entry.weight, "resolution": list(s.full),
                   "subdivision": list(dims), "level": lv, "cycles": r.cycles,
                   "speedup": speedup(ref["cycles"], r.cycles), "bottleneck": r.bottleneck,
                   "utilisation": r.utilisation, "engine": r.engine}
            if o is not None and o[2].cycles < r.cycles:
                od, odims, orr = o
                row["own_best"] = {"cycles": orr.cycles, "design": od.to_dict(), "described": od.describe(),
                                   "cost": self.cost(od), "subdivision": list(odims), "machine": "own"}
            else:
                row["own_best"] = {"cycles": r.cycles, "machine": "workload"}
            row["sharing"] = row["own_best"]["cycles"] / r.cycles
            per_scene.append(row)
        weights = np.asarray(self.workload.weights, float)
        sp = [row["speedup"] for row in per_scene]
        geo = float(np.exp((weights * np.log(sp)).sum() / weights.sum())) if all(sp) else None
        share = [row["sharing"] for row in per_scene]
        cost = self.cost(machine)
        best = {"design": machine.to_dict() if isinstance(machine, Design) else None,
                "machine": cfg.to_dict(), "described": machine.describe() if isinstance(machine, Design)
                else f"the machine of {machine.source or machine.name}",
                "processors": processor_table(cfg),
                "cost": cost, "cost_breakdown": self.breakdown(machine),
                "feasible": self.opts.budget is None or self.opts.objective == "pareto"
                or cost <= self.opts.budget * (1 + 1e-12),
                "speedup_geomean": geo, "speedup_worst": min(sp) if all(sp) else None,
                "total_cycles": float(sum(w * r.cycles for w, (_, r) in zip(weights, full_rows))),
                "sharing_geomean": float(np.exp((weights * np.log(share)).sum() / weights.sum()))}
        fronts = front_rows(front, self.opts.budget, knee_of(front))
        report = {"workload": self.workload.to_dict(), "objective": self.opts.objective, "budget": self.opts.budget,
                  "level": levels, "tolerance": self.fid.tolerance,
                  "search_resolution": [list(s.low) for s in self.scenes],
                  "algorithm": {"global": self.opts.algorithm, "polish": self.opts.polish,
                                "max_evals": self.opts.max_evals, "seed": self.opts.seed},
                  "evaluations": {"machines": len({(r.get("phase"), json.dumps(r.get("design"), sort_keys=True))
                                                   for r in history if r.get("phase") in ("search", "polish")}),
                                  "replayed": self.runner.ran, "reused_from_cache": self.runner.reused,
                                  "repeated": self.runner.repeated,
                                  "worker_restarts": self.runner.pool.restarts if self.runner.pool else 0},
                  "workers": self.runner.workers,
                  "space": {"source": self.space.source,
                            "variables": {v.name: list(v.values) for v in self.space.variables},
                            "unit_costs": self.unit_costs.to_dict()},
                  "settings": settings(self.workload, self.grid, [s.scene for s in self.scenes]),
                  "seconds": time.perf_counter() - self.t0}
        scene_machines = ([machine_config(self.machine_for(s.index, machine)) for s in self.scenes]
                          if self.space.software and isinstance(machine, Design) else [])
        return ExploreResult(best, per_scene, refs, fronts, history, report, cfg, scene_machines)


class _Silent:
    """Phases told to no one (``explore`` without ``phases``)."""
    n = 0

    def step(self, name, estimate=None):
        from contextlib import nullcontext
        return nullcontext()

    def line(self, name, estimate=None):
        pass


def _distinct(space: Space, limit: int = 1 << 16):
    """The number of distinct machines of a space (None: more than ``limit`` index vectors)."""
    import itertools

    if space.count() > limit:
        return None
    return len({space.canonical(i) for i in itertools.product(*(range(v.size) for v in space.variables))})


def _rows(problem, phase: str, lv: int, dims) -> list:
    """The problem's history rows, each with the scenes' subdivisions it was evaluated at (the
    hardware space's own subdivision is a placeholder)."""
    out = []
    for r in problem.history():
        r = dict(r, phase=phase, level=lv, subdivisions=[list(d) for d in dims])
        r.pop("subdivision", None)
        out.append(r)
    return out


def _cache(folder):
    if folder is None:
        return None
    from .distributed import DiskCache
    return DiskCache(folder)


def explore(workload, space: Space | None = None, search: SearchSettings = SearchSettings(),
            fidelity: FidelitySettings = FidelitySettings(), resources: Resources = Resources(),
            machine=None, grid=None, say=None, progress=None, phases=None) -> ExploreResult:
    """One machine for ``workload`` (a ``Workload``, a ``Scene`` name or a list of names) from
    ``space`` (default: the built-in space), and each scene's subdivision.  ``machine`` (a
    ``SystemConfig``): fixed, only the subdivisions are chosen.  ``grid`` ((nx, ny, nz)): every
    scene's subdivision, fixed.  ``say(text)`` is told each step's result as it ends;
    ``progress(problem)`` after each machine the search evaluates; ``phases`` (an
    ``mprt.progress.Phases``) each phase as it starts, numbered, with its estimated time (from what
    ran before it: the traces' and replays' mean seconds)."""
    from .workload import Workload, workload_of

    if not isinstance(workload, Workload):
        workload = workload_of([workload] if isinstance(workload, str) else list(workload))
    if grid is not None:
        grid = (int(grid),) * 3 if isinstance(grid, int) else tuple(int(v) for v in grid)
        if len(grid) == 1:
            grid = grid * 3
    ex = _Explorer(workload, space or default_space(), search, fidelity, resources, machine, grid,
                   say or (lambda text: None), progress, phases)
    try:
        return ex.explore()
    finally:
        ex.runner.close()


__all__ = ["BOUND_LEVEL", "BOUND_SLACK", "ExploreResult", "slack_bounds", "FidelitySettings", "NoLiveDesignError", "OBJECTIVES",
           "Resources", "SearchSettings", "explore", "processor_table", "settings"]
