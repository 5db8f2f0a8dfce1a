"""The command line's options: one validation per option, shared by every ``mprt`` subcommand.

Each option is checked once, here, with its allowed range in the message and
in ``--help``; nothing out of range is passed on to be replaced by a default
(``--res 0x64`` is refused, not rendered at 512x64).  A subcommand module
(``mprt simulate``, ``explore``, ``prepass``, ``sweep``) builds its parser
with these helpers and, before any work:

    from mprt import options
    def add_parser(sub):
        p = sub.add_parser("simulate", ...)
        options.add_scene_argument(p)          # or its own positional
        options.add_render_options(p)          # --grid --listing --res --rules --threshold --threads --tile
                                               # --max-rays --max-depth --mailbox
        p.add_argument("--json", metavar="OUT.json", help=options.OUTPUT_HELP["json"])
    def run(a):
        options.check_render_options(a)        # combinations (--threshold with --rules spd)
        options.check_outputs(("--json", a.json, "json"))
        scene, how = options.load_scene(a.scene)
        ...
        options.write_json(a.json, {..., "settings": options.run_settings(scene, grid, desc, how),
                                    "wall_seconds": ...})

``UsageError`` (exit status 2 in ``mprt``) is raised for a bad option or an
output that cannot be written; argparse's own type errors exit 2 as well.

The scene rule: a SCENE that is an SPD name, with or without ``:SIZE``
(``balls``, ``balls:2``), is always the SPD generator, even when a file or
directory of that name exists (a note says it is not read); any other SCENE
is an NFF file path (write ``./balls`` for a file named ``balls``).
"""
from __future__ import annotations

import argparse
import os
import sys
from fractions import Fraction

from ..errors import InvalidArgument, SceneParseError, UsageError
from ..grid import LISTINGS
from ..scene import SPD_DEFAULT_SIZES, SPD_SCENES, Scene  # noqa: F401 (options.SPD_DEFAULT_SIZES: kept)
from ..settings import (CUTOFF_RULES, DEPTH_MAX, GRID_MAX, MAX_RAYS_MAX, OVER_ONE_NOTE, RES_MAX,  # noqa: F401
                        SPD_MAX_SIZES, THREADS_MAX, TILE_MAX, BadValue, base_settings, command_line_note,
                        default_depths, default_max_rays, default_threads, default_threshold, default_tile,
                        fraction_text, json_safe, read_toml, resolution, run_settings, spd_size,
                        threshold_setting, version, whole_number, write_json)
from .._lowlevel import EXT_VERSION, RULES, binding  # noqa: F401 (the names options had)
from ..util.atomic import open_replacing  # noqa: F401

# The ranges, the library's defaults, TOML reading and what a JSON output records are the
# library's (mprt.settings), shared with the files that give the same settings; here, the
# options that take them from the command line.

OUTPUT_SUFFIX = {"png": ".png", "plot": ".png", "npz": ".npz", "html": ".html"}   # outputs whose format mprt fixes
OUTPUT_HELP = {
    "png": "PNG image to write (the name must end in .png)",
    "npz": "trace file to write (the name must end in .npz)",
    "json": "JSON file to write: the figures, the settings that made them and the wall time",
    "plot": "PNG plot to write (the name must end in .png)",
}


# -- argparse types: each raises ArgumentTypeError with the allowed range -------------------------
def _int(text: str, what: str, lo: int, hi: int) -> int:
    try:
        return whole_number(text, what, lo, hi)
    except BadValue as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def int_range_arg(what: str, lo: int, hi: int):
    """An argparse type: a whole number in lo..hi, the range named in the message."""
    return lambda text: _int(text, what, lo, hi)


def threads_arg(text: str) -> int:
    """--threads: 1..THREADS_MAX."""
    return _int(text, "threads", 1, THREADS_MAX)


def tile_arg(text: str) -> int:
    """--tile: the tile edge in samples, 1..TILE_MAX."""
    return _int(text, "tile edge", 1, TILE_MAX)


def grid_arg(text: str):
    """--grid: N or NX,NY,NZ, each 1..GRID_MAX."""
    parts = text.split(",")
    if len(parts) not in (1, 3):
        raise argparse.ArgumentTypeError(f"grid must be N or NX,NY,NZ, not {text!r}")
    vals = [_int(p.strip(), "voxels per axis", 1, GRID_MAX) for p in parts]
    return vals[0] if len(vals) == 1 else tuple(vals)


