"""``mprt sweep SPEC.toml --out DIR``: scenes x subdivisions x designs on Dask.

The spec file::

    res = "32x32"                        # every scene's, unless it says (default 32x32)
    rules = "paper"                      # every scene's, unless it says: paper | spd | paper1992
    subdivisions = [4, 8, [6, 6, 2]]     # n, or [nx, ny, nz]
    shape = "proportional"               # how one n becomes a grid: cube | proportional
    level = 1                            # fidelity level (0 analytical, 1-3 the compiled replay)
    batch = 64                           # designs per task

    [[scene]]                            # the workload file's scene entries (mprt explore --workload)
    name = "balls:2"                     # an SPD name (with size) or an NFF path
    [[scene]]
    name = "room.nff"                    # a relative path is read from the spec's folder first
    res = "64x64"                        # its own res, rules, threshold, skip_unknown, max_rays,
    skip_unknown = true                  #   max_depth (weight is allowed and not used)
    max_depth = 8

    [designs]
    paper = "3mppe"                      # a built-in machine: 3mppe, M or S (simulate --model's)
    wide = { mapping = "OS|IC|SC", pes = 2 }          # a design: its fields, the rest as base's
    os3 = { units = { OS = { int = 3 } } }           # tables merged key by key (OS keeps fp = 2)
    os3x2 = { base = "os3", replication = { IC = 2 } }    # base: another design here, or "default"
    mine = { machine = "mine.toml" }     # a machine file (spec's folder first), as simulate --config

A list ``scenes = ["balls", "tetra:2"]`` is the same as [[scene]] tables of only a name;
--skip-unknown is skip_unknown for the scenes that do not say.  A design's base is "default"
(the explorer's base design: 2 int + 2 FP OS, 1 int + 3 FP IC, a general SC, 256-word FIFOs,
16/4 KiB caches, 1 PE) unless it says; a unit kind it leaves out keeps the base's, 0 removes it.

writes DIR/sweep.csv (one row per scene, subdivision and design, the scene named as given; a
design that deadlocks there, even with one ray tree in flight, has bottleneck ``deadlock`` and
no cycles) and DIR/sweep.png (cycles against subdivision).
"""
from __future__ import annotations

import csv
import dataclasses
import math
import os
import time

import numpy as np

from .distributed import DiskCache, cache_key, client, map_cached
from .evaluate import is_deadlock
from .space import SHAPES, Design, SpaceError
from ..util.atomic import open_replacing, replacing

_KEYS = {"scene", "scenes", "res", "subdivisions", "shape", "level", "batch", "designs", "rules"}
_DESIGN_FIELDS = ("mapping", "replication", "feed", "units", "fifo", "cache", "resident", "pes")


