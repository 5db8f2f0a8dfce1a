"""SimResult (the figures of a run), Timeline (binned series for plots) and the plots."""
from __future__ import annotations

import json
from dataclasses import dataclass, field

from ..atomic import replacing

SUBTASKS = ("OS", "IC", "SC")
CATEGORIES = ("processing", "communication", "waiting")


class Timeline:
    """Series binned over time for plots, the bin width doubling as the run
    goes on (so memory stays fixed): per stage the busy processors, per FIFO
    the occupancy, both averaged over each bin."""

    def __init__(self, nbins: int = 256):
        self.nbins = nbins
        self.width = 1
        self.series = {}          # name -> list of per-bin integrals
        self.kind = {}            # name -> "busy" | "fifo"
        self.lastlevel = {}       # fifo name -> (time, level)

    def _grow(self, t):
        while t > self.nbins * self.width:
            for s in self.series.values():
                s[:] = [s[2 * i] + s[2 * i + 1] for i in range(self.nbins // 2)] + [0] * (self.nbins // 2)
            self.width *= 2

    def _add(self, name, t0, t1, weight):
        if t1 <= t0 or weight == 0:
            return
        self._grow(t1)
        s = self.series[name]
        w = self.width
        b = t0 // w
        while t0 < t1:
            e = min(t1, (b + 1) * w)
            s[b] += weight * (e - t0)
            t0 = e
            b += 1

    def busy(self, name, k, t, d):
        if name not in self.series:
            self.series[name] = [0] * self.nbins
            self.kind[name] = "busy"
        self._add(name, t, t + d, 1)

    def level(self, name, t, n):
        if name not in self.series:
            self.series[name] = [0] * self.nbins
            self.kind[name] = "fifo"
            self.lastlevel[name] = (0, 0)
        t0, n0 = self.lastlevel[name]
        self._add(name, t0, t, n0)
        self.lastlevel[name] = (t, n)

    def finish(self, end):
        for name, (t0, n0) in self.lastlevel.items():
            self._add(name, t0, end, n0)
            self.lastlevel[name] = (end, n0)

    @classmethod
    def from_log(cls, log, nbins: int = 256) -> "Timeline":
        """The busy series of an event log ((cycle, 'start'|'end', stage, replica, visit), as
        SimPy and the compiled replay record it); no FIFO series (the log has no FIFO events)."""
        tl = cls(nbins)
        started = {}
        for t, what, name, k, _ in log:
            if what == "start":
                started[(name, k)] = t
            else:
                t0 = started.pop((name, k))
                tl.busy(name, k, t0, t - t0)
        return tl

    def mean_series(self, name, end, divisor=1):
        """(bin start times, mean value per bin) up to end."""
        w = self.width
        n = min(self.nbins, max(1, -(-end // w)))
        s = self.series[name]
        times = [i * w for i in range(n)]
        vals = [s[i] / (min(w, end - i * w) * divisor) if end > i * w else 0.0 for i in range(n)]
        return times, vals


@dataclass
class SimResult:
    """Figures of one run.  Cycles summed over PEs (and replicas) unless
    stated; ``stages`` by subtask, ``nodes`` by configured stage."""

    cycles: int
    model: str
    level: int
    config: dict
    stages: dict
    nodes: dict
    processors: list
    pes: list
    fifos: dict
    links: dict
    memory: dict
    rays: dict
    visits: int
    deadlock_bound: dict = field(default_factory=dict)
    wall_seconds: float = 0.0
    log: list | None = None
    timeline: Timeline | None = field(default=None, repr=False)

    def stage_load(self, subtask: str) -> int:
        """Processing + communication cycles of a subtask (its load)."""
        s = self.stages[subtask]
        return s["processing"] + s["communication"]

    def to_dict(self) -> dict:
        return {
            "cycles": self.cycles,
            "model": self.model,
            "level": self.level,
            "engine": "simpy",
            "sampled": 1.0,
            "cycles_interval": [self.cycles, self.cycles],
            "stages": self.stages,
            "nodes": self.nodes,
            "processors": self.processors,
            "pes": self.pes,
            "fifos": self.fifos,
            "links": self.links,
            "memory": self.memory,
            "rays": self.rays,
            "visits": self.visits,
            "deadlock_bound": self.deadlock_bound,
            "wall_seconds": self.wall_seconds,
            "config": self.config,
        }

    def report(self) -> str:
        """A text report: time, the paper's three categories per stage, FIFOs, links, memories."""
        lines = [f"model {self.model} (level {self.level}): {self.cycles:,} cycles, {self.visits:,} visits, "
                 f"{sum(self.rays.values()):,} rays"]
        lines.append(f"  {'stage':6s} {'rays in':>12s} {'processing':>16s} {'communication':>16s} "
                     f"{'waiting':>16s} {'utilisation':>11s}")
        for t in SUBTASKS:
            s = self.stages[t]
            tot = sum(s[c] for c in CATEGORIES) or 1
            lines.append(f"  {t:6s} {s['rays_in']:12,d} " + " ".join(
                f"{s[c]:>10,d} {100 * s[c] / tot:4.1f}%" for c in CATEGORIES) + f" {s['utilisation']:11.3f}")
        if len(self.nodes) != 3 or any(len(n["subtasks"]) != 1 for n in self.nodes.values()):
            for name, n in self.nodes.items():
                lines.append(f"  processor {name}: busy {n['busy']:,}, blocked {n['blocked']:,}, idle {n['idle']:,} "
                             f"(utilisation {n['utilisation']:.3f})")
        for name, f in self.fifos.items():
            if f["packets"]:
                lines.append(f"  fifo {name}: capacity {f['capacity']}, mean {f['mean']:.2f}, max {f['max']}")
        for pe, links in self.links.items():
            lines.append(f"  ring {pe}: link utilisation " + ", ".join(f"{u:.3f}" for u in links))
        for name, m in self.memory.items():
            if "hit_rate" in m:
                lines.append(f"  {name}: {m['hits']:,} of {m['accesses']:,} hit ({m['hit_rate']:.3f})")
            else:
                lines.append(f"  {name}: {m['accesses']:,} reads, port busy {m['busy']:,} cycles, "
                             f"queued {m['queued']:,} cycles")
        if len(self.pes) > 1:
            for p in self.pes:
                lines.append(f"  PE{p['pe']}: {p['primaries']:,} primary rays, {p['rays']:,} rays, last ray at "
                             f"cycle {p['end']:,}")
        return "\n".join(lines)

    def json(self) -> str:
        return json.dumps(self.to_dict(), indent=2)

    # -- plots --------------------------------------------------------------------
    def plot(self, path, title: str | None = None) -> None:
        """PNG: per-stage load bars (processing / communication / waiting, as the
        paper's figure 6), and with a timeline the utilisation and FIFO occupancy over time."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        tl = self.timeline
        nplots = 3 if tl is not None else 1
        fig, axes = plt.subplots(nplots, 1, figsize=(10, 3.2 * nplots), squeeze=False)
        ax = axes[0][0]
        colours = {"processing": "#4878a8", "communication": "#e0a040", "waiting": "#c8c8c8"}
        bottom = [0.0] * 3
        for c in CATEGORIES:
            vals = [self.stages[t][c] / 1e6 for t in SUBTASKS]
            ax.barh(SUBTASKS, vals, left=bottom, color=colours[c], label=c)
            bottom = [b + v for b, v in zip(bottom, vals)]
        ax.invert_yaxis()
        ax.set_xlabel("million cycles (summed over PEs)")
        ax.set_title(title or f"model {self.model}: {self.cycles:,} cycles")
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
        if tl is not None:
            tl.finish(self.cycles)
            ax = axes[1][0]
            for name, kind in tl.kind.items():
                if kind == "busy":
                    reps = self.nodes.get(name.split(".", 1)[1], {}).get("replicas", 1)
                    t, v = tl.mean_series(name, self.cycles, reps)
                    ax.plot([x / 1e6 for x in t], v, label=name, lw=1)
            ax.set_ylabel("utilisation")
            ax.set_ylim(0, 1.05)
            ax.set_xlabel("million cycles")
            ax.legend(fontsize=7, ncol=1, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
            ax = axes[2][0]
            fifo = False
            for name, kind in tl.kind.items():
                if kind == "fifo" and self.fifos.get(name, {}).get("packets"):
                    t, v = tl.mean_series(name, self.cycles)
                    ax.plot([x / 1e6 for x in t], v, label=name, lw=1)
                    fifo = True
            ax.set_ylabel("FIFO occupancy (packets)")
            ax.set_xlabel("million cycles")
            if fifo:
                ax.legend(fontsize=7, ncol=1, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
            else:
                ax.text(0.5, 0.5, "no FIFO series: the compiled replay logs visits, not FIFO levels\n"
                        "(--engine simpy draws them)" if not any(k == "fifo" for k in tl.kind.values())
                        else "no packet went through a FIFO", ha="center", va="center",
                        transform=ax.transAxes, fontsize=9, color="0.4")
        fig.tight_layout()
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=100)
        plt.close(fig)
