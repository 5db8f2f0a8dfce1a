"""Scene and Grid: the idiomatic layer over the C library.

Every C call goes through ``_check``, which turns a status code into a typed
exception carrying the library's own message.  Buffers are numpy arrays
handed to C without copies (``ffi.from_buffer``); no cffi object escapes.
"""
from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from . import _mprt, _mprt32

KINDS = ("sphere", "polygon", "cylinder", "cone")
SPD_SCENES = ("balls", "gears", "mount", "rings", "tetra", "tree")
SPD_DEFAULT_SIZES = {"balls": 4, "gears": 4, "mount": 6, "rings": 7, "tetra": 6, "tree": 11}
COUNTER_NAMES = (
    "eye_rays",
    "eye_hits",
    "reflect_rays",
    "refract_rays",
    "shadow_rays",
    "suppressed_rays",
    "voxels_traversed",
    "hits",
)
RULES = {"paper": 0, "spd": 1}
EXT_VERSION = _mprt.ffi.string(_mprt.lib.mprt_ext_version()).decode()
_PRECISIONS = {"double": _mprt, "single": _mprt32}


class MprtError(Exception):
    """Base of mprt's errors; never raised itself."""


class InvalidArgument(MprtError, ValueError):
    """An argument is out of range, NaN, degenerate or malformed."""


class SceneParseError(MprtError, ValueError):
    """Scene text is malformed; the message names file and line."""


class SceneStateError(MprtError, RuntimeError):
    """The call is not allowed in the object's current state."""


class CapacityError(MprtError, RuntimeError):
    """A buffer was too small (internal; callers should not see it)."""


def _error_class(ext, rc):
    lib = ext.lib
    return {
        lib.MPRT_ERR_INVALID_ARG: InvalidArgument,
        lib.MPRT_ERR_PARSE: SceneParseError,
        lib.MPRT_ERR_STATE: SceneStateError,
        lib.MPRT_ERR_CAPACITY: CapacityError,
        lib.MPRT_ERR_OUT_OF_MEMORY: MemoryError,
        lib.MPRT_ERR_IO: OSError,
    }.get(rc, MprtError)


def _check(ext, rc, message):
    if rc == 0:
        return
    text = ext.ffi.string(message).decode(errors="replace") if message != ext.ffi.NULL else ""
    if not text:
        text = ext.ffi.string(ext.lib.mprt_status_str(rc)).decode()
    raise _error_class(ext, rc)(text)


def _vec3(name, value):
    a = np.asarray(value, dtype=np.float64).reshape(-1)
    if a.shape != (3,):
        raise InvalidArgument(f"{name}: expected 3 numbers, got {a.size}")
    return a