def load_spec(path, skip_unknown: bool = False) -> dict:
    """A sweep spec (the module's text), checked: errors name the file and the field.
    ``skip_unknown``: the default of the scenes that do not say (``--skip-unknown``).
    "scenes": the scene names as given, "entries": their ``workload.SceneEntry``s (each with
    its res and rules, the spec's where it gives none), "designs": name -> Design or SystemConfig."""
    from ..settings import GRID_MAX, BadValue, read_toml, resolution
    from .workload import RULES, WorkloadError, scene_entries

    path = os.fspath(path)
    doc = read_toml(path, "sweep spec", SpaceError)
    folder = os.path.dirname(os.path.abspath(path))
    w = lambda k: f"{path}: {k}"  # noqa: E731
    extra = set(doc) - _KEYS
    if extra:
        raise SpaceError(f"{w(sorted(extra)[0])}: unknown field (known: {', '.join(sorted(_KEYS))})")
    if "scene" in doc and "scenes" in doc:
        raise SpaceError(f"{w('scenes')}: give [[scene]] tables or scenes = [...], not both")
    if "scene" not in doc and "scenes" not in doc:
        raise SpaceError(f"{w('scene')}: missing ([[scene]] tables with name = ..., or scenes = [...])")
    for k in ("subdivisions", "designs"):
        if k not in doc:
            raise SpaceError(f"{w(k)}: missing")
    res = doc.get("res", "32x32")
    try:
        width, height = resolution(str(res))
    except BadValue as e:
        raise SpaceError(f"{w('res')}: {e}") from None
    rules = doc.get("rules", "paper")
    if rules not in RULES:
        raise SpaceError(f"{w('rules')}: {rules!r} is not one of {', '.join(RULES)}")
    key = "scene" if "scene" in doc else "scenes"
    try:
        entries = scene_entries(doc[key], w(key), folder)
    except WorkloadError as e:
        raise SpaceError(str(e)) from None
    seen = {}
    for i, e in enumerate(entries):
        if e.name in seen:
            raise SpaceError(f"{w(f'{key}[{i}]')}: {e.name!r} again (scene[{seen[e.name]}]): a sweep's rows "
                             "name each scene once")
        seen[e.name] = i
    said = [isinstance(x, dict) and "skip_unknown" in x for x in doc[key]]    # (false too: not the default's)
    entries = [_absolute(e.with_defaults(res=(width, height), rules=rules, skip_unknown=skip_unknown and not s))
               for e, s in zip(entries, said)]
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
    if isinstance(level, bool) or not isinstance(level, int) or level not in (0, 1, 2, 3):
        raise SpaceError(f"{w('level')}: {level!r} is not 0, 1, 2 or 3")
    batch = doc.get("batch", 64)
    if isinstance(batch, bool) or not isinstance(batch, int) or not 1 <= batch <= 1 << 16:
        raise SpaceError(f"{w('batch')}: {batch!r} is not an integer in 1..65536")
    designs = _designs(doc["designs"], path, folder)
    return {"scenes": [e.name for e in entries], "entries": entries, "width": width, "height": height,
            "subdivisions": subs, "shape": shape, "level": level, "batch": batch, "designs": designs,
            "rules": rules, "source": path}


def _absolute(entry):
    """The entry with its NFF file's path absolute (a Dask worker may run elsewhere)."""
    return entry if entry.path is None else dataclasses.replace(entry, path=os.path.abspath(entry.path))


def _designs(table, path: str, folder: str) -> dict:
    """The [designs] table: name -> Design (a table of fields over its base) or SystemConfig
    (a built-in machine's name, or ``machine = "file.toml"``), in the spec's order."""
    from ..machine.config import BUILTIN, builtin

    if not isinstance(table, dict) or not table:
        raise SpaceError(f"{path}: designs: must be a table of named designs")
    if "default" in table:
        raise SpaceError(f"{path}: designs.default: \"default\" names the default design (base = \"default\"); "
                         "call this design something else")
    done, busy = {}, []

    def resolve(name):
        if name in done:
            return done[name]
        where = f"{path}: designs.{name}"
        if name in busy:
            ring = " -> ".join(busy[busy.index(name):] + [name])
            raise SpaceError(f"{path}: designs.{busy[-1]}.base: the bases go round ({ring})")
        busy.append(name)
        d = table[name]
        if isinstance(d, str):
            if d not in BUILTIN:
                raise SpaceError(f"{where}: {d!r} is not a built-in machine ({', '.join(BUILTIN)}); a machine file "
                                 "is { machine = \"file.toml\" }, a design a table of its fields")
            m = builtin(d)
        elif isinstance(d, dict):
            known = _DESIGN_FIELDS + ("base", "machine")
            extra = sorted(set(d) - set(known))
            if extra:
                raise SpaceError(f"{where}.{extra[0]}: unknown field (known: {', '.join(known)})")
            if "machine" in d:
                other = sorted(set(d) - {"machine"})
                if other:
                    raise SpaceError(f"{where}.{other[0]}: a design with machine = ... is that file's machine; "
                                     "give it no other field")
                m = _machine_file(d["machine"], f"{where}.machine", folder)
            else:
                b = d.get("base", "default")
                if not isinstance(b, str):
                    raise SpaceError(f"{where}.base: {b!r} is not a design's name (or \"default\")")
                if b == "default":
                    base = Design()
                elif b in table:
                    base = resolve(b)
                    if not isinstance(base, Design):
                        raise SpaceError(f"{where}.base: {b!r} is a whole machine, not a design of fields (a "
                                         "partial design's base is a table of design fields or \"default\")")
                else:
                    raise SpaceError(f"{where}.base: {b!r} is neither a design of this spec "
                                     f"({', '.join(table)}) nor \"default\"")
                m = Design.from_dict({k: v for k, v in d.items() if k != "base"}, where, base=base)
        else:
            raise SpaceError(f"{where}: a built-in machine's name ({', '.join(BUILTIN)}) or a table of design "
                             f"fields, not {d!r}")
        busy.pop()
        done[name] = m
        return m

    return {name: resolve(name) for name in table}


