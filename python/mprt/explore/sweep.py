"""``mprt sweep SPEC.toml --out DIR``: scenes x subdivisions x designs on Dask.

The spec file::

    scenes = ["balls", "tetra:2"]        # SPD names (with size) or NFF paths
    res = "32x32"
    subdivisions = [4, 8, [6, 6, 2]]     # n, or [nx, ny, nz]
    shape = "proportional"               # how one n becomes a grid: cube | proportional
    level = 1                            # fidelity level (0 analytical, 1-3 the compiled replay)
    batch = 64                           # designs per task
    [designs]
    paper = "3mppe"                      # a reference: 3mppe, M, S
    wide = { mapping = "OS|IC|SC", pes = 2 }   # or a design's fields (the rest as the 3MPPE)

writes DIR/sweep.csv (one row per scene, subdivision and design; a design that
deadlocks there, even with one ray tree in flight, has bottleneck ``deadlock`` and
no cycles) and DIR/sweep.png (cycles against subdivision).
"""
from __future__ import annotations

import argparse
import csv
import os
import time

import numpy as np

from .distributed import DiskCache, cache_key, client, map_cached
from .space import REFERENCE_DESIGNS, SHAPES, Design, SpaceError
from ..atomic import open_replacing, replacing

_KEYS = {"scenes", "res", "subdivisions", "shape", "level", "batch", "designs", "rules"}


def load_spec(path) -> dict:
    from ..options import GRID_MAX, read_toml, resolution_arg

    doc = read_toml(path, "sweep spec", SpaceError)
    w = lambda k: f"{path}: {k}"  # noqa: E731
    extra = set(doc) - _KEYS
    if extra:
        raise SpaceError(f"{w(sorted(extra)[0])}: unknown field (known: {', '.join(sorted(_KEYS))})")
    for k in ("scenes", "subdivisions", "designs"):
        if k not in doc:
            raise SpaceError(f"{w(k)}: missing")
    scenes = doc["scenes"]
    if not isinstance(scenes, list) or not scenes or not all(isinstance(s, str) for s in scenes):
        raise SpaceError(f"{w('scenes')}: must be a non-empty list of scene names or paths")
    res = doc.get("res", "32x32")
    try:
        width, height = resolution_arg(str(res))
    except argparse.ArgumentTypeError as e:
        raise SpaceError(f"{w('res')}: {e}") from None
    subs = []
    if not isinstance(doc["subdivisions"], list) or not doc["subdivisions"]:
        raise SpaceError(f"{w('subdivisions')}: must be a non-empty list")
    for i, s in enumerate(doc["subdivisions"]):
        t = s if isinstance(s, list) else [s]
        if len(t) not in (1, 3) or not all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= GRID_MAX
                                           for v in t):
            raise SpaceError(f"{w(f'subdivisions[{i}]')}: {s!r} is not n or [nx, ny, nz] of integers in 1..{GRID_MAX}")
        subs.append(tuple(t))
    shape = doc.get("shape", "cube")
    if shape not in SHAPES:
        raise SpaceError(f"{w('shape')}: {shape!r} is not one of {', '.join(SHAPES)}")
    level = doc.get("level", 1)
    if level not in (0, 1, 2, 3):
        raise SpaceError(f"{w('level')}: {level!r} is not 0, 1, 2 or 3")
    batch = doc.get("batch", 64)
    if isinstance(batch, bool) or not isinstance(batch, int) or not 1 <= batch <= 1 << 16:
        raise SpaceError(f"{w('batch')}: {batch!r} is not an integer in 1..65536")
    rules = doc.get("rules", "paper")
    if rules not in ("paper", "spd"):
        raise SpaceError(f"{w('rules')}: {rules!r} is not paper or spd")
    designs = {}
    if not isinstance(doc["designs"], dict) or not doc["designs"]:
        raise SpaceError(f"{w('designs')}: must be a table of named designs")
    for name, d in doc["designs"].items():
        if isinstance(d, str):
            if d not in REFERENCE_DESIGNS:
                raise SpaceError(f"{w(f'designs.{name}')}: {d!r} is not one of {', '.join(REFERENCE_DESIGNS)}")
            designs[name] = REFERENCE_DESIGNS[d]()
        elif isinstance(d, dict):
            designs[name] = Design.from_dict(d, w(f"designs.{name}"))
        else:
            raise SpaceError(f"{w(f'designs.{name}')}: a reference name or a table of design fields")
    return {"scenes": scenes, "width": width, "height": height, "subdivisions": subs, "shape": shape,
            "level": level, "batch": batch, "designs": designs, "rules": rules}


_TRACES: dict = {}


def _batch_task(scene_spec, dims, width, height, rules, level, designs):
    """One task: trace the scene at this grid (kept per worker process for
    the next batch) and evaluate the designs; returns rows of plain values."""
    from ..scene import Scene
    from .evaluate import TraceEvaluator

    key = (scene_spec, tuple(dims), width, height, rules)
    ev = _TRACES.get(key)
    if ev is None:
        _TRACES.clear()
        _, tr = Scene.load(scene_spec).grid(tuple(dims)).trace(width, height, rules=rules)
        ev = _TRACES[key] = TraceEvaluator(tr)
    return [ev.run(Design.from_dict(d), level).to_dict() for d in designs]


