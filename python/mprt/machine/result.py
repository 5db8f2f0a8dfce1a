"""SimResult (the figures of a run), Timeline (binned series for plots) and the plots."""
from __future__ import annotations

import json
from dataclasses import dataclass, field

from ..util.atomic import replacing

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
    def plot(self, path, title: str | None = None):
        """PNG (and the Figure): per-stage load bars (processing / communication / waiting, as the
        paper's figure 6), and with a timeline each processor's utilisation over time and the
        FIFOs' occupancy (over time where the engine logs it, SimPy's; else each FIFO's mean and
        most, as the compiled replay counts them).  As wide as a report page, its text at least
        the page's body size (mprt.figures)."""
        from ..util import figures

        tl = self.timeline
        nplots = 3 if tl is not None else 1
        fig, axes = figures.figure(3.0 * nplots + 0.4, nplots, 1)
        fig.suptitle(title or f"model {self.model}: {self.cycles:,} cycles", fontsize=figures.body_points(fig) * 1.2)
        ax = axes[0][0]
        colours = {"processing": "#4878a8", "communication": "#e0a040", "waiting": "#c8c8c8"}
        left = [0.0] * 3
        for c in CATEGORIES:
            vals = [self.stages[t][c] for t in SUBTASKS]
            ax.barh(SUBTASKS, vals, left=left, color=colours[c], label=c)
            left = [b + v for b, v in zip(left, vals)]
        ax.invert_yaxis()
        figures.cycles_axis(ax.xaxis)
        ax.set(xlabel="cycles (summed over the PEs)", title="where each stage's time goes")
        figures.legend_outside(ax)
        if tl is not None:
            tl.finish(self.cycles)
            ax = axes[1][0]
            for name, kind in tl.kind.items():
                if kind == "busy":
                    reps = self.nodes.get(name.split(".", 1)[1], {}).get("replicas", 1)
                    t, v = tl.mean_series(name, self.cycles, reps)
                    ax.plot(t, v, label=name, lw=1.5)
            ax.set_ylim(0, 1.05)
            figures.percent_axis(ax.yaxis)
            figures.cycles_axis(ax.xaxis)
            ax.set(ylabel="busy", xlabel="cycle", title="utilisation of each processor over time")
            figures.legend_outside(ax)
            ax = axes[2][0]
            series = [(name, tl.mean_series(name, self.cycles)) for name, kind in tl.kind.items()
                      if kind == "fifo" and self.fifos.get(name, {}).get("packets")]
            used = [(name, f) for name, f in self.fifos.items() if f.get("packets")]
            if series:
                for name, (t, v) in series:
                    ax.plot(t, v, label=name, lw=1.5)
                figures.cycles_axis(ax.xaxis)
                figures.thousands_axis(ax.yaxis, integer=False)
                ax.set(ylabel="packets", xlabel="cycle", title="FIFO occupancy over time")
                figures.legend_outside(ax)
            elif used:      # the compiled replay counts each FIFO's mean and most, not its level over time
                y = range(len(used))
                ax.barh([i - 0.2 for i in y], [f["mean"] for _, f in used], 0.4, color="#4878a8", label="mean")
                ax.barh([i + 0.2 for i in y], [f["max"] for _, f in used], 0.4, color="#e0a040", label="most")
                ax.set_yticks(list(y), [name for name, _ in used])
                ax.invert_yaxis()
                figures.thousands_axis(ax.xaxis)
                ax.set(xlabel="packets", title="FIFO occupancy (this engine counts its mean and most, not a "
                                                  "timeline: --engine simpy draws one)")
                figures.legend_outside(ax)
            else:
                ax.set_axis_off()
                ax.text(0.5, 0.5, "No packet went through a FIFO." if any(k == "fifo" for k in tl.kind.values())
                        else "No FIFO figures: this engine logs visits, not FIFO levels (--engine simpy draws them).",
                        ha="center", va="center", transform=ax.transAxes, color="0.3")
        figures.readable(fig)
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=fig.dpi)
        return fig
