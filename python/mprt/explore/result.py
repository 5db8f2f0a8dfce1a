"""The explorer's vocabulary: its settings (what is searched for, at which fidelity, where it
runs), the workload objective, and its answer (``ExploreResult``) with the machine's table."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import MprtError
from .evaluate import DEADLOCK_CYCLES, is_deadlock  # noqa: F401 (DEADLOCK_CYCLES: the figure of a deadlock)

OBJECTIVES = ("geomean", "total", "worst", "pareto")
# A design's level-1 cycles bound its level-2 and -3 cycles from below, but not strictly: level 3
# was up to 3.2% below level 1 on 150 random designs of tetra.  A design is ruled out only when
# level 1 less this slack is slower than the incumbent.
BOUND_LEVEL, BOUND_SLACK = 1, 0.10

@dataclass(frozen=True)
class SearchSettings:
    """What is searched for and how."""
    objective: str = "geomean"
    budget: float | None = None
    algorithm: str = "direct-l"
    polish: str = "lattice"
    max_evals: int = 1000
    seed: int = 1
    budgets: int = 6                 # pareto: budgets swept
    verify: int = 4                  # best machines of the search re-evaluated at full resolution
    own_evals: int | None = None     # per scene, the polish of its own best machine (default 8 a free variable)
    exhaustive: int = 200            # at most this many machines: every one is evaluated
    bound: bool = True               # levels 2 and 3: level-1 bounds rule designs out

    def __post_init__(self):
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, not {self.objective!r}")


@dataclass(frozen=True)
class FidelitySettings:
    """At which level, and on which traces."""
    level: int | str = "auto"
    tolerance: float = 0.01
    fraction: int | None = None      # search on traces at 1/fraction of each scene's frame (default ~64 px)


@dataclass(frozen=True)
class Resources:
    """Where the evaluations run (``runner.Runner``)."""
    workers: int | None = 1
    client: object = None            # a Dask client
    cache: str | None = None         # a folder: every evaluation kept, a killed run resumes
    threads: int = 1


class NoLiveDesignError(MprtError, RuntimeError):
    """No design the explorer evaluated runs every scene to the end at its level."""


@dataclass
class ExploreResult:
    """The answer: ``best`` (the machine), ``per_scene`` (a row per scene, in order), ``front``
    (pareto), ``references``, ``history`` and the run's figures; ``to_json()`` is ``mprt
    explore --json``'s document."""
    best: dict
    per_scene: list
    references: dict
    front: list
    history: list
    report: dict = field(default_factory=dict)
    machine: object = None           # the answer as a SystemConfig (``machine_toml`` writes its file)
    scene_machines: list = field(default_factory=list)   # per scene, with its software (software spaces)

    def to_json(self) -> dict:
        return {**self.report, "best": self.best, "per_scene": self.per_scene, "references": self.references,
                "front": self.front, "history": self.history}

    def machine_toml(self, k: int | None = None) -> str:
        """The answer as a machine file (``mprt simulate --config`` runs it as it is); ``k``: as
        scene k runs it, with its software (a space with software variables: one file a scene)."""
        from ..machine.config import config_toml

        ks = range(len(self.per_scene)) if k is None else [k]
        rows = [f"  {self.per_scene[i]['scene']}: subdivision {'x'.join(map(str, self.per_scene[i]['subdivision']))}"
                f" at {self.per_scene[i]['resolution'][0]}x{self.per_scene[i]['resolution'][1]}, level "
                f"{self.per_scene[i]['level']}: {self.per_scene[i]['cycles']:,.0f} cycles"
                + (f" (software {self.per_scene[i]['software']})" if "software" in self.per_scene[i] else "")
                for i in ks]
        head = (f"mprt explore's answer ({self.report.get('objective')}"
                + (f", budget {self.report['budget']:g} kGE" if self.report.get("budget") else "")
                + f"): {self.best['cost']:.0f} kGE\n{self.best['described']}\n"
                + ("" if k is None else f"as {self.per_scene[k]['scene']} runs it (its software)\n")
                + "mprt simulate SCENE --config THIS --grid NX,NY,NZ --res WxH --level L gives:\n"
                + "\n".join(rows))
        machine = self.machine if k is None or not self.scene_machines else self.scene_machines[k]
        return config_toml(machine, head)


def aggregate(objective: str, cycles: list, weights: list, refs: list) -> float:
    """The workload's figure of a machine from its scenes' cycles (lower is better): geomean
    (and pareto) the weighted geometric mean of the cycles; total the weighted sum; worst the
    largest ratio of a scene's cycles to the 3MPPE's (``refs``), in units of the 3MPPE's own
    weighted geometric mean of cycles (so the figure ranks as the worst ratio does and stays a
    number of cycles: the search compares logarithms of figures of at least 1)."""
    if any(is_deadlock(c) for c in cycles):
        return DEADLOCK_CYCLES
    w = np.asarray(weights, float)
    c = np.asarray(cycles, float)
    if objective == "total":
        return float((w * c).sum())
    if objective == "worst":
        r = np.asarray(refs, float)
        return float(max(c / r) * np.exp((w * np.log(np.maximum(r, 1.0))).sum() / w.sum()))
    return float(np.exp((w * np.log(np.maximum(c, 1.0))).sum() / w.sum()))


