"""Grid: the uniform voxel grid over a scene, and what it does without recording.

Build one with ``scene.grid(n)`` (added to ``Scene`` here, so that the scene
layer does not depend on this one), then read its statistics and voxel lists,
intersect batches of rays, render images, and run the per-tile calls that
``mprt.tracing`` builds traces from.  This module knows nothing of traces
beyond the record buffers it hands to the library.
"""
from __future__ import annotations

import copy
from typing import Sequence

import numpy as np

from ._lowlevel import RULES, binding
from .errors import InvalidArgument, WorkLimitError
from .scene import Scene
from .util.atomic import replacing


# How a grid lists primitives in voxels (mprt_listing).
LISTINGS = {"exact": 0, "box": 1, "box_outward": 2, "occupied": 3}
# The workload conventions of a render description and their choices, in the order of their
# MPRT_* values (1, 2, ...; 0 leaves the rule set's choice): see mprt.h and docs/workload.md.
CONVENTIONS = {
    "offset": ("scaled", "none"),
    "accept": ("in_voxel", "listed"),
    "behind": ("cutoff", "skip", "cast"),
    "candidates": ("material", "specular", "all"),
    "shadow_term": ("light", "surface"),
}


def convention_fields(conventions: dict | None) -> dict:
    """Render description fields of conventions given by name ({'offset': 'none', ...})."""
    out = {}
    for key, choice in (conventions or {}).items():
        if key not in CONVENTIONS:
            raise InvalidArgument(f"unknown workload convention {key!r}; choose from {', '.join(CONVENTIONS)}")
        if choice not in CONVENTIONS[key]:
            raise InvalidArgument(f"convention {key} must be one of {', '.join(CONVENTIONS[key])}, not {choice!r}")
        out[key] = CONVENTIONS[key].index(choice) + 1
    return out


def render_desc(width: int = 0, height: int = 0, rules: str = "paper", threshold: float | None = None,
                max_depth: int = 0, threads: int = 1, tile: int | None = None, ambient: float | None = None,
                mailbox: bool = False, conventions: dict | None = None, max_rays: int | None = None) -> dict:
    """A render description from keyword options: the fields of ``mprt_render_desc`` to set
    (None leaves the library's default; width/height/max_depth 0 mean the scene's or the rules'
    default, resolved by the library; ``conventions`` sets workload conventions by name;
    ``max_rays`` is the ray budget of one sample)."""
    if rules not in RULES:
        raise InvalidArgument(f"rules must be {' or '.join(repr(r) for r in RULES)}, not {rules!r}")
    desc = {"width": int(width), "height": int(height), "rules": RULES[rules], "max_depth": int(max_depth),
            "threads": int(threads), "mailbox": 1 if mailbox else 0, **convention_fields(conventions)}
    for key, value, kind in (("threshold", threshold, float), ("ambient", ambient, float), ("tile", tile, int),
                             ("max_rays", max_rays, int)):
        if value is not None:
            desc[key] = kind(value)
    return desc


