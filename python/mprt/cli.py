"""The ``mprt`` command: scenes, renders (and later traces, models, studies)."""
from __future__ import annotations

import argparse
import json
import sys
import time

from ._core import SPD_SCENES, MprtError, Scene, write_png



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
            json.dump({k: counters[k] for k in ("eye_rays", "eye_hits", "reflect_rays", "refract_rays",
                                                "shadow_rays", "suppressed_rays", "voxels_traversed", "hits",
                                                "tests")}, f, indent=2)
        print(f"wrote   {a.stats}")
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
                   help="N or NX,NY,NZ (default: about 3 N^(1/3) along the longest axis, see Scene.default_grid)")
    r.add_argument("--res", type=_res_arg, default=None, help="WxH (default: the scene's view resolution)")
    r.add_argument("--rules", choices=("paper", "spd"), default="paper")
    r.add_argument("--threshold", type=float, default=None, help="contribution cutoff (paper rules)")
    r.add_argument("--threads", type=int, default=1)
    r.add_argument("-o", "--output", help="PNG image to write")
    r.add_argument("--stats", help="JSON file for the counters")
    r.set_defaults(func=cmd_render)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (MprtError, MemoryError, OSError) as e:
        print(f"mprt: error: {e}", file=sys.stderr)
        return 1
