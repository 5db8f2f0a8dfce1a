"""The ``scene``, ``render``, ``trace`` and ``stats`` subcommands: scenes, renders, traces and
their statistics (``mprt.cli`` builds the parser and runs them)."""
from __future__ import annotations

import os
import shutil
import sys
import threading
import time
import zlib

import numpy as np

from . import options
from ..trace import tracefile
from ..grid import render_desc, write_png
from .options import UsageError
from ..scene import SPD_SCENES
from ..trace import load_trace
from ..trace.tracing import select_tiles, trace, trace_records
from ..util.atomic import open_replacing

EPILOG = options.EXIT_STATUS


def _size(n: float) -> str:
    """A byte count for people: 972 MB, 15.1 GB, 34 kB."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            v = n / scale
            return f"{v:.1f} {unit}" if v < 100 else f"{v:.0f} {unit}"
    return f"{int(n)} bytes"


def _progress_wanted(a) -> bool:
    return bool(a.progress) or sys.stderr.isatty()


# -- mprt scene ---------------------------------------------------------------------------------
def cmd_scene(a) -> int:
    name, colon, size = a.name.partition(":")
    if name not in SPD_SCENES:
        raise UsageError(f"unknown SPD scene {name!r}; choose one of {', '.join(SPD_SCENES)} (with an optional :SIZE)")
    if colon and a.size is not None:
        raise UsageError(f"give the size once: {a.name} or --size {a.size}, not both")
    n = options.spd_size(name, size if colon else a.size)
    options.check_outputs(("-o", a.output, "nff"))
    scene, _ = options.load_scene(name if n is None else f"{name}:{n}")
    text = scene.to_nff()
    if a.output:
        with open_replacing(a.output) as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


# -- mprt render --------------------------------------------------------------------------------
def _scene_and_grid(a):
    """The scene, how it was chosen, its grid and the resolved render description; prints the
    scene and grid lines."""
    t0 = time.perf_counter()
    scene, how = options.load_scene(a.scene, skip_unknown=a.skip_unknown)
    t1 = time.perf_counter()
    grid = scene.grid(a.grid, listing=a.listing)
    t2 = time.perf_counter()
    desc = grid.resolve(render_desc(**options.render_kwargs(a)))
    info, gs = scene.info(), grid.stats()
    print(f"scene   {scene.name}, {how}: {info['prims']} primitives "
          + ", ".join(f"{v} {k}" for k, v in info["count"].items() if v)
          + f"; {info['lights']} lights" + (f"; {info['dropped']} dropped ({info['warning']})" if info["dropped"] else ""))
    print(f"grid    {'x'.join(map(str, gs['n']))}: {gs['nonempty']} of {gs['voxels']} voxels non-empty, "
          f"mean list {gs['mean_len']:.2f}, max {gs['max_len']}, {gs['bytes'] / 1e6:.1f} MB")
    return scene, how, grid, desc, {"load": t1 - t0, "grid": t2 - t1}


def _render(grid, kw: dict, desc: dict, show: bool, force: bool):
    """Grid.render, with a progress bar when ``show``: the render is one library call, so its
    time is estimated from a render at 1/8 of the size each way (about 1.6% more work) and the
    bar follows the clock; shown when the estimate is over a second, or always when ``force``."""
    if not show:
        return grid.render(**kw)
    w, h = desc["width"], desc["height"]
    sw, sh = max(1, w // 8), max(1, h // 8)
    t0 = time.perf_counter()
    grid.render(**dict(kw, width=sw, height=sh))
    estimate = (time.perf_counter() - t0) * (w * h) / (sw * sh)
    if estimate < 1.0 and not force:
        return grid.render(**kw)
    out = {}

    def work():
        try:
            out["result"] = grid.render(**kw)
        except BaseException as e:  # handed to the caller's thread
            out["error"] = e

    worker = threading.Thread(target=work, daemon=True)
    start = time.perf_counter()
    worker.start()
    from tqdm import tqdm          # (here: importing it costs tens of ms, paid only where a bar is shown)

    with tqdm(total=max(round(estimate, 1), 0.1), unit="s", desc="render (time estimated)", leave=False,
              bar_format="{desc}: {percentage:3.0f}% |{bar}| {n:.1f}/{total:.1f} s", file=sys.stderr) as bar:
        while worker.is_alive():
            worker.join(0.2)
            bar.n = min(time.perf_counter() - start, bar.total * 0.99)
            bar.refresh()
        bar.n = bar.total
        bar.refresh()
    if "error" in out:
        raise out["error"]
    return out["result"]


def cmd_render(a) -> int:
    options.check_render_options(a)
    options.check_outputs(("-o", a.output, "png"), ("--json", a.json, "json"))
    t0 = time.perf_counter()
    scene, how, grid, desc, times = _scene_and_grid(a)
    t2 = time.perf_counter()
    image, counters = _render(grid, options.render_kwargs(a), desc, _progress_wanted(a), a.progress)
    times["render"] = time.perf_counter() - t2
    print(f"image   {desc['width']}x{desc['height']}, rules {a.rules}"
          + (f", threshold {options.fraction_text(desc['threshold'])}" if a.rules == "paper" else ""))
    for k, v in counters.items():
        print(f"  {k:18s} {v}")
    print(f"time    load {times['load']:.3f} s, grid {times['grid']:.3f} s, render {times['render']:.3f} s "
          f"({desc['threads']} thread(s))")
    if a.output:
        write_png(a.output, image)
        print(f"wrote   {a.output}")
    if a.json:
        info, gs = scene.info(), grid.stats()
        options.write_json(a.json, {
            **counters,
            "scene_stats": {"primitives": info["prims"], "by_kind": info["count"], "lights": info["lights"],
                            "dropped": info["dropped"], "ks_t_over_1": scene.over_one()},
            "grid_stats": gs,
            "settings": options.run_settings(scene, grid, desc, how, argv=a.argv),
            "seconds": times,
            "wall_seconds": time.perf_counter() - t0,
        })
        print(f"wrote   {a.json}")
    return 0


# -- mprt trace ---------------------------------------------------------------------------------
def _check_selection(a, tiling, tile: int) -> None:
    """--tiles and --sample against the image's tiles: refuse what cannot be done as asked."""
    sw, sh, tx, ty = tiling
    ntiles = tx * ty
    what = f"{sw}x{sh} samples make {tx}x{ty} = {ntiles} tiles of {tile}x{tile}"
    if a.tiles is not None and max(a.tiles) >= ntiles:
        raise UsageError(f"--tiles {','.join(map(str, a.tiles))}: tile {max(a.tiles)} does not exist ({what}: "
                         f"tiles 0..{ntiles - 1})")
    if a.sample and a.sample.startswith("random:") and int(a.sample.split(":")[1]) > ntiles:
        raise UsageError(f"--sample {a.sample} asks for {a.sample.split(':')[1]} tiles but {what}; ask for at most "
                         f"{ntiles}, or leave --sample out to trace them all")