def resolution_arg(text: str):
    """--res: WxH, each 1..RES_MAX."""
    try:
        return resolution(text)
    except BadValue as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def threshold_arg(text: str) -> float:
    """--threshold: a contribution cutoff in [0, 1)."""
    try:
        v = float(Fraction(text)) if "/" in text else float(text)
    except (ValueError, ZeroDivisionError):
        raise argparse.ArgumentTypeError(f"threshold must be a number in [0, 1) such as 0.002 or 1/512, "
                                         f"not {text!r}") from None
    if not 0 <= v < 1:
        raise argparse.ArgumentTypeError(f"threshold {text} is not in [0, 1)")
    return v


def tiles_arg(text: str):
    """--tiles: a comma-separated list of tile numbers (checked against the image's tiles later)."""
    try:
        vals = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        vals = None
    if not vals or min(vals) < 0:
        raise argparse.ArgumentTypeError(f"tiles must be a comma-separated list of tile numbers (0, 1, ...), "
                                         f"not {text!r}")
    return vals


def sample_arg(text: str) -> str:
    """--sample of mprt trace: a sample of the tiles in the grammar of every --sample
    (``tracing.SAMPLE_GRAMMAR``: random:N:SEED, stratified:K:SEED, regular:K; N is checked
    against the image's tiles later); runs, a replay's sample, are refused here."""
    from ..trace.tracing import Sampling

    try:
        s = Sampling.parse(text)
    except InvalidArgument as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    if s.method == "runs":
        raise argparse.ArgumentTypeError(f"{text}: runs sample the replay of a whole frame's trace (mprt simulate "
                                         "--sample), not the tiles to trace; use random, stratified or regular")
    return str(s)


def spd_size_arg(text: str) -> int:
    """--size: a whole number (its range depends on the scene, checked with it)."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"SPD size must be a whole number, not {text!r}") from None


# -- groups of options --------------------------------------------------------------------------
SCENE_HELP = ("an SPD scene name with an optional size (balls, balls:2; always the SPD generator, even when "
              "a file of that name exists: write ./balls for the file) or an NFF file path")


def add_scene_argument(p: argparse.ArgumentParser, name: str = "scene") -> None:
    p.add_argument(name, metavar="SCENE", help=SCENE_HELP)
    add_skip_unknown(p)


def add_skip_unknown(p: argparse.ArgumentParser) -> None:
    """--skip-unknown: for every subcommand that reads an NFF scene."""
    p.add_argument("--skip-unknown", action="store_true",
                   help="read an NFF file without the entities mprt does not know (extension lines such as "
                        "'fp ...', 'Q 0', 'Z 481', with the number lines after each), warning with each entity "
                        "and its count (default: off, such a line is an error naming the entity)")


# -- the shared options: one definition each, so every subcommand spells, checks and documents
# them alike (tests/test_cli_grammar.py walks every parser and checks it) ------------------------
def exit_status(*more: str) -> str:
    """A parser's exit-status section: 0, 1 and 2 as every command has them, then ``more`` (a
    command's own, e.g. "3 with --baseline: ..."), then 130 (Ctrl-C)."""
    return "; ".join(("exit status: 0 done", "1 an error during the work (a malformed scene file, a damaged trace, ...)",
                      "2 a bad option, scene, input or output path, found before any work", *more,
                      "130 interrupted (Ctrl-C): nothing half-written is left under an output's name"))


EXIT_STATUS = exit_status()


GRID_DEFAULT = "Scene.default_grid, about 8*N^(1/3) along the box's longest axis for N primitives"


def add_grid(p, default_text: str = GRID_DEFAULT, extra: str = "") -> None:
    """--grid (``default_text``: what a command does without it, e.g. explore's search)."""
    p.add_argument("--grid", type=grid_arg, default=None, metavar="N|NX,NY,NZ",
                   help=f"voxels per axis, each 1..{GRID_MAX}{extra} (default: {default_text})")


def add_listing(p) -> None:
    """--listing: how the grid lists primitives in voxels (mprt.grid.LISTINGS)."""
    p.add_argument("--listing", choices=tuple(LISTINGS), default="exact",
                   help="voxels a primitive is listed in: exact (every voxel its surface may touch, closed and "
                        "padded), box (every voxel its bounding box touches), box_outward (and one more on each "
                        "axis's high side), occupied (a study: only the voxels whose interior its surface meets; "
                        "fewer tests but not watertight, a ray through a voxel edge can miss) (default: exact)")


def add_res(p) -> None:
    p.add_argument("--res", type=resolution_arg, default=None, metavar="WxH",
                   help=f"image size, each 1..{RES_MAX} (default: the scene's view resolution)")


