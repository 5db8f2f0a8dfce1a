"""The settings the library and the command line share: the ranges of every traced setting, the
library's defaults, the text forms of a resolution and a whole number in a range, TOML reading,
and what a JSON output records of the run (the version, the settings that made a result).

The command line (``mprt.cli.options``) builds its options on these; the library uses them where
a file gives the same settings (a workload's ``res`` and ``max_rays``, a sweep spec's
subdivisions, a machine file).  Nothing here parses arguments or prints.
"""
from __future__ import annotations

import json
import math
import os
import sys

from ._lowlevel import EXT_VERSION, RULES, binding
from .errors import UsageError
from .scene import SPD_DEFAULT_SIZES, Scene
from .util.atomic import open_replacing


# The ranges the library accepts (render.c, grid.c, spd.c; tests/test_cli_options.py
# checks each against the library), except where the command line is stricter:
# threads 0 (the library's "1") and tile <= 0 (its "16") are refused there, and the
# tile edge is capped so that a tile's record buffers stay small.
RES_MAX = 65536          # width and height: 1..RES_MAX
GRID_MAX = 1024          # voxels per axis: 1..GRID_MAX
THREADS_MAX = 64         # threads: 1..THREADS_MAX
TILE_MAX = 256           # tile edge in samples: 1..TILE_MAX
MAX_RAYS_MAX = 1 << 24   # ray budget of a sample: 1..MAX_RAYS_MAX (the library: any positive int)
CUTOFF_RULES = ("paper", "paper1992")   # rule sets with a contribution cutoff (--threshold)
DEPTH_MAX = 255          # depth limit of a ray tree: 1..DEPTH_MAX (the library: 0..255, 0 the default)
OVER_ONE_NOTE = " is over 1 ("   # in the NFF reader's note of a material with Ks + T over 1
SPD_MAX_SIZES = {"balls": 8, "gears": 69, "mount": 12, "rings": 135, "tetra": 12, "tree": 23}


class BadValue(ValueError):
    """A value written as text (a resolution, a whole number) is malformed or out of range; the
    message names the value and the allowed range (the command line reports it as the option's)."""


def whole_number(text, what: str, lo: int, hi: int) -> int:
    """``text`` as a whole number in lo..hi, or BadValue naming ``what`` and the range."""
    try:
        v = int(text)
    except ValueError:
        raise BadValue(f"{text!r} is not a whole number ({what} must be in {lo}..{hi})") from None
    if not lo <= v <= hi:
        raise BadValue(f"{what} {v} is not in {lo}..{hi}")
    return v


def resolution(text: str) -> tuple:
    """WxH (each 1..RES_MAX) as (width, height), or BadValue."""
    parts = str(text).lower().split("x")
    if len(parts) != 2:
        raise BadValue(f"resolution must be WxH (e.g. 512x512), not {text!r}")
    w, h = (whole_number(p.strip(), "width" if i == 0 else "height", 1, RES_MAX) for i, p in enumerate(parts))
    return w, h


def default_threads() -> int:
    """The machine's cores available to this process (at most THREADS_MAX)."""
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    return max(1, min(n, THREADS_MAX))


def default_threshold() -> float:
    """The library's default contribution cutoff (paper rules)."""
    return binding().render_desc_init()["threshold"]


def default_max_rays() -> int:
    """The library's default ray budget of a sample (MPRT_DEFAULT_MAX_RAYS)."""
    return int(binding().lib.MPRT_DEFAULT_MAX_RAYS)


_DEPTHS: dict = {}


def default_depths() -> dict:
    """The library's depth limit of each rule set (max_depth 0), by rules name: read from it once
    (a render description resolved over a one-sphere scene)."""
    if not _DEPTHS:
        scene = Scene()
        scene.add_sphere((0, 0, 0), 1)
        grid = scene.grid(1)
        _DEPTHS.update({r: grid.resolve({"width": 1, "height": 1, "rules": v})["max_depth"] for r, v in RULES.items()})
    return dict(_DEPTHS)


def default_tile() -> int:
    return binding().render_desc_init()["tile"]


def fraction_text(x: float) -> str:
    """1/512 for 0.001953125 (a unit fraction, exactly); other numbers as %g."""
    if 0 < x < 1 and (1 / x).is_integer() and 1 / round(1 / x) == x:
        return f"1/{round(1 / x)}"
    return f"{x:g}"