ESTIMATE_TILES = 16    # tiles traced to estimate a trace's size: this many, or 1% of the run if more
ESTIMATE_FROM = 64     # estimate only runs of at least this many tiles


ESTIMATE_BLOCKS, ESTIMATE_BLOCK = 16, 1 << 16   # deflated to estimate --compress: at most 1 MiB of each array


def _deflate_sample(a) -> tuple:
    """(bytes, scale): what to deflate (at --compress's level) to estimate the array's deflated
    size, and the factor to scale that by: its bytes, or ESTIMATE_BLOCKS blocks spread over them
    when more (copies: the array itself may go)."""
    b = a.view(np.uint8).reshape(-1)
    if b.size <= ESTIMATE_BLOCKS * ESTIMATE_BLOCK:
        return b.tobytes(), 1.0
    step = (b.size - ESTIMATE_BLOCK) // (ESTIMATE_BLOCKS - 1)
    part = b"".join(b[i * step:i * step + ESTIMATE_BLOCK].tobytes() for i in range(ESTIMATE_BLOCKS))
    return part, b.size / len(part)


def _estimate(grid, kw: dict, sel, static: int):
    """(bytes, packed, tiles used): the size of a trace of the tiles ``sel`` from ESTIMATE_TILES
    of them (or 1%) spread evenly, traced in memory first, and ``packed()`` the size with
    --compress (deflating samples of the records: called when the figure is wanted, on any
    thread; the records themselves are let go, for the trace to reuse their pages); ``static``
    is the size of what does not depend on the tiles (voxel lists, primitive table, samples)."""
    k = max(ESTIMATE_TILES, len(sel) // 100)
    pick = sorted({int(sel[round(i * (len(sel) - 1) / (k - 1))]) for i in range(k)})
    rays, visits = trace_records(grid, pick, **kw)
    raw = rays.nbytes + visits.nbytes
    parts = [_deflate_sample(rays), _deflate_sample(visits)]
    del rays, visits
    per_tile = raw / len(pick)

    def packed() -> float:
        deflated = sum(len(zlib.compress(part, tracefile.DEFLATE_LEVEL)) * scale for part, scale in parts)
        return static + deflated / len(pick) * len(sel)
    return static + per_tile * len(sel), packed, len(pick)


def cmd_trace(a) -> int:
    options.check_render_options(a)
    options.check_outputs(("-o", a.output, "npz"))
    scene, how, grid, desc, _ = _scene_and_grid(a)
    tiling = grid.tiling(desc)
    _check_selection(a, tiling, desc["tile"])
    sel = select_tiles(tiling[2] * tiling[3], a.tiles, a.sample)
    kw = options.render_kwargs(a)
    start, ids = grid.lists()
    static = start.nbytes + ids.nbytes + 12 * scene.info()["prims"] + tiling[0] * tiling[1] * 24
    said = None    # the size line, printed by a thread of its own while tracing (deflate lets go of the GIL)
    if len(sel) >= ESTIMATE_FROM:
        est, packed, k = _estimate(grid, kw, sel, static)

        def say(est_c: float) -> None:
            print(f"size    about {_size(est)} (about {_size(est_c)} with --compress, which is slower to write "
                  f"and loads into memory instead of being memory-mapped); estimated from {k} of the {len(sel)} "
                  "tiles", flush=True)
        d = os.path.dirname(a.output) or "."
        free = shutil.disk_usage(d).free
        if a.compress or est > free:    # the --compress figure is wanted before tracing
            est_c = packed()
            say(est_c)
            need = est + (est_c if a.compress else 0)
            if need > free:
                how = (f"with --compress, about {_size(est)} streamed beside the output first, then "
                       f"{_size(est_c)} deflated into it; use --sample or a smaller --res" if a.compress
                       else f"use --sample, a smaller --res or --compress (about {_size(est_c)})")
                raise UsageError(f"-o {a.output}: the trace needs about {_size(need)} but {d} has {_size(free)} "
                                 f"free ({how})")
        else:
            said = threading.Thread(target=lambda: say(packed()), daemon=True)
            said.start()
    t0 = time.perf_counter()
    try:   # written beside the output and renamed onto it whole (with --compress: streamed, then deflated)
        _, tr = trace(grid, **kw, tiles=a.tiles, sample=a.sample, path=a.output, compress=a.compress,
                      progress=_progress_wanted(a))
    except OSError as e:   # (disk full, ...) name the user's file, not the temporary ones beside it
        raise OSError(f"-o {a.output}: {e.strerror or e}") from None
    finally:
        if said is not None:
            said.join()
    t1 = time.perf_counter()
    size = os.path.getsize(a.output)
    nr, nv = len(tr.rays), len(tr.visits)  # memory-mapped: not read here
    records = tr.rays.nbytes + tr.visits.nbytes
    print(f"trace   {scene.name}, grid {'x'.join(map(str, grid.n))}, {desc['width']}x{desc['height']} "
          f"{a.rules}, {len(sel)} of {tiling[2] * tiling[3]} tiles: {nr} rays, {nv} visits in {t1 - t0:.2f} s")
    if records >= size - records:
        detail = (f"records {_size(records)}{' before compression' if a.compress else ''}, "
                  f"{records / max(nv, 1):.1f} bytes per visit with the rays")
    else:   # the static tables dominate: a per-visit figure would mislead
        detail = f"mostly voxel lists, primitive table and samples; records {_size(records)}"
    print(f"wrote   {a.output}: {_size(size)}{' compressed' if a.compress else ''} ({detail}); "
          f"'mprt stats {a.output}' gives the statistics")
    return 0


# -- mprt stats ---------------------------------------------------------------------------------
STATS_ROWS = (
    ("OS input rays", "os_input"), ("  of which primary", "os_input_primary"),
    ("  of which returns from IC", "os_input_returns"), ("  of which new rays from SC", "os_input_new"),
    ("OS kills (ray left the space)", "os_kills"), ("OS -> IC", "os_to_ic"),
    ("OS -> SC (unblocked shadow rays)", "os_to_sc"), ("IC input", "ic_input"),
    ("IC kills (blocked shadow rays)", "ic_kills"), ("IC -> OS (returns)", "ic_to_os"),
    ("IC -> SC (hits)", "ic_to_sc"), ("SC input", "sc_input"),
    ("SC makes: secondary rays", "sc_made_secondary"), ("SC makes: shadow rays", "sc_made_shadow"),
    ("rays suppressed", "suppressed"), ("voxels traversed", "voxels_traversed"),
    ("intersection tests", "tests"),
)


def trace_settings(meta: dict, path: str, argv) -> dict:
    """The settings a trace was made with (from its metadata), for a JSON computed from it."""
    paper = meta.get("rules") == "paper"
    return {**options.base_settings(argv), "trace": path,
            **{k: meta.get(k) for k in ("scene", "scene_sha256", "precision", "grid")},
            "resolution": [meta.get("width"), meta.get("height")], "rules": meta.get("rules"),
            "threshold": meta.get("threshold") if paper else None,
            **{k: meta.get(k) for k in ("max_depth", "mailbox", "tile", "tiles_total", "subset")},
            "tiles": len(meta.get("tiles", []))}


def cmd_stats(a) -> int:
    if a.trace is None and a.json and a.json.endswith(".npz"):     # the old spelling: stats --json TRACE.npz
        a.trace, a.json = a.json, "-"
    if a.trace is None:
        raise UsageError("the following argument is required: TRACE.npz")
    options.check_input("TRACE", a.trace)
    if a.json != "-":
        options.check_outputs(("--json", a.json, "json"))
    t0 = time.perf_counter()
    # memory-mapped and read in chunks: bounded memory; validated (mprt.tracevalid) as it loads
    tr = load_trace(a.trace, mmap=True, invariants=a.check)
    st = tr.stats()
    if a.json:
        options.write_json(sys.stdout if a.json == "-" else a.json,
                           {**st, "invariants_checked": bool(a.check),
                            "settings": trace_settings(tr.meta, a.trace, a.argv),
                            "wall_seconds": time.perf_counter() - t0})
        if a.json == "-":
            return 0
    m = tr.meta
    print(f"{m['scene']}  grid {'x'.join(map(str, m['grid']))}  {m['width']}x{m['height']}  rules {m['rules']}"
          f"  threshold {m['threshold']:g}  tiles {len(m['tiles'])}/{m['tiles_total']}")
    rows = [(name, st[key]) for name, key in STATS_ROWS]
    rows += [(f"  {k} tests", v) for k, v in st["tests_by_kind"].items() if v]
    rows += [("returns per ray entering OS from outside", f"{st['returns_per_ray']:.2f}")]
    for name, val in rows:
        print(f"  {name:42s} {val}")
    for key, title in (("hist_voxels_per_os_visit", "voxels per OS visit"),
                       ("hist_tests_per_ic_visit", "tests per IC visit"),
                       ("hist_returns_per_ray", "returns per ray")):
        hist = st[key]
        total = sum(hist) or 1
        mean = sum(i * c for i, c in enumerate(hist)) / total
        print(f"  {title}: mean {mean:.2f}, max {len(hist) - 1}, histogram (value: share) "
              + " ".join(f"{i}:{c / total:.3f}" for i, c in enumerate(hist[:12]) if c))
    if a.check:
        print("  invariants: ok")
    if a.json:
        print(f"wrote   {a.json}")
    return 0


def _add_scene(sub) -> None:
    s = sub.add_parser("scene", help="write an SPD scene as NFF", epilog=EPILOG,
                       description="Write an SPD scene as NFF text.")
    s.add_argument("name", metavar="NAME[:SIZE]", help=f"SPD scene: {', '.join(SPD_SCENES)}, with an optional size")
    s.add_argument("--size", type=options.spd_size_arg, default=None,
                   help="SPD size factor (or NAME:SIZE); its range depends on the scene: "
                        + ", ".join(f"{k} 1..{v}" for k, v in options.SPD_MAX_SIZES.items())
                        + " (default: the SPD default, " + ", ".join(f"{k} {v}" for k, v in
                                                                     options.SPD_DEFAULT_SIZES.items()) + ")")
    s.add_argument("-o", "--output", metavar="OUT.nff", help="NFF file to write (default: stdout)")
    s.set_defaults(func=cmd_scene)


def _add_render(sub) -> None:
    r = sub.add_parser("render", help="render a scene to PNG and print its statistics", epilog=EPILOG,
                       description="Render a scene, print its counters, and write the image and a JSON record.")
    options.add_scene_argument(r)
    options.add_render_options(r)
    r.add_argument("--progress", action="store_true",
                   help="show a progress bar (time estimated) even when stderr is not a terminal or the render "
                        "takes under a second (default: on a terminal)")
    r.add_argument("-o", "--output", metavar="OUT.png", help=options.OUTPUT_HELP["png"] + " (default: none)")
    options.add_json(r, "--stats")
    r.set_defaults(func=cmd_render)


def _add_trace(sub) -> None:
    t = sub.add_parser("trace", help="record every stage visit of every ray (a per-ray cost trace)", epilog=EPILOG,
                       description="Trace a scene, recording every stage visit of every ray, to an .npz file "
                                   "(streamed to disk: bounded memory).  Before a run of many tiles, the file's size "
                                   f"is estimated from {ESTIMATE_TILES} of them (or 1%) and printed.")
    options.add_scene_argument(t)
    options.add_render_options(t, trace=True)
    sel = t.add_mutually_exclusive_group()
    sel.add_argument("--tiles", type=options.tiles_arg, default=None, metavar="T,T,...",
                     help="only these tiles, e.g. 0,5,9 (numbered row by row from 0) (default: every tile)")
    sel.add_argument("--sample", type=options.sample_arg, default=None, metavar="SPEC",
                     help="only a sample of the tiles, in the grammar of every --sample: random:N:SEED (N tiles, "
                          "at most the image's), stratified:K:SEED (one at random in each block of about K tiles) "
                          "or regular:K (the tile nearest each block's centre) (default: every tile)")
    t.add_argument("--progress", action="store_true",
                   help="show a progress bar even when stderr is not a terminal (default: on a terminal)")
    t.add_argument("--compress", action="store_true",
                   help="deflate the trace (several times smaller, slower to write; loads into memory whole "
                        "instead of memory-mapped) (default: off)")
    t.add_argument("-o", "--output", metavar="OUT.npz", required=True,
                   help=options.OUTPUT_HELP["npz"] + " (required)")
    t.set_defaults(func=cmd_trace)


def _add_stats(sub) -> None:
    st = sub.add_parser("stats", help="the paper's statistics of a trace", epilog=EPILOG,
                        description="Print the paper's statistics of a trace (bounded memory, any size).")
    st.add_argument("trace", metavar="TRACE.npz", nargs="?", help="a trace written by mprt trace")
    st.add_argument("--check", action="store_true", help="validate the trace's invariants first (default: off)")
    st.add_argument("--json", metavar="OUT.json", nargs="?", const="-", default=None,
                    help=options.OUTPUT_HELP["json"] + "; --json alone (or -) prints it to stdout instead of the "
                         "table, as before (default: none)")
    st.set_defaults(func=cmd_stats)
