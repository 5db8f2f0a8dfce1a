"""The explorer's level: the fidelity ladder measured on each scene of the workload.

With ``level = "auto"`` the ladder's designs (``ladder_designs``: the space's first design, a
model M and a model S of the space's vocabulary, and two designs of the space drawn with the
seed) are replayed at levels 0, 1 and 3 on each scene's low-resolution trace at the subdivision
the search starts from.  A scene's adequate level is the lowest whose worst error against
level 3 is within the tolerance; the workload's is the highest of its scenes' (so every scene
is modelled well enough).  Level 2 (the ring without memories) is left out: where it would do,
level 3 costs little more.
"""
from __future__ import annotations

import time

import numpy as np

from .evaluate import is_deadlock
from .space import Design, Space, model_m, model_s

LADDER_LEVELS = (0, 1, 3)


def ladder_designs(space: Space, seed: int, extra: int = 2) -> list:
    """The designs the ladder is measured on: the space's first design (every variable at its
    first value), models M and S as designs, and ``extra`` designs of the space drawn with the seed."""
    designs = [space.point(space.canonical([0] * len(space.variables))).design, model_m(), model_s()]
    rng = np.random.default_rng(seed)
    for _ in range(extra):
        idx = [int(rng.integers(v.size)) for v in space.variables]
        designs.append(space.point(space.canonical(idx)).design)
    return list({d.key(): d for d in designs}.values())


def lowest_adequate(table, tolerance: float) -> int:
    """The lowest level whose worst error against the top level is within the tolerance (the top
    level when none is).  ``Table.choose`` takes the fastest measured; the levels are in order of
    cost, and choosing by their order keeps the answer independent of timings on a busy machine."""
    ok = [r.level for r in table.rows if r.error_top_worst <= tolerance]
    return min(ok) if ok else table.rows[-1].level


def measure(run_level, names, designs: list, tolerance: float):
    """One scene's ladder: ``run_level(designs, level) -> (results, seconds)``; returns (chosen
    level, ``fidelity.ladder.Table``)."""
    from ..fidelity.ladder import tabulate

    cycles, seconds, engines = {}, {}, {}
    for lv in LADDER_LEVELS:
        res, secs = run_level(designs, lv)
        for n, r in zip(names, res):
            cycles[n, lv] = None if is_deadlock(r) else r.cycles
        seconds[lv] = [secs / max(len(designs), 1)]
        engines[lv] = {r.engine for r in res if r.engine}
    table = tabulate(names, list(LADDER_LEVELS), cycles, seconds, engines)
    return lowest_adequate(table, tolerance), table


def choose_level(level, tolerance: float, scenes: list, run_level, space: Space, seed: int, say=None) -> dict:
    """The level of the search and of everything after it: as given, or with "auto" the highest
    of the scenes' adequate levels.  ``run_level(k, designs, level) -> (results, seconds)``
    replays designs on scene k's ladder trace.  Returns the report's ``level`` table."""
    if level != "auto":
        if level not in (0, 1, 2, 3):
            raise ValueError(f"level must be 0, 1, 2, 3 or 'auto', not {level!r}")
        return {"asked": level, "search": level, "verify": level}
    designs: list[Design] = ladder_designs(space, seed)
    names = [f"design#{i}" for i in range(len(designs))]
    t0 = time.perf_counter()
    per_scene = []
    for k, name in enumerate(scenes):
        chosen, table = measure(lambda ds, lv: run_level(k, ds, lv), names, designs, tolerance)
        per_scene.append({"scene": name, "level": chosen, "ladder": [r.to_dict() for r in table.rows]})
        if say:
            worst = {r.level: r.error_top_worst for r in table.rows}
            say(f"ladder  {name}: level {chosen} is the lowest within {100 * tolerance:g}% of level 3 "
                f"(worst errors: " + ", ".join(f"level {lv} {100 * e:.2f}%" for lv, e in worst.items()) + ")")
    chosen = max(r["level"] for r in per_scene)
    return {"asked": "auto", "search": chosen, "verify": chosen, "per_scene": per_scene,
            "ladder": per_scene[[r["level"] for r in per_scene].index(chosen)]["ladder"],
            "ladder_seconds": time.perf_counter() - t0}


__all__ = ["LADDER_LEVELS", "choose_level", "ladder_designs", "lowest_adequate", "measure"]