class Scene:
    """A scene: primitives, materials, lights, view and background.

    Build one from an NFF file (``Scene.from_nff``), NFF text
    (``Scene.from_text``), an SPD generator (``Scene.spd``) or by hand with
    the ``add_*`` methods.  ``precision`` selects the double (default) or the
    single-precision build of the library.
    """

    def __init__(self, precision: str = "double"):
        if precision not in _PRECISIONS:
            raise InvalidArgument(f"precision must be 'double' or 'single', not {precision!r}")
        self._ext = _PRECISIONS[precision]
        self.precision = precision
        out = self._ext.ffi.new("mprt_scene **")
        rc = self._ext.lib.mprt_scene_create(out)
        if rc:
            raise MemoryError("mprt_scene_create failed")
        self._h = self._ext.ffi.gc(out[0], self._ext.lib.mprt_scene_destroy)
        self.name = "scene"
        self._grids = []

    # -- construction ---------------------------------------------------
    def _call(self, rc):
        _check(self._ext, rc, self._ext.lib.mprt_scene_errmsg(self._h))

    @classmethod
    def from_nff(cls, path, precision: str = "double") -> "Scene":
        """Load an NFF file."""
        s = cls(precision)
        s._call(s._ext.lib.mprt_scene_load_nff(s._h, os.fsencode(path)))
        s.name = os.path.basename(os.fspath(path))
        return s

    @classmethod
    def from_text(cls, text: str, name: str = "<string>", precision: str = "double") -> "Scene":
        """Parse NFF text; ``name`` appears in error messages."""
        s = cls(precision)
        data = text.encode()
        s._call(s._ext.lib.mprt_scene_parse_nff(s._h, data, len(data), name.encode()))
        s.name = name
        return s

    @classmethod
    def spd(cls, name: str, size: int | None = None, precision: str = "double") -> "Scene":
        """Generate SPD scene ``name`` at SPD size factor ``size`` (None: the SPD default)."""
        if name not in SPD_SCENES:
            raise InvalidArgument(f"unknown SPD scene {name!r}; choose one of {', '.join(SPD_SCENES)}")
        if size is not None and (not isinstance(size, (int, np.integer)) or size < 1):
            raise InvalidArgument(f"SPD size must be a positive integer, not {size!r}")
        s = cls(precision)
        s._call(s._ext.lib.mprt_scene_spd(s._h, name.encode(), int(size or 0)))
        s.name = f"{name}:{size or SPD_DEFAULT_SIZES[name]}"
        return s

    @classmethod
    def load(cls, spec: str, precision: str = "double") -> "Scene":
        """An NFF path, or an SPD name with an optional size: ``balls``, ``balls:2``."""
        base, _, size = spec.partition(":")
        if base in SPD_SCENES and not os.path.exists(spec):
            if size and not size.isdigit():
                raise InvalidArgument(f"SPD size in {spec!r} must be a positive integer")
            return cls.spd(base, int(size) if size else None, precision)
        if not os.path.exists(spec):
            raise InvalidArgument(
                f"scene {spec!r} is neither a file nor an SPD scene ({', '.join(SPD_SCENES)}[:size])"
            )
        return cls.from_nff(spec, precision)

    def _ensure_unlocked(self):
        if any(g() is not None for g in self._grids):
            raise SceneStateError("the scene has grids; change it before building a grid")

    def set_view(self, eye, at, up, angle, hither=0.0, resolution=(512, 512)):
        self._ensure_unlocked()
        self._call(self._ext.lib.mprt_scene_set_view(
            self._h, self._ptr(_vec3("eye", eye)), self._ptr(_vec3("at", at)), self._ptr(_vec3("up", up)),
            float(angle), float(hither), int(resolution[0]), int(resolution[1])))

    def set_background(self, rgb):
        self._ensure_unlocked()
        self._call(self._ext.lib.mprt_scene_set_background(self._h, self._ptr(_vec3("rgb", rgb))))

    def add_light(self, pos, rgb=None):
        self._ensure_unlocked()
        c = self._ptr(_vec3("rgb", rgb)) if rgb is not None else self._ext.ffi.NULL
        self._call(self._ext.lib.mprt_scene_add_light(self._h, self._ptr(_vec3("pos", pos)), c))

    def set_material(self, rgb, kd, ks, shine, t, ior):
        self._ensure_unlocked()
        self._call(self._ext.lib.mprt_scene_set_material(
            self._h, self._ptr(_vec3("rgb", rgb)), float(kd), float(ks), float(shine), float(t), float(ior)))

    def add_sphere(self, center, radius):
        self._ensure_unlocked()
        self._call(self._ext.lib.mprt_scene_add_sphere(self._h, self._ptr(_vec3("center", center)), float(radius)))

    def add_polygon(self, vertices, normals=None):
        self._ensure_unlocked()
        v = np.ascontiguousarray(vertices, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise InvalidArgument(f"polygon vertices must have shape (n, 3), not {v.shape}")
        nrm = self._ext.ffi.NULL
        if normals is not None:
            nn = np.ascontiguousarray(normals, dtype=np.float64)
            if nn.shape != v.shape:
                raise InvalidArgument(f"polygon normals must have shape {v.shape}, not {nn.shape}")
            nrm = self._ptr(nn)
        self._call(self._ext.lib.mprt_scene_add_polygon(self._h, v.shape[0], self._ptr(v), nrm))

    def add_cone(self, base, base_radius, apex, apex_radius):
        self._ensure_unlocked()
        self._call(self._ext.lib.mprt_scene_add_cone(
            self._h, self._ptr(_vec3("base", base)), float(base_radius), self._ptr(_vec3("apex", apex)),
            float(apex_radius)))

    def _ptr(self, a):
        # a typed from_buffer keeps the array alive as long as the pointer
        # (a cast of it would not: temporaries could be freed and reused)
        return self._ext.ffi.from_buffer("double[]", a)

    # -- queries --------------------------------------------------------
    def info(self) -> dict:
        """Counts by kind, bounding box, view and background."""
        ffi, lib = self._ext.ffi, self._ext.lib
        i = ffi.new("mprt_scene_info *")
        self._call(lib.mprt_scene_get_info(self._h, i))
        return {
            "prims": i.prims,
            "count": {k: i.count[n] for n, k in enumerate(KINDS)},
            "patches": i.patches,
            "vertices": i.vertices,
            "lights": i.lights,
            "materials": i.materials,
            "dropped": i.dropped,
            "warning": ffi.string(lib.mprt_scene_warning(self._h)).decode(errors="replace"),
            "lo": list(i.lo),
            "hi": list(i.hi),
            "from": list(getattr(i, "from")),
            "at": list(i.at),
            "up": list(i.up),
            "angle": i.angle,
            "hither": i.hither,
            "resolution": (i.width, i.height),
            "background": list(i.background),
        }

    def camera_rays(self, width: int = 0, height: int = 0):
        """The paper rules' primary rays, one through each pixel centre, as the
        renderer makes them (row by row from the top): (origins, unit
        directions), each of shape (width*height, 3)."""
        info = self.info()
        w = int(width) or info["resolution"][0]
        h = int(height) or info["resolution"][1]
        eye, at, up = (np.array(info[k], dtype=np.float64) for k in ("from", "at", "up"))
        fwd = (at - eye) / np.linalg.norm(at - eye)
        right = np.cross(fwd, up)
        right /= np.linalg.norm(right)
        upv = np.cross(right, fwd)
        pitch = 2 * np.tan(np.radians(info["angle"]) / 2) / max(h - 1, 1)
        ii, jj = np.meshgrid(np.arange(w), np.arange(h))
        d = (fwd + ((ii - (w - 1) / 2) * pitch)[..., None] * right
             + (((h - 1) / 2 - jj) * pitch)[..., None] * upv).reshape(-1, 3)
        d /= np.linalg.norm(d, axis=1)[:, None]
        return np.broadcast_to(eye, d.shape).copy(), d

    def content_hash(self) -> str:
        """SHA-256 of the scene's NFF text (cached once the scene has a grid,
        since it cannot change then): names the scene in traces."""
        if getattr(self, "_hash", None) and any(g() is not None for g in self._grids):
            return self._hash
        import hashlib

        self._hash = hashlib.sha256(self.to_nff().encode()).hexdigest()
        return self._hash

    def to_nff(self) -> str:
        """The scene as NFF text (full precision, reads back equal)."""
        ffi, lib = self._ext.ffi, self._ext.lib
        need = ffi.new("size_t *")
        rc = lib.mprt_scene_write_nff(self._h, ffi.NULL, 0, need)
        if rc not in (0, lib.MPRT_ERR_CAPACITY):
            self._call(rc)
        buf = ffi.new("char[]", need[0])
        self._call(lib.mprt_scene_write_nff(self._h, buf, need[0], need))
        return ffi.string(buf).decode()

    def default_grid(self, density: float = 8.0, limit: int = 256) -> tuple:
        """A subdivision from the primitive count and the box's shape: about
        ``density`` * N^(1/3) voxels along the longest axis, the other axes in
        proportion (pbrt's rule with its 3 raised to 8: over the six SPD
        scenes at 256x256, density 8 was at most 1.5x slower than the best of
        3/4/6/8 on any scene, density 3 up to 4.8x; see README), each clamped
        to 1..``limit``."""
        info = self.info()
        ext = np.maximum(np.subtract(info["hi"], info["lo"]), 0.0)
        longest = float(ext.max()) or 1.0
        along = density * max(info["prims"], 1) ** (1.0 / 3.0)
        return tuple(int(min(max(round(along * e / longest), 1), limit)) for e in ext)

    def grid(self, n: int | Sequence[int] | None = None, max_bytes: int = 0) -> "Grid":
        """Build a uniform grid of n per axis (or (nx, ny, nz)) voxels;
        None picks ``default_grid()``."""
        return Grid(self, self.default_grid() if n is None else n, max_bytes)


class Grid:
    """The voxel grid over a scene: renders images and intersects rays."""

    def __init__(self, scene: Scene, n, max_bytes: int = 0):
        import weakref

        if isinstance(n, (int, np.integer)):
            dims = (int(n),) * 3
        else:
            dims = tuple(int(v) for v in n)
            if len(dims) != 3:
                raise InvalidArgument(f"grid subdivision must be one number or three, not {n!r}")
        self.scene = scene
        self.n = dims
        self._ext = ext = scene._ext
        out = ext.ffi.new("mprt_grid **")
        rc = ext.lib.mprt_grid_create(scene._h, dims[0], dims[1], dims[2], int(max_bytes), out)
        if out[0] == ext.ffi.NULL:
            raise MemoryError("mprt_grid_create: out of memory")
        h = ext.ffi.gc(out[0], ext.lib.mprt_grid_destroy)
        _check(ext, rc, ext.lib.mprt_grid_errmsg(h))
        self._h = h
        scene._grids.append(weakref.ref(self))

    def _call(self, rc):
        _check(self._ext, rc, self._ext.lib.mprt_grid_errmsg(self._h))

    def stats(self) -> dict:
        """Non-empty voxels, list lengths, memory."""
        s = self._ext.ffi.new("mprt_grid_stats *")
        self._call(self._ext.lib.mprt_grid_get_stats(self._h, s))
        return {
            "n": list(s.n),
            "voxels": s.voxels,
            "nonempty": s.nonempty,
            "refs": s.refs,
            "max_len": s.max_len,
            "mean_len": s.mean_len,
            "bytes": s.bytes,
            "lo": list(s.lo),
            "hi": list(s.hi),
        }

    def _counters(self, c) -> dict:
        d = {name: getattr(c, name) for name in COUNTER_NAMES}
        d["tests"] = {k: c.tests[i] for i, k in enumerate(KINDS)}
        d["polygon_vertices"] = c.polygon_vertices
        d["os_visits"] = c.os_visits
        d["ic_visits"] = c.ic_visits
        d["sc_visits"] = c.sc_visits
        return d

    def render(self, width: int = 0, height: int = 0, rules: str = "paper", threshold: float | None = None,
               threads: int = 1, max_depth: int = 0, ambient: float | None = None, tile: int = 16,
               mailbox: bool = False):
        """Render; returns (image as float32 array (H, W, 3), counters dict).

        width/height 0 use the scene's view resolution.  rules is 'paper'
        (pixel centres, contribution cutoff at ``threshold``) or 'spd' (SPD's
        procedure: pixel corners averaged, depth 5, no cutoff)."""
        ffi, lib = self._ext.ffi, self._ext.lib
        if rules not in RULES:
            raise InvalidArgument(f"rules must be 'paper' or 'spd', not {rules!r}")
        d = ffi.new("mprt_render_desc *")
        lib.mprt_render_desc_init(d)
        d.width, d.height = int(width), int(height)
        d.rules = RULES[rules]
        if threshold is not None:
            d.threshold = float(threshold)
        if ambient is not None:
            d.ambient = float(ambient)
        d.threads = int(threads)
        d.max_depth = int(max_depth)
        d.tile = int(tile)
        d.mailbox = 1 if mailbox else 0
        res = self.scene.info()["resolution"]
        w = int(width) or res[0]
        h = int(height) or res[1]
        if w < 1 or h < 1 or w > 65536 or h > 65536:
            raise InvalidArgument(f"render: resolution {w}x{h} is not in 1..65536")
        img = np.zeros((h, w, 3), dtype=np.float32)
        c = ffi.new("mprt_counters *")
        self._call(lib.mprt_grid_render(self._h, d, ffi.cast("float *", ffi.from_buffer(img)), img.size, c))
        return img, self._counters(c)

    def trace(self, width: int = 0, height: int = 0, rules: str = "paper", threshold: float | None = None, **kw):
        """Trace (a subset of) the image recording every stage visit; returns
        (image, Trace).  See mprt.trace.trace_grid for the options (threads,
        tiles, sample, path for streaming to disk, progress, mailbox...)."""
        from .trace import trace_grid

        return trace_grid(self, width, height, rules, threshold, **kw)

    def intersect(self, origins, directions, return_counters: bool = False):
        """Closest hit of each ray: (t, prim) arrays; t is inf and prim -1 on a miss.

        t is measured in units of the given direction (which need not be
        unit length)."""
        ffi, lib = self._ext.ffi, self._ext.lib
        o = np.ascontiguousarray(origins, dtype=np.float64)
        dd = np.ascontiguousarray(directions, dtype=np.float64)
        if o.ndim != 2 or o.shape[1] != 3 or dd.shape != o.shape:
            raise InvalidArgument(f"origins and directions must both have shape (n, 3), not {o.shape} and {dd.shape}")
        n = o.shape[0]
        t = np.empty(n, dtype=np.float64)
        prim = np.empty(n, dtype=np.int32)
        c = ffi.new("mprt_counters *")
        self._call(lib.mprt_grid_intersect(
            self._h, n, ffi.cast("double *", ffi.from_buffer(o)), ffi.cast("double *", ffi.from_buffer(dd)),
            ffi.cast("double *", ffi.from_buffer(t)), ffi.cast("int32_t *", ffi.from_buffer(prim)), c))
        if return_counters:
            return t, prim, self._counters(c)
        return t, prim


def write_png(path, image) -> None:
    """Write an (H, W, 3) float image with values in [0, 1] as an 8-bit PNG."""
    img = np.ascontiguousarray(image, dtype=np.float32)
    if img.ndim != 3 or img.shape[2] != 3:
        raise InvalidArgument(f"image must have shape (H, W, 3), not {img.shape}")
    ffi, lib = _mprt.ffi, _mprt.lib
    rc = lib.mprt_image_write_png(os.fsencode(path), img.shape[1], img.shape[0],
                                  ffi.cast("float *", ffi.from_buffer(img)))
    if rc:
        raise _error_class(_mprt, rc)(f"{path}: cannot write PNG ({ffi.string(lib.mprt_status_str(rc)).decode()})")