def add_rules(p, sentinel: bool = False) -> None:
    """``sentinel``: the parsed default is None (so a command can tell it was given), the help
    the same."""
    p.add_argument("--rules", choices=tuple(RULES), default=None if sentinel else "paper",
                   help="shading rules: paper (pixel centres, contribution cutoff), spd (SPD's procedure: "
                        "pixel corners, depth 5, no cutoff) or paper1992 (paper with the workload conventions "
                        "that reproduce the 1992 paper's counts: docs/workload.md) (default: paper)")


def add_threshold(p) -> None:
    p.add_argument("--threshold", type=threshold_arg, default=None, metavar="X",
                   help=f"contribution cutoff in [0, 1), paper and paper1992 rules only "
                        f"(default: {fraction_text(default_threshold())})")


def add_threads(p, sentinel: bool = False) -> None:
    p.add_argument("--threads", type=threads_arg, default=None if sentinel else default_threads(), metavar="N",
                   help=f"threads, 1..{THREADS_MAX}; results are the same bits for any number "
                        f"(default: {default_threads()}, the machine's cores)")


def add_tile(p, trace: bool = False) -> None:
    p.add_argument("--tile", type=tile_arg, default=None, metavar="N",
                   help=f"tile edge in samples, 1..{TILE_MAX}: the unit of work{' and of --tiles/--sample' if trace else ''}"
                        f" (default: {default_tile()})")


def add_json(p, *aliases: str) -> None:
    """--json OUT.json (``aliases``: old spellings, kept)."""
    p.add_argument("--json", *aliases, dest="json", metavar="OUT.json", default=None,
                   help=OUTPUT_HELP["json"] + (f" ({', '.join(aliases)}: the old spelling)" if aliases else "")
                   + " (default: none)")


LEVEL_HELP = ("fidelity level: 0 analytical, 1 ideal network and memory (the compiled replay), 2 the ring, "
              "3 the memories")


def add_level(p, default, default_text: str, extra: str = "") -> None:
    p.add_argument("--level", choices=("0", "1", "2", "3", "auto"), default=default,
                   help=f"{LEVEL_HELP}{extra} (default: {default_text})")


def add_render_options(p: argparse.ArgumentParser, trace: bool = False) -> argparse._ArgumentGroup:
    """--grid, --listing, --res, --rules, --threshold, --threads, --tile, --max-rays, --max-depth
    (add_trace_limits), --mailbox, each with its range and default in --help.  Returns the
    argument group (to add more)."""
    g = p.add_argument_group("rendering")
    add_grid(g)
    add_listing(g)
    add_res(g)
    add_rules(g)
    add_threshold(g)
    add_threads(g)
    add_tile(g, trace)
    add_trace_limits(g)
    g.add_argument("--mailbox", action="store_true",
                   help="IC skips primitives the ray already tested (fewer tests, same image) (default: off, as the "
                        "paper's IC)")
    return g


def add_trace_limits(p) -> None:
    """--max-rays and --max-depth, the limits of a sample's ray tree, for every command that
    traces a scene (render and trace through add_render_options; simulate, explore and prepass
    add them with this one call, to a parser or an argument group); ``trace_limits(a)`` gives the
    keywords of Grid.render / Grid.trace / SceneEvaluator."""
    from ..scene import OVER_ONE_MAX_DEPTH

    depths = default_depths()
    p.add_argument("--max-rays", type=int_range_arg("max-rays", 1, MAX_RAYS_MAX), default=None, metavar="N",
                   help=f"ray budget of one sample (its eye ray and all its descendants), 1..{MAX_RAYS_MAX}: a "
                        "sample needing more stops the render with an error naming it, so no scene runs away "
                        f"(default: {default_max_rays()})")
    p.add_argument("--max-depth", type=int_range_arg("max-depth", 1, DEPTH_MAX), default=None, metavar="N",
                   help=f"depth limit of a ray tree (the eye ray is level 1), 1..{DEPTH_MAX} (default: the rules' "
                        + ", ".join(f"{r} {d}" for r, d in depths.items())
                        + f"; {OVER_ONE_MAX_DEPTH} for a scene with a surface whose Ks + T is over 1, the classic "
                          "glass, whose ray trees the contribution cutoff cannot end)")


def trace_limits(a) -> dict:
    """The keywords max_rays and max_depth of Grid.render, Grid.trace (tracing.trace) and
    SceneEvaluator from options parsed with add_trace_limits (absent or not given: None and 0,
    the library's budget and the scene's or rules' depth)."""
    return {"max_rays": getattr(a, "max_rays", None), "max_depth": getattr(a, "max_depth", None) or 0}


