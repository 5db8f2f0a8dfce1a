"""The ``mprt`` command: scenes, renders (and later traces, models, studies)."""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

from ._lowlevel import binding
from .errors import MprtError
from .machine.cli import add_parser as add_simulate
from .grid import write_png
from .scene import SPD_SCENES, Scene
from .trace import load_trace
from .tracing import trace


def _grid_arg(text: str):
    parts = text.split(",")
    try:
        vals = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"grid must be N or NX,NY,NZ, not {text!r}") from None
    if len(vals) == 1:
        return vals[0]
    if len(vals) == 3:
        return tuple(vals)
    raise argparse.ArgumentTypeError(f"grid must be N or NX,NY,NZ, not {text!r}")


def _res_arg(text: str):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"resolution must be WxH, not {text!r}") from None
    return w, h


def cmd_scene(a) -> int:
    scene = Scene.spd(a.name, a.size)
    text = scene.to_nff()
    if a.output:
        with open(a.output, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


def cmd_render(a) -> int:
    t0 = time.perf_counter()
    scene = Scene.load(a.scene)
    t1 = time.perf_counter()
    grid = scene.grid(a.grid)
    t2 = time.perf_counter()
    w, h = a.res or (0, 0)
    image, counters = grid.render(width=w, height=h, rules=a.rules, threshold=a.threshold, threads=a.threads)
    t3 = time.perf_counter()
    info, gs = scene.info(), grid.stats()
    print(f"scene   {scene.name}: {info['prims']} primitives "
          + ", ".join(f"{v} {k}" for k, v in info["count"].items() if v)
          + f"; {info['lights']} lights" + (f"; {info['dropped']} dropped ({info['warning']})" if info["dropped"] else ""))
    print(f"grid    {'x'.join(map(str, gs['n']))}: {gs['nonempty']} of {gs['voxels']} voxels non-empty, "
          f"mean list {gs['mean_len']:.2f}, max {gs['max_len']}, {gs['bytes'] / 1e6:.1f} MB")
    print(f"image   {image.shape[1]}x{image.shape[0]}, rules {a.rules}")
    for k, v in counters.items():
        print(f"  {k:18s} {v}")
    print(f"time    load {t1 - t0:.3f} s, grid {t2 - t1:.3f} s, render {t3 - t2:.3f} s ({a.threads} thread(s))")
    if a.output:
        write_png(a.output, image)
        print(f"wrote   {a.output}")
    if a.stats:
        with open(a.stats, "w") as f:
            json.dump(counters, f, indent=2)
        print(f"wrote   {a.stats}")
    return 0


def _tiles_arg(text: str):
    try:
        return [int(v) for v in text.split(",") if v]
    except ValueError:
        raise argparse.ArgumentTypeError(f"tiles must be a comma-separated list of tile numbers, not {text!r}") from None


def cmd_trace(a) -> int:
    scene = Scene.load(a.scene)
    grid = scene.grid(a.grid)
    w, h = a.res or (0, 0)
    t0 = time.perf_counter()
    _, tr = trace(grid, w, h, rules=a.rules, threshold=a.threshold, threads=a.threads, tiles=a.tiles,
                  sample=a.sample, tile=a.tile, path=a.output, progress=sys.stderr.isatty() or a.progress,
                  mailbox=a.mailbox)
    t1 = time.perf_counter()
    size = os.path.getsize(a.output)
    nr, nv = len(tr.rays), len(tr.visits)  # memory-mapped: not read here
    print(f"trace   {scene.name}, grid {'x'.join(map(str, grid.n))}, {tr.meta['width']}x{tr.meta['height']} "
          f"{a.rules}, {len(tr.meta['tiles'])} of {tr.meta['tiles_total']} tiles: "
          f"{nr} rays, {nv} visits in {t1 - t0:.2f} s")
    print(f"wrote   {a.output}: {size} bytes ({size / max(nv, 1):.1f} bytes per visit, rays included); "
          f"'mprt stats {a.output}' gives the statistics")
    return 0


def cmd_stats(a) -> int:
    tr = load_trace(a.trace)
    st = tr.check() if a.check else tr.stats()
    if a.json:
        print(json.dumps(st, indent=2))
        return 0
    m = tr.meta
    print(f"{m['scene']}  grid {'x'.join(map(str, m['grid']))}  {m['width']}x{m['height']}  rules {m['rules']}"
          f"  threshold {m['threshold']:g}  tiles {len(m['tiles'])}/{m['tiles_total']}")
    rows = [
        ("OS input rays", st["os_input"]), ("  of which primary", st["os_input_primary"]),
        ("  of which returns from IC", st["os_input_returns"]), ("  of which new rays from SC", st["os_input_new"]),
        ("OS kills (ray left the space)", st["os_kills"]), ("OS -> IC", st["os_to_ic"]),
        ("OS -> SC (unblocked shadow rays)", st["os_to_sc"]), ("IC input", st["ic_input"]),
        ("IC kills (blocked shadow rays)", st["ic_kills"]), ("IC -> OS (returns)", st["ic_to_os"]),
        ("IC -> SC (hits)", st["ic_to_sc"]), ("SC input", st["sc_input"]),
        ("SC makes: secondary rays", st["sc_made_secondary"]), ("SC makes: shadow rays", st["sc_made_shadow"]),
        ("rays suppressed", st["suppressed"]), ("voxels traversed", st["voxels_traversed"]),
        ("intersection tests", st["tests"]),
    ] + [(f"  {k} tests", v) for k, v in st["tests_by_kind"].items() if v] + [
        ("returns per ray entering OS from outside", f"{st['returns_per_ray']:.2f}"),
    ]
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
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="mprt", description="3MPRT ray-tracing machine explorer")
    sub = p.add_subparsers(dest="cmd", required=True)

    s = sub.add_parser("scene", help="write an SPD scene as NFF")
    s.add_argument("name", choices=SPD_SCENES)
    s.add_argument("--size", type=int, default=None, help="SPD size factor (default: the SPD default)")
    s.add_argument("-o", "--output", help="output file (default: stdout)")
    s.set_defaults(func=cmd_scene)

    r = sub.add_parser("render", help="render a scene to PNG and print its statistics")
    r.add_argument("scene", help="NFF path, or SPD name with optional size (balls, balls:2)")
    r.add_argument("--grid", type=_grid_arg, default=None,
                   help="N or NX,NY,NZ (default: Scene.default_grid)")
    r.add_argument("--res", type=_res_arg, default=None, help="WxH (default: the scene's view resolution)")
    r.add_argument("--rules", choices=("paper", "spd"), default="paper")
    r.add_argument("--threshold", type=float, default=None, help="contribution cutoff (paper rules)")
    r.add_argument("--threads", type=int, default=1)
    r.add_argument("-o", "--output", help="PNG image to write")
    r.add_argument("--stats", help="JSON file for the counters")
    r.set_defaults(func=cmd_render)

    t = sub.add_parser("trace", help="record every stage visit of every ray (a per-ray cost trace)")
    t.add_argument("scene", help="NFF path, or SPD name with optional size (balls, balls:2)")
    t.add_argument("--grid", type=_grid_arg, default=None, help="N or NX,NY,NZ (default: Scene.default_grid)")
    t.add_argument("--res", type=_res_arg, default=None, help="WxH (default: the scene's view resolution)")
    t.add_argument("--rules", choices=("paper", "spd"), default="paper")
    t.add_argument("--threshold", type=float, default=None, help="contribution cutoff (paper rules)")
    t.add_argument("--threads", type=int, default=1)
    t.add_argument("--tile", type=int, default=None, help="tile edge in samples, the unit of subsets "
                   f"(default {binding().render_desc_init()['tile']})")
    sel = t.add_mutually_exclusive_group()
    sel.add_argument("--tiles", type=_tiles_arg, default=None, help="only these tiles, e.g. 0,5,9")
    sel.add_argument("--sample", default=None, help="regular:K (every K-th tile) or random:N:SEED")
    t.add_argument("--mailbox", action="store_true", help="IC skips primitives the ray already tested")
    t.add_argument("--progress", action="store_true", help="show a progress bar even when not on a terminal")
    t.add_argument("-o", "--output", required=True, help="trace file (.npz)")
    t.set_defaults(func=cmd_trace)

    st = sub.add_parser("stats", help="the paper's statistics of a trace")
    st.add_argument("trace")
    st.add_argument("--check", action="store_true", help="validate the trace's invariants first")
    st.add_argument("--json", action="store_true", help="print the statistics as JSON")
    st.set_defaults(func=cmd_stats)
    add_simulate(sub)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (MprtError, MemoryError, OSError, ValueError) as e:
        print(f"mprt: error: {e}", file=sys.stderr)
        return 1