def knee_of(front):
    """The front's knee: in log cost against log figure, each scaled to [0, 1] over the front, the
    machine farthest from the straight line between its cheapest and its fastest (where the
    figure stops falling fast for the cost added); the only one of a front of one or two, the
    fastest."""
    rows = sorted(front, key=lambda e: (e.cost, e.cycles))
    if len(rows) <= 2:
        return min(rows, key=lambda e: (e.cycles, e.cost)) if rows else None
    x = np.log([e.cost for e in rows])
    y = np.log([e.cycles for e in rows])
    x = (x - x[0]) / ((x[-1] - x[0]) or 1.0)
    y = (y - y[-1]) / ((y[0] - y[-1]) or 1.0)
    # the chord from (0, 1) to (1, 0): distance below it is 1 - x - y (over sqrt 2)
    return rows[int(np.argmax(1.0 - x - y))]


def front_rows(front, budget=None, knee=None) -> list:
    """The Pareto front as rows, cheapest first: each machine's cost, figure and design, which of
    them is the knee (least figure x cost: the answer) and the best within ``budget``, and
    ``differs``: the design fields that are not the same on every row (what a reader compares)."""
    def flat(d, pre=""):
        out = {}
        for k, v in d.items():
            out.update(flat(v, f"{pre}{k}.") if isinstance(v, dict) else {f"{pre}{k}": v})
        return out
    rows = sorted(front, key=lambda e: (e.cost, e.cycles))
    fields = [flat(e.point.design.to_dict()) for e in rows]
    keys = sorted({k for f in fields for k in f})
    varying = [k for k in keys if len({repr(f.get(k, 0)) for f in fields}) > 1]
    within = [e for e in rows if budget is None or e.cost <= budget]
    best = min(within, key=lambda e: (e.cycles, e.cost)) if budget is not None and within else None
    return [{"design": e.point.design.to_dict(), "described": e.point.design.describe(), "cost": e.cost,
             "objective": e.cycles, "knee": e is knee, "budget_best": e is best,
             "differs": {k: f.get(k, 0) for k in varying}} for e, f in zip(rows, fields)]


def speedup(ref, cycles):
    if ref is None or cycles is None or not cycles or is_deadlock(cycles) or is_deadlock(ref):
        return None
    return ref / cycles


def slack_bounds(results) -> list:
    """Lower bounds for a search at level 2 or 3 from level-1 results: the cycles less BOUND_SLACK
    (none, 0 cycles, where level 1 deadlocks)."""
    return [replace(r, cycles=0.0 if is_deadlock(r.cycles) else float(np.floor(r.cycles * (1 - BOUND_SLACK))))
            for r in results]


def processor_table(cfg) -> list:
    """The machine's processors as a table: per stage its subtasks, copies, units and FIFOs, its
    memories, and the count over the PEs."""
    rows = []
    for st in cfg.stages:
        mems = []
        for tag, mem in (("IC", cfg.ic_memory), ("SC", cfg.sc_memory)):
            if tag in st.subtasks and mem is not None:
                mems.append(f"{tag}: cache {mem.cache.size >> 10 if mem.cache else 0} KiB, "
                            f"resident {mem.resident >> 10} KiB")
        rows.append({"stage": st.name, "copies_per_pe": st.replicas, "units": dict(st.processor.units),
                     "send_fifo": st.send_fifo, "receive_fifo": st.receive_fifo, "feed": st.feed,
                     "memories": "; ".join(mems), "processors": st.replicas * cfg.pes})
    return rows


def settings(workload, grid=None, loaded=None) -> dict:
    """What made a report: the scenes (each with its content's hash), the subdivision when it was
    fixed (``grid``: None when searched), the version."""
    from ..settings import threshold_setting, version
    scenes = []
    for e in workload:
        d = e.to_dict()
        d["threshold"] = threshold_setting(d["rules"], e.threshold)       # the cutoff the traces had
        d["scene_sha256"] = (loaded[len(scenes)] if loaded else e.load()).content_hash()
        scenes.append(d)
    return {"scenes": scenes, "grid": None if grid is None else list(grid), "mprt_version": version()}


__all__ = ["BOUND_LEVEL", "BOUND_SLACK", "ExploreResult", "FidelitySettings", "NoLiveDesignError", "OBJECTIVES",
           "Resources", "SearchSettings", "aggregate", "front_rows", "knee_of", "processor_table", "settings", "slack_bounds", "speedup"]
