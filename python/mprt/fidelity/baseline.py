"""``mprt simulate --baseline FILE.json --tolerance P``: pin a design's replay in CI.

The baseline is the JSON of an earlier ``mprt simulate --json`` (its ``cycles`` and
``stages``).  After the replay, the frame's cycles are compared with the baseline's: a move
beyond P (relative; default 0, a replay is deterministic) is a failure, exit status 3, and
the message says which stages moved (each stage's processing, communication, waiting and
memory-stall cycles and its rays, every figure that moved beyond P, largest first).  A
baseline of other settings (scene, grid, resolution, model) is compared all the same, with a
note naming what differs.
"""
from __future__ import annotations

import json
import os

from ..errors import UsageError

EXIT_MOVED = 3
STAGE_FIGURES = ("processing", "communication", "waiting", "memory_stall", "rays_in")
SETTINGS = ("scene_sha256", "grid", "resolution", "rules", "model", "pes")


def load(path) -> dict:
    """The baseline's figures; UsageError (exit 2, before any work) naming the file when it
    cannot be read or holds no cycles."""
    path = os.fspath(path)
    try:
        with open(path) as f:
            d = json.load(f)
    except OSError as e:
        raise UsageError(f"--baseline {path}: cannot read it ({e.strerror or e})") from None
    except ValueError as e:
        raise UsageError(f"--baseline {path}: not JSON ({e})") from None
    if not isinstance(d, dict) or not isinstance(d.get("cycles"), (int, float)) or isinstance(d.get("cycles"), bool) \
            or not d["cycles"] > 0:
        raise UsageError(f"--baseline {path}: no positive 'cycles' (write one with mprt simulate ... --json FILE)")
    if not isinstance(d.get("stages", {}), dict):
        raise UsageError(f"--baseline {path}: 'stages' is not a table of stages")
    return d


def _move(now, before) -> float:
    return (now - before) / before if before else (0.0 if now == before else float("inf"))


def compare(result: dict, base: dict, tolerance: float, name: str) -> tuple:
    """(moved, lines): whether the cycles moved beyond ``tolerance`` from the baseline, and
    what to print (the cycles' move, the stage figures that moved beyond it, notes)."""
    now, before = result["cycles"], base["cycles"]
    m = _move(now, before)
    moved = abs(m) > tolerance
    lines = []
    diff = [k for k in SETTINGS if k in base.get("settings", {}) and k in result.get("settings", {})
            and base["settings"][k] != result["settings"][k]]
    if diff:
        lines.append(f"note    the baseline {name} has other settings: "
                     + ", ".join(f"{k} {base['settings'][k]!r} (now {result['settings'][k]!r})" for k in diff))
    stages = []
    for s, b in sorted(base.get("stages", {}).items()):
        r = result.get("stages", {}).get(s)
        if r is None:
            stages.append((float("inf"), f"{s} is not in this machine"))
            continue
        for k in STAGE_FIGURES:
            if k in b and k in r:
                dm = _move(r[k], b[k])
                if abs(dm) > tolerance:
                    stages.append((abs(dm), f"{s} {k.replace('_', ' ')} {100 * dm:+.2f}% ({b[k]:,} -> {r[k]:,})"))
    for s in sorted(set(result.get("stages", {})) - set(base.get("stages", {}))):
        stages.append((float("inf"), f"{s} is new (not in the baseline)"))
    stages.sort(key=lambda t: -t[0])
    head = (f"cycles {now:,} against the baseline's {before:,} ({name}): {100 * m:+.2f}%, "
            f"{'beyond' if moved else 'within'} the tolerance of {100 * tolerance:g}%")
    lines.append(("moved   " if moved else "baseline ") + head)
    if moved:
        lines += [f"        {text}" for _, text in stages] or ["        no stage figure moved beyond the tolerance"]
    return moved, lines