def run_sweep(spec: dict, out_dir, scheduler=None, workers=None, progress=None) -> dict:
    from ..scene import Scene
    from .evaluate import grid_dims

    t0 = time.perf_counter()
    os.makedirs(out_dir, exist_ok=True)
    cache = DiskCache(os.path.join(out_dir, "cache"))
    names = list(spec["designs"])
    tasks, where = [], []
    for sc in spec["scenes"]:
        scene = Scene.load(sc)
        h = scene.content_hash()
        for sub in spec["subdivisions"]:
            dims = grid_dims(scene, sub, spec["shape"])
            for a in range(0, len(names), spec["batch"]):
                part = names[a:a + spec["batch"]]
                ds = [spec["designs"][n].to_dict() for n in part]
                key = cache_key("sweep", h, dims, spec["width"], spec["height"], spec["rules"], spec["level"], ds)
                tasks.append((key, (sc, list(dims), spec["width"], spec["height"], spec["rules"], spec["level"],
                                    ds)))
                where.append((sc, sub, dims, part))
    everything_cached = all(cache.get(k) is not None for k, _ in tasks)
    with client(scheduler, 0 if everything_cached else workers) as c:
        results, cached = map_cached(tasks, _batch_task, cache, c, progress)
    rows = []
    for (sc, sub, dims, part), res in zip(where, results):
        for name, r in zip(part, res):
            row = {"scene": sc, "subdivision": "x".join(map(str, dims)), "n": sub[0] if len(sub) == 1 else "",
                   "design": name, "cycles": "" if r["bottleneck"] == "deadlock" else r["cycles"],   # (no count)
                   "cost": r["cost"], "bottleneck": r["bottleneck"],
                   "level": r["level"], "costs": r["costs"]}
            for p, u in r["utilisation"].items():
                row[f"util_{p}"] = round(u, 6)
            rows.append(row)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    path = os.path.join(out_dir, "sweep.csv")
    with open_replacing(path, newline="") as f:
        wr = csv.DictWriter(f, fieldnames=fields, restval="")
        wr.writeheader()
        wr.writerows(rows)
    png = os.path.join(out_dir, "sweep.png")
    _plot(rows, spec, png)
    return {"csv": path, "png": png, "rows": len(rows), "tasks": len(tasks), "cached": cached,
            "seconds": time.perf_counter() - t0}


def _plot(rows, spec, path):
    """sweep.png, and the Figure: per scene (two panels a row, as wide as a report page) the cycles
    of each design against the subdivision on a log scale, a deadlock an x on the axis and a gap in
    the line; one legend.  Over 8 designs: the 8 fastest (report.sweep_answer's ranking) in colour,
    the rest grey and unnamed."""
    from .. import figures
    from ..report import sweep_answer

    scenes, names = spec["scenes"], list(spec["designs"])
    ranked = sweep_answer(rows)["ranked"]
    named = (ranked + [n for n in names if n not in ranked])[:8]
    colour = {n: f"C{i}" for i, n in enumerate(sorted(named, key=names.index))}
    ncols = 1 if len(scenes) == 1 else 2
    nrows = -(-len(scenes) // ncols)
    fig, axes = figures.figure(3.4 * nrows, nrows, ncols)
    handles, dead_any = {}, False
    for i, ax in enumerate(axes.flat):
        if i >= len(scenes):
            ax.set_visible(False)
            continue
        sc = scenes[i]
        labels = list(dict.fromkeys(r["subdivision"] for r in rows if r["scene"] == sc))
        for name in names:
            mine = [r for r in rows if r["scene"] == sc and r["design"] == name]
            xs = [labels.index(r["subdivision"]) for r in mine]
            ys = [np.nan if r["cycles"] == "" else r["cycles"] for r in mine]    # a deadlock: a gap in the line
            c = colour.get(name, "0.75")
            (line,) = ax.plot(xs, ys, marker="o", color=c, lw=2 if name in colour else 1,
                              zorder=3 if name in colour else 2)
            if name in colour:
                handles.setdefault(name, line)
            dead = [x for x, y in zip(xs, ys) if np.isnan(y)]
            if dead:        # on the axis (x in data, y in the axes' fraction): no cycles to place it at
                dead_any = True
                ax.plot(dead, [0.04] * len(dead), ls="", marker="x", ms=9, mew=2, color=c,
                        transform=ax.get_xaxis_transform(), clip_on=False, zorder=4)
        ax.set_yscale("log")
        figures.cycles_axis(ax.yaxis, log=True)
        figures.index_axis(ax.xaxis, labels)
        ax.set_xlim(-0.5, len(labels) - 0.5)
        ax.set(title=sc, xlabel="subdivision (cells in x, y, z)", ylabel="cycles")
        ax.grid(True, which="major", axis="y", color="0.9")
    from matplotlib.lines import Line2D
    leg = [handles[n] for n in names if n in handles]
    lab = [n for n in names if n in handles]
    if len(names) > len(named):
        leg.append(Line2D([], [], color="0.75", marker="o"))
        lab.append(f"{len(names) - len(named)} more designs")
    if dead_any:
        leg.append(Line2D([], [], ls="", marker="x", ms=9, mew=2, color="0.3"))
        lab.append("deadlocks there\n(no cycles)")
    figures.legend_outside(fig, handles=leg, labels=lab, title="design")
    figures.readable(fig)
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=fig.dpi)
    return fig