def _machine_file(name, where: str, folder: str):
    """The SystemConfig of a machine file named in the spec (its folder first, then here)."""
    from ..machine.config import load_config
    from ..machine.errors import ConfigError

    if not isinstance(name, str) or not name:
        raise SpaceError(f"{where}: {name!r} is not a machine file's path")
    tried = ([os.path.join(folder, name)] if not os.path.isabs(name) else []) + [name]
    found = next((p for p in tried if os.path.isfile(p)), None)
    if found is None:
        raise SpaceError(f"{where}: no machine file {name!r} (looked for "
                         f"{' and '.join(repr(p) for p in dict.fromkeys(tried))})")
    try:
        return load_config(found)
    except ConfigError as e:
        raise SpaceError(f"{where}: {e}") from None


def _portable(m):
    """A design as a task carries it: a Design's fields, a machine as its machine file's text (a
    configuration does not pickle)."""
    from ..machine.config import config_toml

    return m.to_dict() if isinstance(m, Design) else ["machine file", config_toml(m)]


def _machine(p):
    """The Design or SystemConfig a task's ``_portable`` form stands for."""
    from .runner import config_of_text

    return Design(**p) if isinstance(p, dict) else config_of_text(p[1])


def _cost(m) -> float:
    """A machine's hardware cost (kGE) at the default unit costs."""
    from .hwcost import machine_breakdown

    return float(sum(machine_breakdown(m).values()))


def load_scene(entry):
    """The Scene of a scene entry; an unknown entity's error says how to skip such entities."""
    from ..errors import SceneParseError

    try:
        return entry.load()
    except SceneParseError as e:
        if "unknown entity" in str(e) and not entry.skip_unknown:
            raise SceneParseError(f"{e} (skip_unknown = true in its [[scene]] table, or --skip-unknown, reads the "
                                  "file without the entities mprt does not know)") from None
        raise


def check_memory(spec: dict, workers: int | None):
    """Before any work: a sweep's workers each hold one traced frame (scene at its res,
    subdivision) at a time; the largest must fit every worker (else MemoryRefused)."""
    from ..memory_estimate import for_frames, workers_of
    from .evaluate import grid_dims

    worst = None
    for e in spec["entries"]:
        scene = load_scene(e)
        voxels = max(int(np.prod(grid_dims(scene, sub, spec["shape"]))) for sub in spec["subdivisions"])
        est = for_frames("", [(e.res[0], e.res[1], (voxels,), scene.info()["prims"])], workers_of(workers))
        if worst is None or est.total > worst.total:
            worst = est
    worst.check()
    return worst


_TRACES: dict = {}
_SCENES: dict = {}


def _batch_task(entry, dims, level, machines, scene_hash=None):
    """One task: trace the scene entry (its res and trace options) at this grid (kept per worker
    process for the next batch) and evaluate the machines (``_portable`` forms); returns rows of
    plain values.  ``scene_hash``: the content hash the scene read here must have."""
    from ..errors import MprtError
    from .evaluate import TraceEvaluator

    key = (entry, tuple(dims))
    ev = _TRACES.get(key)
    if ev is None:
        _TRACES.clear()
        scene = _SCENES.get(entry)
        if scene is None:
            scene = load_scene(entry)
            if scene_hash is not None and scene.content_hash() != scene_hash:
                raise MprtError(f"{entry.name}: the scene read on this worker differs from the one swept (content "
                                f"hash {scene.content_hash()[:12]} against {scene_hash[:12]})")
            _SCENES.clear()
            _SCENES[entry] = scene
        _, tr = scene.grid(tuple(dims)).trace(entry.res[0], entry.res[1], **entry.trace_options())
        ev = _TRACES[key] = TraceEvaluator(tr)
    out = []
    for p in machines:
        m = _machine(p)
        r = ev.run(m, level) if isinstance(m, Design) else ev.run_config(m, level, cost=_cost(m))
        out.append(r.to_dict())
    return out


