"""What the explorer's answer is set against: the paper's machines on each scene at their own
subdivision (``references``), and each scene's own best machine under the same budget
(``own_best``, for ``sharing``: what a scene gives up by sharing the chip)."""
from __future__ import annotations

from dataclasses import replace

from .hwcost import hardware_cost
from .problem import Problem
from .search import compass


class Compare:
    """The references and each scene's own best, mixed into the explorer (they run through it)."""

    def references(self, lv: int) -> dict:
        """The 3MPPE at each scene's own best subdivision (descended at full resolution from its
        low-resolution one); models M and S at the 3MPPE's subdivision."""
        out = {}
        any_full = any(s.full != s.low for s in self.scenes)
        dims3 = []
        for s in self.scenes:
            d = s.ref_dims
            if any_full:
                d, _ = self.descend(s.index, self.refs["3mppe"], lv, s.ref_dims, full=True)
            dims3.append(d)
        for name, cfg in self.refs.items():
            got = self.run([(s.index, d, cfg) for s, d in zip(self.scenes, dims3)], lv, "full")
            out[name] = {"machine": cfg.to_dict(), "cost": self.cost(cfg), "cost_breakdown": self.breakdown(cfg),
                         "per_scene": [{"scene": s.entry.name, "subdivision": list(d),
                                        "cycles": None if r.deadlocked else r.cycles, "deadlock": r.deadlocked,
                                        "utilisation": r.utilisation, "bottleneck": r.bottleneck}
                                       for s, d, r in zip(self.scenes, dims3, got)]}
            if len(self.scenes) == 1:
                out[name]["cycles"] = out[name]["per_scene"][0]["cycles"]
        for s, row, m in zip(self.scenes, out["3mppe"]["per_scene"], out["M"]["per_scene"]):
            s.ref_full = row["cycles"] if row["cycles"] is not None else m["cycles"]
        return out

    def own_best(self, problem, lv: int, full_rows) -> list:
        """Per scene: the best machine of the search's for that scene alone under the budget, walked
        a little further on that scene alone (``own_evals``), at full resolution."""
        if problem is None:
            return [None] * len(self.scenes)
        out = []
        hw = problem.space
        evals = self.opts.own_evals if self.opts.own_evals is not None else 8 * len(problem.free)
        for j, s in enumerate(self.scenes):
            if len(self.scenes) == 1:
                out.append(None)        # the answer is its own best
                continue
            single = Problem(hw, lambda pts, j=j: [self.per_scene([(j, self.scenes[j].dims, p.design)], lv)[0][0]
                                                   for p in pts], "time", self.opts.budget,
                             cost_of=lambda p: hardware_cost(p.design, self.unit_costs))
            for e in problem.memo.values():
                rows = self.per_scene_memo.get((e.point.design.key(), tuple(x.dims for x in self.scenes)))
                if rows is not None and not e.bound:
                    single.add(e.point, replace(rows[j], cost=e.cost))
            start = single.best()
            if start is None:
                out.append(None)
                continue
            if evals > 0:
                compass(single, start.index, evals)
            d = single.best().point.design
            r = self.per_scene([(j, full_rows[j][0], d)], lv, "full")[0][0]
            out.append((d, full_rows[j][0], r))
        return out


__all__ = ["Compare"]