def threshold_setting(rules: str, threshold) -> float | None:
    """The cutoff a trace under ``rules`` uses: the one given, the library's default for the
    rules with a cutoff, None for the others (what a report's settings show)."""
    if rules not in CUTOFF_RULES:
        return None
    return float(threshold) if threshold is not None else default_threshold()


def spd_size(name: str, size) -> int | None:
    """A validated SPD size factor for scene ``name`` (None: the SPD default); the same
    message for every size out of range, whichever end."""
    if size is None or size == "":
        if size == "":
            raise UsageError(f"SPD size missing after '{name}:' (sizes are 1..{SPD_MAX_SIZES[name]}, "
                             f"default {SPD_DEFAULT_SIZES[name]})")
        return None
    lo, hi = 1, SPD_MAX_SIZES[name]
    try:
        v = int(size)
    except (TypeError, ValueError):
        v = None
    what = "a whole number in" if v is None else "in"
    if v is None or not lo <= v <= hi:
        raise UsageError(f"SPD size {size} for {name} is not {what} {lo}..{hi} (default {SPD_DEFAULT_SIZES[name]})")
    return v


def command_line_note(scene, note: str) -> str:
    """A reader's note as the command line prints it: the Ks + T over 1 note names the option
    (--max-rays for max_rays) and says what a render or trace of the scene does about it (its
    ray trees stop at ``Scene.default_max_depth`` unless --max-depth is given)."""
    if OVER_ONE_NOTE not in note:
        return note
    note = note.replace("(max_rays)", "(--max-rays)")
    depth = scene.default_max_depth()
    if depth:
        return (f"{note}; as the contribution cutoff cannot end the ray trees of such a surface, they stop at "
                f"depth {depth} (SPD's; classic NFF renderers limit depth) unless --max-depth is given")
    return f"{note}; no surface takes such a material, so the rules' depth limit stands"


def read_toml(path, what: str, error=UsageError) -> dict:
    """A TOML file's tables; ``error`` naming the file when it cannot be read
    ("cannot read the WHAT") or is not TOML ("not valid TOML")."""
    import tomllib

    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise error(f"{path}: cannot read the {what} ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise error(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        raise error(f"{path}: not valid TOML ({e})") from None
    except RecursionError:
        raise error(f"{path}: not a TOML file mprt reads (nested too deeply)") from None


def version() -> str:
    return EXT_VERSION


def base_settings(argv=None) -> dict:
    """What every JSON output records of the run itself: the mprt version and the command line
    (``argv``, default sys.argv)."""
    return {"mprt_version": version(), "command": " ".join(["mprt"] + list(sys.argv[1:] if argv is None else argv))}


def run_settings(scene=None, grid=None, desc: dict | None = None, how: str | None = None, argv=None,
                 **extra) -> dict:
    """The settings that made a result, for its JSON: ``base_settings``, the scene (name, how it
    was read, NFF SHA-256), grid, resolution, rules, threshold (None under rules without a
    cutoff), threads, tile, max depth, mailbox, ray budget; ``extra`` adds more."""
    s = base_settings(argv)
    if scene is not None:
        s.update(scene=scene.name, scene_source=how, scene_sha256=scene.content_hash(),
                 precision=scene.precision)
    if grid is not None:
        s["grid"] = list(grid.n)
    if desc is not None:
        rules = next(k for k, v in RULES.items() if v == desc["rules"])
        s.update(resolution=[desc["width"], desc["height"]], rules=rules,
                 threshold=desc["threshold"] if rules in CUTOFF_RULES else None, threads=desc["threads"],
                 tile=desc["tile"], max_depth=desc["max_depth"], mailbox=bool(desc["mailbox"]),
                 max_rays=desc["max_rays"])
    s.update(extra)
    return s


def json_safe(data):
    """``data`` with every infinite or NaN number made None, so that it is JSON as the standard
    has it (``null``; Python's own ``Infinity`` and ``NaN`` are no JSON, and strict parsers
    refuse them): e.g. a ladder's worst error where a design deadlocked at one level only."""
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: json_safe(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [json_safe(v) for v in data]
    return data


def write_json(path, data: dict, indent: int = 2) -> None:
    """Write ``data`` as indented, standard JSON (``json_safe``) to a path (checked with
    check_output first) or an open text file."""
    if hasattr(path, "write"):
        json.dump(json_safe(data), path, indent=indent, allow_nan=False)
        path.write("\n")
        return
    with open_replacing(path) as f:
        write_json(f, data, indent)