def run_sweep(spec: dict, out_dir, scheduler=None, workers=None, progress=None, note=None) -> dict:
    """Every design on every scene entry at every subdivision (load_spec's ``spec``), to
    ``out_dir``/sweep.csv and sweep.png through its cache; ``note(text)``: an NFF reader's notes
    (entities skipped, ...), one call each (default: none shown)."""
    from ..settings import command_line_note
    from .evaluate import grid_dims

    t0 = time.perf_counter()
    os.makedirs(out_dir, exist_ok=True)
    cache = DiskCache(os.path.join(out_dir, "cache"))
    names = list(spec["designs"])
    entries = spec.get("entries") or _entries_of(spec)
    tasks, where = [], []
    for e in entries:
        scene = load_scene(e)
        for line in scene.notes if note else ():
            note(f"{e.name}: {command_line_note(scene, line)}")
        h = scene.content_hash()
        for sub in spec["subdivisions"]:
            dims = grid_dims(scene, sub, spec["shape"])
            for a in range(0, len(names), spec["batch"]):
                part = names[a:a + spec["batch"]]
                ms = [_portable(spec["designs"][n]) for n in part]
                key = cache_key("sweep", h, e.res, e.trace_options(), dims, spec["level"], ms)
                tasks.append((key, (e, list(dims), spec["level"], ms, h)))
                where.append((e.name, sub, dims, part))
    everything_cached = all(cache.get(k) is not None for k, _ in tasks)
    with client(scheduler, 0 if everything_cached else workers) as c:
        results, cached = map_cached(tasks, _batch_task, cache, c, progress)
    rows = []
    for (sc, sub, dims, part), res in zip(where, results):
        for name, r in zip(part, res):
            row = {"scene": sc, "subdivision": "x".join(map(str, dims)), "n": sub[0] if len(sub) == 1 else "",
                   "design": name, "cycles": "" if is_deadlock(r) else r["cycles"],   # (no count)
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


def _entries_of(spec: dict) -> list:
    """The scene entries of a spec made without load_spec (scene names, the spec's res and rules)."""
    from .workload import scene_entry

    return [_absolute(scene_entry(s, f"scene {s!r}").with_defaults(res=(spec["width"], spec["height"]),
                                                                   rules=spec.get("rules", "paper")))
            for s in spec["scenes"]]


def row_cycles(v):
    """A sweep row's cycles as a number, None where the design deadlocked ("" in the CSV)."""
    return None if v in ("", None) else float(v)


def _geomean(xs) -> float:
    return math.exp(sum(math.log(x) for x in xs) / len(xs))


def sweep_answer(rows) -> dict:
    """What a sweep found, from its rows (dicts with scene, subdivision, design and cycles, "" or
    None where the design deadlocked; the CSV's or run_sweep's): "best", per (scene, design) its
    fewest cycles and the row that has them (its best subdivision); "geomean", per design the
    geometric mean over the scenes of those cycles (None if it deadlocks at every subdivision of
    some scene); "ranked", the designs with a geometric mean, fewest cycles first (ties in the
    spec's order); "scenes", "designs" in their order."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    designs = list(dict.fromkeys(r["design"] for r in rows))
    best: dict = {}
    for r in rows:
        c = row_cycles(r["cycles"])
        k = (r["scene"], r["design"])
        if c is not None and (k not in best or c < best[k][0]):
            best[k] = (c, r)
    geo = {d: _geomean([best[(s, d)][0] for s in scenes]) if all((s, d) in best for s in scenes) else None
           for d in designs}
    ranked = sorted((d for d in designs if geo[d] is not None), key=lambda d: (geo[d], designs.index(d)))
    return {"scenes": scenes, "designs": designs, "best": best, "geomean": geo, "ranked": ranked}


def _plot(rows, spec, path):
    """sweep.png, and the Figure: per scene (two panels a row, as wide as a report page) the cycles
    of each design against the subdivision on a log scale, a deadlock an x on the axis and a gap in
    the line; one legend.  Over 8 designs: the 8 fastest (sweep_answer's ranking) in colour,
    the rest grey and unnamed."""
    from ..util import figures

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