class Grid:
    """The voxel grid over a scene: renders images and intersects rays."""

    def __init__(self, scene: Scene, n, max_bytes: int = 0, listing: str = "exact"):
        if isinstance(n, (int, np.integer)):
            dims = (int(n),) * 3
        else:
            dims = tuple(int(v) for v in n)
            if len(dims) != 3:
                raise InvalidArgument(f"grid subdivision must be one number or three, not {n!r}")
        if listing not in LISTINGS:
            raise InvalidArgument(f"listing must be {' or '.join(repr(k) for k in LISTINGS)}, not {listing!r}")
        self.scene = scene
        self.n = dims
        self.listing = listing
        self._ll = scene._ll
        self._h = self._ll.grid_create(scene._h, dims, max_bytes, LISTINGS[listing])
        self._stats = self._lists = None
        self._depth = None      # the scene's default_max_depth (the scene cannot change now)
        scene._add_grid(self)

    def stats(self) -> dict:
        """Voxels per axis, non-empty voxels, list lengths, memory, the box covered (computed
        once: a grid does not change; a trace asks twice)."""
        if self._stats is None:
            self._stats = self._ll.grid_get_stats(self._h)
        return copy.deepcopy(self._stats)

    def lists(self):
        """The voxel lists in CSR form: voxel v (x fastest, then y, then z) lists primitive ids
        ``ids[start[v]:start[v + 1]]``.  Returns (start uint32, ids int32), read-only: copied
        from the library once (a grid does not change; every trace carries them)."""
        if self._lists is None:
            st = self.stats()
            self._lists = self._ll.grid_get_lists(self._h, st["voxels"], st["refs"])
            for a in self._lists:
                a.setflags(write=False)
        return self._lists

    # -- a render's description, samples and tiles -------------------------------------------
    def _scene_depth(self, desc: dict) -> dict:
        """``desc`` with max_depth 0 made the scene's ``default_max_depth`` where it has one (a
        material with Ks + T over 1: depth 5); otherwise unchanged (0: the rules' default)."""
        if desc.get("max_depth", 0):
            return desc
        if self._depth is None:
            self._depth = self.scene.default_max_depth()
        return dict(desc, max_depth=self._depth) if self._depth else desc

    def resolve(self, desc: dict) -> dict:
        """Every field of the render description, with the library's defaults filled in for this
        grid's scene (width/height 0: the view's resolution; max_depth 0: the rules' default, or
        ``Scene.default_max_depth`` where the scene has one, 5 when a surface's Ks + T is over 1;
        threads 0: 1), validated as a render would."""
        return self._ll.grid_resolve_desc(self._h, self._scene_depth(desc))

    def _over_budget(self, e: WorkLimitError, desc: dict) -> WorkLimitError:
        """The library's error of a sample over the ray budget with the command line's options
        that change it (the threshold only under the rules with a cutoff)."""
        cutoff = desc.get("rules", RULES["paper"]) != RULES["spd"]
        opts = ("--threshold, " if cutoff else "") + "--max-rays, --max-depth"
        return WorkLimitError(f"{e} (mprt's options: {opts})")

    def tiling(self, desc: dict):
        """(samples_w, samples_h, tiles_x, tiles_y): the sample grid of a render (pixel centres
        under paper rules, pixel corners under spd rules) and its tiles (edge desc['tile'])."""
        return self._ll.grid_tiling(self._h, desc)

    def tile_rect(self, desc: dict, tile: int) -> tuple:
        """(x0, y0, x1, y1): the samples of tile number ``tile``, columns x0..x1-1, rows y0..y1-1."""
        return self._ll.grid_tile_rect(self._h, desc, tile)

    def camera_rays(self, width: int = 0, height: int = 0, rules: str = "paper", first: int = 0,
                    n: int | None = None):
        """The eye rays of a render exactly as the renderer makes them, one per sample (pixel
        centres under paper rules, pixel corners under spd rules), row by row from the top:
        (origins, unit directions), float64 (n, 3) each; samples first..first+n-1 (default:
        all from first)."""
        desc = render_desc(width, height, rules)
        sw, sh, _, _ = self.tiling(desc)
        if n is None:
            n = sw * sh - int(first)
        return self._ll.grid_camera_rays(self._h, desc, first, n)

    def trace_tile(self, desc: dict, tile: int, samples: np.ndarray, rays: np.ndarray, visits: np.ndarray):
        """Trace one tile, recording its rays and stage visits into the given buffers
        (``RAY_DTYPE`` and ``VISIT_DTYPE`` arrays) and its sample colours into ``samples``.
        Returns (nrays, nvisits, fitted); when fitted is False the records did not fit and
        nothing was written: nrays and nvisits are the sizes needed."""
        desc = self._scene_depth(desc)
        try:
            return self._ll.grid_trace_tile(self._h, desc, tile, samples, rays, visits)
        except WorkLimitError as e:
            raise self._over_budget(e, desc) from None

    def trace_tiles(self, desc: dict, tiles: np.ndarray, samples: np.ndarray, first_ray: int, rays: np.ndarray,
                    visits: np.ndarray):
        """Trace the tiles (``np.intc`` tile numbers) in order, writing each record once, in place,
        from the start of ``rays`` and ``visits`` with ray ids numbered on from ``first_ray``, and
        each tile's sample colours into ``samples``, the whole sample image ((samples_h, samples_w,
        3) float64).  Stops before a tile that would not fit.  Returns (tiles traced, nrays,
        nvisits); (0, nrays, nvisits) when not even the first tile fits: the sizes it needs."""
        desc = self._scene_depth(desc)
        try:
            return self._ll.grid_trace_tiles(self._h, desc, tiles, samples, first_ray, rays, visits)
        except WorkLimitError as e:
            raise self._over_budget(e, desc) from None

    # -- rendering and intersection ----------------------------------------------------------
    def render(self, width: int = 0, height: int = 0, rules: str = "paper", threshold: float | None = None,
               threads: int = 1, max_depth: int = 0, ambient: float | None = None, tile: int | None = None,
               mailbox: bool = False, conventions: dict | None = None, max_rays: int | None = None):
        """Render; returns (image as float32 array (H, W, 3), counters dict).

        width/height 0 use the scene's view resolution.  rules is 'paper'
        (pixel centres, contribution cutoff at ``threshold``) or 'spd' (SPD's
        procedure: pixel corners averaged, depth 5, no cutoff) or 'paper1992' (paper rules with
        the workload conventions that reproduce the paper's counts); ``conventions`` overrides
        single conventions by name (``CONVENTIONS``); ``max_rays`` bounds the rays of one sample
        (a sample needing more raises ``WorkLimitError`` naming it); ``max_depth`` 0 is the rules'
        depth, or 5 for a scene with a material whose Ks + T is over 1 (``Scene.default_max_depth``)."""
        desc = self._scene_depth(render_desc(width, height, rules, threshold, max_depth, threads, tile, ambient,
                                             mailbox, conventions, max_rays))
        full = self.resolve(desc)
        img = np.zeros((full["height"], full["width"], 3), dtype=np.float32)
        try:
            return img, self._ll.grid_render(self._h, desc, img)
        except WorkLimitError as e:
            raise self._over_budget(e, desc) from None

    def intersect(self, origins, directions, return_counters: bool = False):
        """Closest hit of each ray: (t, prim) arrays; t is inf and prim -1 on a miss.

        t is measured in units of the given direction (which need not be
        unit length).  With ``return_counters``, also the counters."""
        t, prim, counters = self._ll.grid_intersect(self._h, origins, directions)
        return (t, prim, counters) if return_counters else (t, prim)


def _scene_grid(scene: Scene, n: int | Sequence[int] | None = None, max_bytes: int = 0,
                listing: str = "exact") -> Grid:
    """Build a uniform grid of n per axis (or (nx, ny, nz)) voxels over the scene;
    None picks ``default_grid()``.  max_bytes bounds its memory (0: the library's default);
    listing 'exact' lists a primitive in the voxels its surface touches, 'box' in those its
    bounding box touches, 'occupied' (a study, not watertight) only in those whose interior its
    surface meets."""
    return Grid(scene, scene.default_grid() if n is None else n, max_bytes, listing)


_scene_grid.__name__, _scene_grid.__qualname__ = "grid", "Scene.grid"
Scene.grid = _scene_grid


def write_png(path, image) -> None:
    """Write an (H, W, 3) float image with values in [0, 1] as an 8-bit PNG."""
    img = np.ascontiguousarray(image, dtype=np.float32)
    if img.ndim != 3 or img.shape[2] != 3:
        raise InvalidArgument(f"image must have shape (H, W, 3), not {img.shape}")
    with replacing(path) as tmp:
        binding().image_write_png(tmp, img)