def check_render_options(a) -> None:
    """Combinations of the render options that would be silently ignored."""
    if getattr(a, "threshold", None) is not None and a.rules not in CUTOFF_RULES:
        raise UsageError(f"--threshold applies to the paper and paper1992 rules only (the {a.rules} rules have "
                         "no cutoff); leave it out or use --rules paper")


def render_kwargs(a) -> dict:
    """The keyword options of Grid.render / tracing.trace from parsed render options."""
    w, h = a.res or (0, 0)
    return dict(width=w, height=h, rules=a.rules, threshold=a.threshold, threads=a.threads, tile=a.tile,
                mailbox=a.mailbox, **trace_limits(a))


# -- scenes -------------------------------------------------------------------------------------
def load_scene(spec: str, precision: str = "double", note=None, skip_unknown: bool = False):
    """(Scene, how): the scene a SCENE argument names under the rule in this module's text, and
    a phrase saying which was used.  When an SPD name is also a file or directory here, a note
    says it is not read (``note``: a function of the message; default: print to stderr).  An NFF
    file's reader notes (Ks + T over 1, unknown entities skipped under ``skip_unknown``) are
    printed as warnings; an unknown entity without ``skip_unknown`` is an error that names it
    and says how to read the file without it."""
    base, colon, size = spec.partition(":")
    if base in SPD_SCENES:
        n = spd_size(base, size if colon else None)
        scene = Scene.spd(base, n, precision)
        if os.path.exists(spec):
            kind = "directory" if os.path.isdir(spec) else "file"
            (note or _note)(f"{spec} is the SPD scene; the {kind} {spec} here is not read (write ./{spec} for it)")
        return scene, "SPD scene (generated)"
    if os.path.isdir(spec):
        raise UsageError(f"scene {spec!r} is a directory, not an NFF file")
    if not os.path.exists(spec):
        raise UsageError(f"scene {spec!r} is neither a file nor an SPD scene ({', '.join(SPD_SCENES)}, "
                         "with an optional :SIZE)")
    try:
        scene = Scene.from_nff(spec, precision, skip_unknown=skip_unknown)
    except SceneParseError as e:
        if "unknown entity" in str(e) and not skip_unknown:
            raise SceneParseError(f"{e} (--skip-unknown reads the file without the entities mprt does not "
                                  "know, warning with each)") from None
        raise
    for line in scene.notes:
        print(f"mprt: warning: {command_line_note(scene, line)}", file=sys.stderr)
    return scene, f"NFF file {spec}"


def _note(message: str) -> None:
    print(f"mprt: note: {message}", file=sys.stderr)


# -- outputs ------------------------------------------------------------------------------------
def check_output(option: str, path, kind: str = "any") -> None:
    """Fail (UsageError naming the option and the user's path) unless ``path`` can be written
    as ``kind`` ('png', 'npz', or any other for free-form files): the directory exists and is
    writable, the path is not a directory, and a format mprt fixes has its suffix."""
    if path is None:
        return
    p = os.fspath(path)
    if not p:
        raise UsageError(f"{option}: the file name is empty")
    suffix = OUTPUT_SUFFIX.get(kind)
    if suffix and not p.lower().endswith(suffix):
        raise UsageError(f"{option} {p}: mprt writes {suffix[1:].upper()} here; give a name ending in {suffix}")
    if os.path.isdir(p):
        raise UsageError(f"{option} {p}: is a directory")
    d = os.path.dirname(p) or "."
    if not os.path.isdir(d):
        raise UsageError(f"{option} {p}: directory {d} does not exist")
    if not os.access(d, os.W_OK | os.X_OK) or (os.path.exists(p) and not os.access(p, os.W_OK)):
        raise UsageError(f"{option} {p}: not writable")


def check_outputs(*outputs) -> None:
    """check_output for each (option, path, kind); also refuses two outputs naming one file."""
    seen = {}
    for option, path, kind in outputs:
        if path is None:
            continue
        check_output(option, path, kind)
        real = os.path.realpath(path)
        if real in seen:
            raise UsageError(f"{seen[real]} and {option} both name {path}")
        seen[real] = option


def check_input(option: str, path) -> None:
    """An input file must exist and be a file (not a directory)."""
    p = os.fspath(path)
    if os.path.isdir(p):
        raise UsageError(f"{option} {p}: is a directory, not a file")
    if not os.path.exists(p):
        raise UsageError(f"{option} {p}: no such file")


# -- what JSON outputs record -------------------------------------------------------------------


