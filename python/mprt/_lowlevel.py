"""The binding layer: the only module that imports the compiled extensions.

A ``Binding`` wraps one build of the C library (``double``: ``mprt._mprt``;
``single``: ``mprt._mprt32``, float geometry) with one method per C call.
Each method turns its arguments into C buffers (numpy arrays handed over
without copies by a typed ``ffi.from_buffer``, which keeps them alive for the
call), makes the call, and turns a failed status into the matching exception
of ``mprt.errors`` carrying the library's own message.  Nothing from cffi
leaves this module but opaque handles, which callers only hand back.

Everything the header defines is read from it, never written again here:
the enums (``Status``, ``Kind``, ``Rules``, ``Stage``, ``RayKind``,
``Outcome``), the render description's fields and defaults, the counters'
names, and the trace records' numpy layout (``RAY_DTYPE``, ``VISIT_DTYPE``,
built from the C structs' fields and offsets).
"""
from __future__ import annotations

import enum
import os

import numpy as np

from . import _mprt, _mprt32
from .errors import CapacityError, InvalidArgument, MprtError, SceneParseError, SceneStateError, WorkLimitError
from .util.pages import sparse_zeros

_FFI = _mprt.ffi


def _enum(name: str, ctype: str, prefix: str, skip=()) -> type[enum.IntEnum]:
    """An IntEnum of the header's enum ``ctype``: members named without ``prefix``, in value order."""
    members = sorted((value, cname[len(prefix):]) for cname, value in _FFI.typeof(ctype).relements.items()
                     if cname.startswith(prefix) and cname not in skip)
    return enum.IntEnum(name, [(n, v) for v, n in members], module=__name__)


Status = _enum("Status", "mprt_status", "MPRT_")
Kind = _enum("Kind", "mprt_kind", "MPRT_", skip=("MPRT_NKINDS",))
Rules = _enum("Rules", "mprt_rules", "MPRT_RULES_")
Stage = _enum("Stage", "mprt_stage", "MPRT_STAGE_")
RayKind = _enum("RayKind", "mprt_ray_kind", "MPRT_RAY_")
Outcome = _enum("Outcome", "mprt_outcome", "MPRT_OUT_")
if len(Kind) != _mprt.lib.MPRT_NKINDS or [k.value for k in Kind] != list(range(len(Kind))):
    raise ImportError("mprt_kind is not 0..MPRT_NKINDS-1 in the header")

KINDS = tuple(k.name.lower() for k in Kind)     # "sphere", "polygon", "cylinder", "cone"
RULES = {r.name.lower(): r for r in Rules}      # "paper", "spd"

_ERRORS = {
    Status.ERR_INVALID_ARG: InvalidArgument,
    Status.ERR_PARSE: SceneParseError,
    Status.ERR_STATE: SceneStateError,
    Status.ERR_CAPACITY: CapacityError,
    Status.ERR_OUT_OF_MEMORY: MemoryError,
    Status.ERR_IO: OSError,
    Status.ERR_LIMIT: WorkLimitError,
}


def error_class(status: int) -> type[Exception]:
    """The exception raised for a failed status code."""
    return _ERRORS.get(status, MprtError)


# ---- trace records: numpy views of the C structs ------------------------------------------

_NUMPY_OF_C = {"int64_t": "<i8", "int32_t": "<i4", "int16_t": "<i2", "uint8_t": "u1", "uint32_t": "<u4",
               "double": "<f8"}


def _record_dtype(ffi, ctype: str) -> np.dtype:
    names, formats, offsets = [], [], []
    for name, field in ffi.typeof(ctype).fields:
        t = field.type
        names.append(name)
        offsets.append(field.offset)
        formats.append((_NUMPY_OF_C[t.item.cname], (t.length,)) if t.kind == "array" else _NUMPY_OF_C[t.cname])
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": ffi.sizeof(ctype)},
                    align=True)


RAY_DTYPE = _record_dtype(_FFI, "mprt_trace_ray")
VISIT_DTYPE = _record_dtype(_FFI, "mprt_trace_visit")
REPLAY_PROC_DTYPE = _record_dtype(_FFI, "mprt_replay_proc")
REPLAY_NODE_DTYPE = _record_dtype(_FFI, "mprt_replay_node")
REPLAY_PE_DTYPE = _record_dtype(_FFI, "mprt_replay_pe")
REPLAY_MEMORY_DTYPE = _record_dtype(_FFI, "mprt_replay_memory")
# What each C element type of a buffer argument is in numpy (Binding._buffer checks it).
_CTYPE_DTYPES = {"double": np.dtype(np.float64), "float": np.dtype(np.float32), "int32_t": np.dtype(np.int32),
                 "int": np.dtype(f"i{_FFI.sizeof('int')}"),
                 "int64_t": np.dtype(np.int64), "uint32_t": np.dtype(np.uint32), "mprt_trace_ray": RAY_DTYPE,
                 "mprt_trace_visit": VISIT_DTYPE, "mprt_replay_proc": REPLAY_PROC_DTYPE,
                 "mprt_replay_node": REPLAY_NODE_DTYPE, "mprt_replay_pe": REPLAY_PE_DTYPE,
                 "mprt_replay_memory": REPLAY_MEMORY_DTYPE}
for _ctype, _dt in (("mprt_trace_ray", RAY_DTYPE), ("mprt_trace_visit", VISIT_DTYPE)):
    if _record_dtype(_mprt32.ffi, _ctype) != _dt:
        raise ImportError(f"{_ctype} differs between the double and the single build")


# ---- argument conversion ---------------------------------------------------------------------

def _plain(a, dtype) -> np.ndarray:
    """``a`` as a C-contiguous, aligned array of ``dtype`` (a copy only when needed): a member
    memory-mapped from a trace file lies at any offset, and C reads plain arrays in place."""
    return np.require(a, dtype, ("C", "A"))


def vec3(name: str, value) -> np.ndarray:
    """Three doubles, or InvalidArgument naming the argument."""
    a = _plain(value, np.float64).reshape(-1)
    if a.shape != (3,):
        raise InvalidArgument(f"{name}: expected 3 numbers, got {a.size}")
    return a


def points(name: str, value) -> np.ndarray:
    """An (n, 3) array of doubles, or InvalidArgument naming the argument."""
    a = _plain(value, np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InvalidArgument(f"{name} must have shape (n, 3), not {a.shape}")
    return a


def _struct_dict(ffi, cdata, ctype: str) -> dict:
    """A C struct's fields by name (arrays as lists)."""
    return {name: list(getattr(cdata, name)) if f.type.kind == "array" else getattr(cdata, name)
            for name, f in ffi.typeof(ctype).fields}


class Binding:
    """One build of the library; one method per C function."""

    def __init__(self, ext, precision: str):
        self.ffi, self.lib = ext.ffi, ext.lib
        self.precision = precision
        self.version = self.ffi.string(self.lib.mprt_ext_version()).decode()

    # -- status ------------------------------------------------------------------------
    def status_str(self, status: int) -> str:
        return self.ffi.string(self.lib.mprt_status_str(status)).decode()

    def _text(self, ptr) -> str:
        return "" if ptr == self.ffi.NULL else self.ffi.string(ptr).decode(errors="replace")

    def _check(self, rc: int, errmsg, handle) -> None:
        """Raise the status's exception with the handle's message (read after the call)."""
        if rc != Status.OK:
            raise error_class(rc)(self._text(errmsg(handle)) or self.status_str(rc))

    def _scene(self, h, rc):
        self._check(rc, self.lib.mprt_scene_errmsg, h)

    def _grid(self, h, rc):
        self._check(rc, self.lib.mprt_grid_errmsg, h)

    def _buffer(self, ctype: str, a, n, writable: bool):
        """A typed view of a for C, after checking what C will do with it: a numpy array of
        ctype's exact dtype, C-contiguous (writable for outputs), holding at least n elements
        of ctype (None: C is told a's own size).  Anything else is InvalidArgument, so no
        caller can make C read or write past a buffer."""
        want = _CTYPE_DTYPES[ctype]
        if not isinstance(a, np.ndarray):
            raise InvalidArgument(f"{ctype} buffer: expected a numpy array, not {type(a).__name__}")
        if a.dtype != want:
            raise InvalidArgument(f"{ctype} buffer: dtype {a.dtype} is not {want} (C reads {ctype} records)")
        if not a.flags.c_contiguous:
            raise InvalidArgument(f"{ctype} buffer: the array is not C-contiguous")
        if writable and not a.flags.writeable:
            raise InvalidArgument(f"{ctype} buffer: the array is read-only, and C writes into it")
        if n is not None and (int(n) < 0 or a.size < int(n)):
            raise InvalidArgument(f"{ctype} buffer: holds {a.size} elements, C {'writes' if writable else 'reads'} {int(n)}")
        return self.ffi.from_buffer(ctype + "[]", a, require_writable=writable)

    def _in(self, ctype: str, a: np.ndarray, n=None):
        return self._buffer(ctype, a, n, False)

    def _out(self, ctype: str, a: np.ndarray, n=None):
        return self._buffer(ctype, a, n, True)

    @staticmethod
    def _records(name: str, a, dtype: np.dtype) -> np.ndarray:
        """A one-dimensional array of records of dtype (C takes its length as the count)."""
        if not isinstance(a, np.ndarray) or a.ndim != 1:
            raise InvalidArgument(f"{name} must be a one-dimensional numpy array of records, not "
                                  f"{getattr(a, 'shape', type(a).__name__)}")
        if a.dtype != dtype:
            raise InvalidArgument(f"{name}: dtype {a.dtype} is not the C library's record {dtype}")
        return a

    # -- scene -------------------------------------------------------------------------
    def scene_create(self):
        out = self.ffi.new("mprt_scene **")
        if self.lib.mprt_scene_create(out) != Status.OK:
            raise MemoryError("mprt_scene_create: out of memory")
        return self.ffi.gc(out[0], self.lib.mprt_scene_destroy)

    def scene_warning(self, h) -> str:
        return self._text(self.lib.mprt_scene_warning(h))

    def scene_notes(self, h) -> list:
        return self._text(self.lib.mprt_scene_notes(h)).splitlines()

    def _nff_flags(self, skip_unknown: bool) -> int:
        return self.lib.MPRT_NFF_SKIP_UNKNOWN if skip_unknown else 0

    def scene_load_nff(self, h, path, skip_unknown: bool = False) -> None:
        self._scene(h, self.lib.mprt_scene_load_nff_ex(h, os.fsencode(path), self._nff_flags(skip_unknown)))

    def scene_parse_nff(self, h, text: str, name: str, skip_unknown: bool = False) -> None:
        data = text.encode()
        self._scene(h, self.lib.mprt_scene_parse_nff_ex(h, data, len(data), name.encode(),
                                                        self._nff_flags(skip_unknown)))

    def scene_write_nff(self, h) -> str:
        ffi, lib = self.ffi, self.lib
        need = ffi.new("size_t *")
        rc = lib.mprt_scene_write_nff(h, ffi.NULL, 0, need)   # asks for the size
        if rc != Status.ERR_CAPACITY:
            self._scene(h, rc)
        buf = ffi.new("char[]", need[0])
        self._scene(h, lib.mprt_scene_write_nff(h, buf, need[0], need))
        return ffi.string(buf).decode()

    def scene_spd(self, h, name: str, size: int) -> None:
        self._scene(h, self.lib.mprt_scene_spd(h, name.encode(), int(size)))

    def scene_set_view(self, h, eye, at, up, angle, hither, width, height) -> None:
        self._scene(h, self.lib.mprt_scene_set_view(
            h, self._in("double", vec3("eye", eye)), self._in("double", vec3("at", at)),
            self._in("double", vec3("up", up)), float(angle), float(hither), int(width), int(height)))

    def scene_set_background(self, h, rgb) -> None:
        self._scene(h, self.lib.mprt_scene_set_background(h, self._in("double", vec3("rgb", rgb))))

    def scene_add_light(self, h, pos, rgb=None) -> None:
        c = self.ffi.NULL if rgb is None else self._in("double", vec3("rgb", rgb))
        self._scene(h, self.lib.mprt_scene_add_light(h, self._in("double", vec3("pos", pos)), c))

    def scene_set_material(self, h, rgb, kd, ks, shine, t, ior) -> None:
        self._scene(h, self.lib.mprt_scene_set_material(
            h, self._in("double", vec3("rgb", rgb)), float(kd), float(ks), float(shine), float(t), float(ior)))

    def scene_add_sphere(self, h, center, radius) -> None:
        self._scene(h, self.lib.mprt_scene_add_sphere(h, self._in("double", vec3("center", center)), float(radius)))

    def scene_add_polygon(self, h, vertices, normals=None) -> None:
        v = points("polygon vertices", vertices)
        nrm = self.ffi.NULL
        if normals is not None:
            nn = _plain(normals, np.float64)
            if nn.shape != v.shape:
                raise InvalidArgument(f"polygon normals must have shape {v.shape}, not {nn.shape}")
            nrm = self._in("double", nn)
        self._scene(h, self.lib.mprt_scene_add_polygon(h, v.shape[0], self._in("double", v), nrm))

    def scene_add_cone(self, h, base, base_radius, apex, apex_radius) -> None:
        self._scene(h, self.lib.mprt_scene_add_cone(
            h, self._in("double", vec3("base", base)), float(base_radius), self._in("double", vec3("apex", apex)),
            float(apex_radius)))

    def scene_get_info(self, h) -> dict:
        """The mprt_scene_info fields by name (arrays as lists)."""
        i = self.ffi.new("mprt_scene_info *")
        self._scene(h, self.lib.mprt_scene_get_info(h, i))
        return _struct_dict(self.ffi, i, "mprt_scene_info")

    def scene_get_prims(self, h, n: int) -> dict:
        """Per primitive id: kind, words (shape data size) and material, int32 arrays of length n."""
        out = {k: np.zeros(n, dtype=np.int32) for k in ("kind", "words", "material")}
        self._scene(h, self.lib.mprt_scene_get_prims(
            h, self._out("int32_t", out["kind"]), self._out("int32_t", out["words"]),
            self._out("int32_t", out["material"]), n))
        return out

    def scene_get_spheres(self, h, n: int):
        """(ids int32[n], data float64[n, 4]: centre xyz, radius) in primitive-id order."""
        ids, data = np.zeros(n, dtype=np.int32), np.zeros((n, 4))
        self._scene(h, self.lib.mprt_scene_get_spheres(h, self._out("int32_t", ids), self._out("double", data), n))
        return ids, data

    def scene_get_cones(self, h, n: int):
        """(ids int32[n], data float64[n, 8]: base xyz, base radius, apex xyz, apex radius) of the
        cones and cylinders, in primitive-id order."""
        ids, data = np.zeros(n, dtype=np.int32), np.zeros((n, 8))
        self._scene(h, self.lib.mprt_scene_get_cones(h, self._out("int32_t", ids), self._out("double", data), n))
        return ids, data

    def scene_get_polygons(self, h, npoly: int, nverts: int):
        """(ids int32[npoly], vstart int32[npoly + 1], verts float64[nverts, 3]): polygon k has the
        vertices verts[vstart[k]:vstart[k + 1]]."""
        ids, vstart, verts = np.zeros(npoly, dtype=np.int32), np.zeros(npoly + 1, dtype=np.int32), np.zeros((nverts, 3))
        self._scene(h, self.lib.mprt_scene_get_polygons(h, self._out("int32_t", ids), self._out("int32_t", vstart),
                                                        npoly, self._out("double", verts), nverts))
        return ids, vstart, verts

    def scene_get_materials(self, h, n: int) -> np.ndarray:
        """float64[n, 8]: r, g, b, kd, ks, shine, t, ior per material."""
        data = np.zeros((n, 8))
        self._scene(h, self.lib.mprt_scene_get_materials(h, self._out("double", data), n))
        return data

    def scene_get_lights(self, h, n: int) -> np.ndarray:
        """float64[n, 6]: position xyz, intensity rgb per light."""
        data = np.zeros((n, 6))
        self._scene(h, self.lib.mprt_scene_get_lights(h, self._out("double", data), n))
        return data

    # -- grid --------------------------------------------------------------------------
    def grid_create(self, scene_h, dims, max_bytes: int, listing: int = 0):
        ffi, lib = self.ffi, self.lib
        out = ffi.new("mprt_grid **")
        rc = lib.mprt_grid_create_listing(scene_h, dims[0], dims[1], dims[2], int(max_bytes), int(listing), out)
        if out[0] == ffi.NULL:
            raise MemoryError("mprt_grid_create: out of memory")
        h = ffi.gc(out[0], lib.mprt_grid_destroy)
        self._grid(h, rc)
        return h

    def grid_get_stats(self, h) -> dict:
        s = self.ffi.new("mprt_grid_stats *")
        self._grid(h, self.lib.mprt_grid_get_stats(h, s))
        return _struct_dict(self.ffi, s, "mprt_grid_stats")

    def grid_get_lists(self, h, voxels: int, refs: int):
        """The voxel lists in CSR form: (start uint32[voxels + 1], ids int32[refs])."""
        start = np.zeros(voxels + 1, dtype=np.uint32)
        ids = np.zeros(max(refs, 1), dtype=np.int32)
        self._grid(h, self.lib.mprt_grid_get_lists(h, self._out("uint32_t", start), start.size,
                                                   self._out("int32_t", ids), ids.size))
        return start, ids[:refs]

    def render_desc_init(self) -> dict:
        """The library's default render description, field by field."""
        d = self.ffi.new("mprt_render_desc *")
        self.lib.mprt_render_desc_init(d)
        return _struct_dict(self.ffi, d, "mprt_render_desc")

    def _struct(self, ctype: str, init, fields: dict, what: str):
        """A new C struct of type ``ctype``, set to its defaults by ``init`` then field by field
        from ``fields``; a field it does not have, or a value that does not fit, is an
        InvalidArgument naming ``what`` and the field."""
        d = self.ffi.new(ctype + " *")
        init(d)
        for k, v in fields.items():
            try:
                setattr(d, k, v)
            except AttributeError:
                raise InvalidArgument(f"{what} has no field {k!r}") from None
            except (TypeError, OverflowError, IndexError) as e:
                raise InvalidArgument(f"{what} field {k!r}: {e}") from None
        return d

    def _desc(self, desc: dict):
        return self._struct("mprt_render_desc", self.lib.mprt_render_desc_init, desc, "render description")

    def _counters(self, c) -> dict:
        """mprt_counters by name; the per-kind array as a dict by kind name."""
        out = {}
        for name, f in self.ffi.typeof("mprt_counters").fields:
            v = getattr(c, name)
            out[name] = {k: v[i] for i, k in enumerate(KINDS)} if f.type.kind == "array" else v
        return out

    def grid_resolve_desc(self, h, desc: dict) -> dict:
        """Every field of the description with the defaults resolved for the grid's scene, validated."""
        d = self._desc(desc)
        self._grid(h, self.lib.mprt_grid_resolve_desc(h, d, d))
        return _struct_dict(self.ffi, d, "mprt_render_desc")

    def grid_tile_rect(self, h, desc: dict, tile: int) -> tuple:
        """(x0, y0, x1, y1): tile's samples, columns x0..x1-1 and rows y0..y1-1."""
        rect = self.ffi.new("int[4]")
        self._grid(h, self.lib.mprt_grid_tile_rect(h, self._desc(desc), int(tile), rect))
        return tuple(rect)

    def grid_camera_rays(self, h, desc: dict, first: int, n: int):
        """Eye rays of samples first..first+n-1 as the renderer makes them: (origins, unit
        directions), float64[n, 3] each."""
        o, d = np.zeros((n, 3)), np.zeros((n, 3))
        self._grid(h, self.lib.mprt_grid_camera_rays(h, self._desc(desc), int(first), int(n), self._out("double", o),
                                                     self._out("double", d)))
        return o, d

    def grid_render(self, h, desc: dict, rgb: np.ndarray) -> dict:
        """Render into rgb (float32, C order, height*width*3); returns the counters."""
        c = self.ffi.new("mprt_counters *")
        self._grid(h, self.lib.mprt_grid_render(h, self._desc(desc), self._out("float", rgb, rgb.size), rgb.size, c))
        return self._counters(c)

    def grid_intersect(self, h, origins, directions):
        """Closest hits: (t float64[n], prim int32[n], counters)."""
        o = points("origins", origins)
        d = _plain(directions, np.float64)
        if d.shape != o.shape:
            raise InvalidArgument(f"origins and directions must both have shape (n, 3), not {o.shape} and {d.shape}")
        n = o.shape[0]
        t = np.empty(n, dtype=np.float64)
        prim = np.empty(n, dtype=np.int32)
        c = self.ffi.new("mprt_counters *")
        self._grid(h, self.lib.mprt_grid_intersect(h, n, self._in("double", o), self._in("double", d),
                                                   self._out("double", t), self._out("int32_t", prim), c))
        return t, prim, self._counters(c)

    def grid_tiling(self, h, desc: dict):
        """(samples_w, samples_h, tiles_x, tiles_y) of a render."""
        out = [self.ffi.new("int *") for _ in range(4)]
        self._grid(h, self.lib.mprt_grid_tiling(h, self._desc(desc), *out))
        return tuple(int(p[0]) for p in out)

    def grid_trace_tile(self, h, desc: dict, tile: int, samples: np.ndarray, rays: np.ndarray, visits: np.ndarray):
        """Trace one tile into the buffers: (nrays, nvisits, fitted).  When the records do not fit,
        fitted is False and nrays/nvisits are the numbers needed."""
        ffi = self.ffi
        nr, nv = ffi.new("size_t *"), ffi.new("size_t *")
        rc = self.lib.mprt_grid_trace_tile(
            h, self._desc(desc), int(tile), self._out("double", samples), samples.size,
            self._out("mprt_trace_ray", self._records("rays", rays, RAY_DTYPE)), len(rays), nr,
            self._out("mprt_trace_visit", self._records("visits", visits, VISIT_DTYPE)), len(visits),
            nv, ffi.NULL)
        if rc == Status.ERR_CAPACITY and (nr[0] > len(rays) or nv[0] > len(visits)):
            return int(nr[0]), int(nv[0]), False
        self._grid(h, rc)
        return int(nr[0]), int(nv[0]), True

    def grid_trace_tiles(self, h, desc: dict, tiles: np.ndarray, samples: np.ndarray, first_ray: int,
                         rays: np.ndarray, visits: np.ndarray):
        """Trace the tiles in order, records written in place from the buffers' starts with ray ids
        from first_ray, samples into the whole sample image: (tiles traced, nrays, nvisits).  Stops
        before a tile that would not fit; (0, nrays, nvisits needed) when the first does not."""
        ffi = self.ffi
        nr, nv, nt = ffi.new("size_t *"), ffi.new("size_t *"), ffi.new("size_t *")
        rc = self.lib.mprt_grid_trace_tiles(
            h, self._desc(desc), self._in("int", tiles), len(tiles), self._out("double", samples), samples.size,
            int(first_ray), self._out("mprt_trace_ray", rays), len(rays), nr, self._out("mprt_trace_visit", visits),
            len(visits), nv, nt, ffi.NULL)
        if rc == Status.ERR_CAPACITY and (nr[0] > len(rays) or nv[0] > len(visits)):
            return 0, int(nr[0]), int(nv[0])
        self._grid(h, rc)
        return int(nt[0]), int(nr[0]), int(nv[0])

    # -- replay ------------------------------------------------------------------------
    def _replay_config(self, config: dict):
        return self._struct("mprt_replay_config", self.lib.mprt_replay_config_init, config,
                            "replay configuration")

    def replay_create(self, config: dict):
        """A compiled replay of a machine: ``config`` holds mprt_replay_config's fields by name
        (the others keep mprt_replay_config_init's values); a bad field raises InvalidArgument
        with the library's message naming it."""
        ffi, lib = self.ffi, self.lib
        c = self._replay_config(config)
        out = ffi.new("mprt_replay **")
        rc = lib.mprt_replay_create(c, out)
        if out[0] == ffi.NULL:
            raise MemoryError("mprt_replay_create: out of memory")
        h = ffi.gc(out[0], lib.mprt_replay_destroy)
        self._check(rc, lib.mprt_replay_errmsg, h)
        return h

    def replay_set_config(self, h, config: dict) -> None:
        """Another configuration for the replay (the loaded trace stays)."""
        self._check(self.lib.mprt_replay_set_config(h, self._replay_config(config)), self.lib.mprt_replay_errmsg, h)

    def replay_load_priced(self, h, rays: np.ndarray, visits: np.ndarray, table: dict, children: np.ndarray,
                           prim_kind: np.ndarray, flits: np.ndarray | None = None, threads: int = 1) -> None:
        """Load the records, each visit priced as it loads with ``table`` (mprt_cost_table's fields
        by name, lights included) and ``children`` (as cost_children gives it), as ``replay_load``
        of the arrays ``cost_visits`` would make; ``flits`` (int64 per visit, as replay_set_flits
        takes them, or int32) receives their flits.  ``threads`` 2 or more: priced on a thread of
        their own ahead of the loading (the same replay, flits and errors)."""
        rays, visits = self._records("rays", rays, RAY_DTYPE), self._records("visits", visits, VISIT_DTYPE)
        if children.shape != (len(rays), 4) or children.dtype != np.int64 or not children.flags.c_contiguous:
            raise InvalidArgument(f"replay_load_priced: children must be int64[{len(rays)}, 4] as cost_children "
                                  "makes it")
        pk = _plain(prim_kind, np.int32)
        out = flits
        if flits is not None and getattr(flits, "dtype", None) != np.int64:
            out = np.zeros(len(visits), np.int64)       # (narrowed into flits after)
        try:
            self._load_priced(h, rays, visits, table, children, pk, out, threads)
        finally:
            if out is not flits:
                np.copyto(flits[:len(visits)], out, casting="unsafe")

    def _load_priced(self, h, rays, visits, table, children, pk, flits, threads) -> None:
        self._check(self.lib.mprt_replay_load_priced_threads(
            h, self._in("mprt_trace_ray", np.ascontiguousarray(rays), len(rays)), len(rays),
            self._in("mprt_trace_visit", np.ascontiguousarray(visits), len(visits)), len(visits),
            self.ffi.new("mprt_cost_table *", table), self._in("int64_t", children, 4 * len(rays)),
            self._in("int32_t", pk, len(pk)), len(pk),
            self.ffi.NULL if flits is None else self._out("int64_t", flits, len(visits)), max(1, int(threads))),
            self.lib.mprt_replay_errmsg, h)

    def replay_load(self, h, rays: np.ndarray, visits: np.ndarray, process: np.ndarray, receive: np.ndarray,
                    send: np.ndarray) -> None:
        """Load the records (RAY_DTYPE, VISIT_DTYPE) with int64 costs per visit (copied)."""
        rays, visits = self._records("rays", rays, RAY_DTYPE), self._records("visits", visits, VISIT_DTYPE)
        costs = [_plain(a, np.int64) for a in (process, receive, send)]
        for name, a in zip(("process", "receive", "send"), costs):
            if a.shape != (len(visits),):
                raise InvalidArgument(f"costs.{name} has shape {a.shape}, the trace has {len(visits)} visits")
        self._check(self.lib.mprt_replay_load(h, self._in("mprt_trace_ray", np.ascontiguousarray(rays), len(rays)),
                                              len(rays),
                                              self._in("mprt_trace_visit", np.ascontiguousarray(visits), len(visits)),
                                              len(visits), *(self._in("int64_t", a, len(visits)) for a in costs)),
                    self.lib.mprt_replay_errmsg, h)

    def replay_set_flits(self, h, flits: np.ndarray, kid_flits, inject_flits: int) -> None:
        """The packets' sizes for the ring: flits per visit (of the packet it sends on), per ray
        kind of a ray SC made, and of a primary ray SC made (copied)."""
        f = np.asarray(flits)
        if f.dtype != np.int64 or not f.flags.c_contiguous:   # widened into 4 KiB pages (cost.fast.fresh's reason)
            import mmap

            f = np.frombuffer(mmap.mmap(-1, max(8 * f.size, 1)), dtype=np.int64, count=f.size).reshape(f.shape)
            np.copyto(f, flits, casting="same_kind")
        k = _plain(kid_flits, np.int64)
        self._check(self.lib.mprt_replay_set_flits(h, self._in("int64_t", f), f.size, self._in("int64_t", k), k.size,
                                                   int(inject_flits)), self.lib.mprt_replay_errmsg, h)

    def replay_run(self, h, log: np.ndarray | None = None) -> bool:
        """Replay the loaded trace; ``log`` (int64, 8 * (visits + primary rays) entries)
        receives the events.  False when the machine deadlocked (its state stays readable
        by the getters)."""
        lib = self.lib
        rc = lib.mprt_replay_run(h, self.ffi.NULL if log is None else self._out("int64_t", log, log.size),
                                 0 if log is None else log.size)
        if rc == Status.ERR_STATE and self.replay_get_info(h)["deadlocked"]:
            return False
        self._check(rc, lib.mprt_replay_errmsg, h)
        return True

    def replay_work_bound(self, h) -> int:
        """mprt_replay_work_bound: a lower bound of the cycles of a run of the configuration set
        (the stages' work shared among their processors), at any level; nothing is run."""
        out = self.ffi.new("int64_t *")
        self._check(self.lib.mprt_replay_work_bound(h, out), self.lib.mprt_replay_errmsg, h)
        return int(out[0])

    def replay_get_info(self, h) -> dict:
        """mprt_replay_info of the last run, by field."""
        i = self.ffi.new("mprt_replay_info *")
        self._got(self.lib.mprt_replay_get_info(h, i), "info")
        return _struct_dict(self.ffi, i, "mprt_replay_info")

    def _got(self, rc: int, what: str) -> None:
        """A getter's status (its failures are the caller's: a run missing, a buffer too small)."""
        if rc != Status.OK:
            raise error_class(rc)(f"mprt_replay_get_{what}: {self.status_str(rc)}")

    def replay_get_procs(self, h, n: int) -> np.ndarray:
        """mprt_replay_proc per processor (REPLAY_PROC_DTYPE[n])."""
        out = np.zeros(n, dtype=REPLAY_PROC_DTYPE)
        self._got(self.lib.mprt_replay_get_procs(h, self._out("mprt_replay_proc", out, n), n), "procs")
        return out

    def replay_get_nodes(self, h, n: int) -> np.ndarray:
        """mprt_replay_node per stage of each PE (REPLAY_NODE_DTYPE[n])."""
        out = np.zeros(n, dtype=REPLAY_NODE_DTYPE)
        self._got(self.lib.mprt_replay_get_nodes(h, self._out("mprt_replay_node", out, n), n), "nodes")
        return out

    def replay_get_pes(self, h, n: int) -> np.ndarray:
        """mprt_replay_pe per PE (REPLAY_PE_DTYPE[n])."""
        out = np.zeros(n, dtype=REPLAY_PE_DTYPE)
        self._got(self.lib.mprt_replay_get_pes(h, self._out("mprt_replay_pe", out, n), n), "pes")
        return out

    def replay_get_trees(self, h, n: int):
        """Per primary ray (tree): (PE that admitted it int32[n], when int64[n]); -1: never."""
        pe, when = np.zeros(n, dtype=np.int32), np.zeros(n, dtype=np.int64)
        self._got(self.lib.mprt_replay_get_trees(h, self._out("int32_t", pe, n), self._out("int64_t", when, n), n), "trees")
        return pe, when

    def replay_record_busy(self, h, on: bool) -> None:
        """Record, in later runs, each stage's busy cycles at every tree's admission."""
        self._check(self.lib.mprt_replay_record_busy(h, int(bool(on))), self.lib.mprt_replay_errmsg, h)

    def replay_get_tree_busy(self, h, trees: int, stages: int) -> np.ndarray:
        """Per tree and stage (int64[trees, stages]): the busy cycles at its admission; -1: not
        admitted or not recorded."""
        out = np.zeros((trees, stages), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_tree_busy(h, self._out("int64_t", out), out.size), "tree_busy")
        return out

    def replay_get_links(self, h, pes: int, stages: int) -> np.ndarray:
        """Each ring link's busy cycles (int64[pes, stages]: link n from stage n to n + 1)."""
        out = np.zeros((pes, stages), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_links(h, self._out("int64_t", out), out.size), "links")
        return out

    def replay_get_ring(self, h, pe: int, stages: int, classes: int):
        """PE pe's ring at the end: (buffers int64[stages, classes]: source x 4 + destination
        stage of the packet holding each, -1 free; waiting packets int64[n, 4]: source,
        destination, node, phase, in the order they began to wait)."""
        n = self.ffi.new("size_t *")
        buffers = np.zeros((stages, classes), dtype=np.int64)
        waiting = np.zeros((4 * 3, ), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_ring(h, pe, self._out("int64_t", buffers), buffers.size,
                                                self._out("int64_t", waiting), waiting.size, n), "ring")
        return buffers, waiting[: 4 * n[0]].reshape(-1, 4)

    def replay_get_waiters(self, h, pe: int, stage: int, which: int) -> list:
        """Who waits for a slot in a stage's receive FIFO (which 0: sending stages, -1 the DIS)
        or send FIFO (which 1: replicas), in order."""
        n = self.ffi.new("size_t *")
        self.lib.mprt_replay_get_waiters(h, pe, stage, which, self.ffi.NULL, 0, n)
        out = np.zeros(max(n[0], 1), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_waiters(h, pe, stage, which, self._out("int64_t", out), out.size, n),
                  "waiters")
        return out[: n[0]].tolist()

    # -- visit costs -------------------------------------------------------------------
    def _cost_errmsg(self):
        return self.ffi.new("char[]", 512)

    def _cost_check(self, rc: int, msg) -> None:
        if rc != Status.OK:
            raise error_class(rc)(self.ffi.string(msg).decode(errors="replace") or self.status_str(rc))

    def cost_children(self, rays: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Children of every ray by kind (int64[len(rays), 4], into ``out`` if given);
        InvalidArgument naming a ray of an unknown kind or with a parent that is not a ray."""
        rays = np.ascontiguousarray(self._records("rays", rays, RAY_DTYPE))
        if out is None:
            out = np.empty((len(rays), 4), dtype=np.int64)
        elif out.shape != (len(rays), 4) or out.dtype != np.int64 or not out.flags.c_contiguous:
            raise InvalidArgument(f"cost_children: out must be int64[{len(rays)}, 4]")
        msg = self._cost_errmsg()
        self._cost_check(self.lib.mprt_cost_children(self._in("mprt_trace_ray", rays, len(rays)), len(rays),
                                                     self._out("int64_t", out, 4 * len(rays)), msg, len(msg)), msg)
        return out

    def cost_visits(self, table: dict, rays: np.ndarray, children: np.ndarray, prim_kind: np.ndarray,
                    visits: np.ndarray, prev_ray: int = -1, prev_outcome: int = 0, *, process=None, receive=None,
                    send=None, flits=None, runs=None, packets=None, threads: int = 1) -> None:
        """mprt_cost_visits: ``table`` holds mprt_cost_table's fields by name; the records are
        RAY_DTYPE, VISIT_DTYPE, ``children`` as cost_children gives it, ``prim_kind`` int32;
        the outputs given (int64 process, receive, send; int32 flits, runs (visits x 10) and
        packets (visits x 3)) are filled, by up to ``threads`` threads (the same results)."""
        ffi = self.ffi
        t = ffi.new("mprt_cost_table *", table)
        rays = np.ascontiguousarray(self._records("rays", rays, RAY_DTYPE))
        visits = np.ascontiguousarray(self._records("visits", visits, VISIT_DTYPE))
        n = len(visits)
        outs = []
        for name, a, ctype, width in (("process", process, "int64_t", 1), ("receive", receive, "int64_t", 1),
                                      ("send", send, "int64_t", 1), ("flits", flits, "int32_t", 1),
                                      ("runs", runs, "int32_t", 10), ("packets", packets, "int32_t", 3)):
            if a is None:
                outs.append(ffi.NULL)
                continue
            if a.dtype != np.dtype(ctype[:-2]) or not a.flags.c_contiguous or a.size != n * width:
                raise InvalidArgument(f"cost_visits: {name} must be a contiguous {ctype[:-2]} array of "
                                      f"{n * width} entries")
            outs.append(self._out(ctype, a, n * width))
        if children.shape != (len(rays), 4) or children.dtype != np.int64 or not children.flags.c_contiguous:
            raise InvalidArgument(f"cost_visits: children must be int64[{len(rays)}, 4] as cost_children makes it")
        pk = _plain(prim_kind, np.int32)
        msg = self._cost_errmsg()
        self._cost_check(self.lib.mprt_cost_visits(t, self._in("mprt_trace_ray", rays, len(rays)),
                                                   self._in("int64_t", children, 4 * len(rays)),
                                                   len(rays), self._in("int32_t", pk, len(pk)), len(pk),
                                                   self._in("mprt_trace_visit", visits, n), n, int(prev_ray),
                                                   int(prev_outcome), *outs, int(threads), msg, len(msg)), msg)

    def visit_keys(self, visits: np.ndarray, prim_material: np.ndarray, nvoxels: int, nmaterials: int):
        """mprt_visit_keys: (keys int32 per visit, voxel_refs int64[nvoxels], material_refs
        int64[nmaterials]); ValueError naming a visit whose key does not fit."""
        visits = self._records("visits", visits, VISIT_DTYPE)
        mat = _plain(prim_material, np.int64)
        keys = np.empty(len(visits), np.int32)
        vref, mref = sparse_zeros(int(nvoxels), np.int64), np.zeros(int(nmaterials), np.int64)  # (see memkeys.c)
        msg = self._cost_errmsg()
        if self.lib.mprt_visit_keys(self._in("mprt_trace_visit", np.ascontiguousarray(visits), len(visits)),
                                    len(visits), self._in("int64_t", mat), len(mat), self._out("int32_t", keys),
                                    self._out("int64_t", vref), len(vref), self._out("int64_t", mref), len(mref),
                                    msg, len(msg)) != Status.OK:
            raise ValueError(self.ffi.string(msg).decode(errors="replace"))
        return keys, vref, mref

    # -- replay: level 3, the memories ---------------------------------------------------
    def replay_set_memory(self, h, key: np.ndarray, ic: dict | None, sc: dict | None) -> None:
        """Give the loaded trace its memory data (copied): ``key`` int32 per visit (>= 0 an IC
        key, <= -2 SC key -2 - key, -1 none); ``ic``, ``sc``: None or dicts of ``line`` (bytes)
        and per key ``items``, ``resident`` (int32), ``line_start`` (int64, keys + 1), ``lines``
        (int64 line numbers)."""
        ffi = self.ffi
        keep = []

        def data(d):
            if d is None:
                return ffi.NULL
            c = ffi.new("mprt_replay_memory_data *")
            arrs = {k: _plain(d[k], t) for k, t in
                    (("items", np.int32), ("resident", np.int32), ("line_start", np.int64), ("lines", np.int64))}
            n = len(arrs["items"])
            if len(arrs["resident"]) != n or len(arrs["line_start"]) != n + 1:
                raise InvalidArgument("memory data: items, resident and line_start (keys + 1) differ in length")
            if len(arrs["lines"]) < (int(arrs["line_start"][-1]) if n + 1 else 0):
                raise InvalidArgument("memory data: fewer lines than line_start says")
            keep.append(arrs)
            c.nkeys, c.line = n, int(d["line"])
            c.items, c.resident = self._in("int32_t", arrs["items"]), self._in("int32_t", arrs["resident"])
            c.line_start, c.lines = self._in("int64_t", arrs["line_start"]), self._in("int64_t", arrs["lines"])
            keep.append(c)
            return c

        k = _plain(key, np.int32)
        self._check(self.lib.mprt_replay_set_memory(h, self._in("int32_t", k), len(k), data(ic), data(sc)),
                    self.lib.mprt_replay_errmsg, h)

    def replay_get_memory(self, h, pes: int, processors: int):
        """The last run's memory figures: (REPLAY_MEMORY_DTYPE[pes, 2] per PE and memory (IC, SC),
        int64[processors] memory stall per processor)."""
        out = np.zeros(2 * pes, dtype=REPLAY_MEMORY_DTYPE)
        stall = np.zeros(max(processors, 1), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_memory(h, self._out("mprt_replay_memory", out), out.size,
                                                  self._out("int64_t", stall), processors), "memory")
        return out.reshape(pes, 2), stall[:processors]

    # -- images ------------------------------------------------------------------------
    def samples_to_image(self, rules: int, samples: np.ndarray) -> np.ndarray:
        """Pixels (float32 (H, W, 3)) from samples (float64 (samples_h, samples_w, 3)) as the
        renderer reconstructs them under ``rules``."""
        s = _plain(samples, np.float64)
        if s.ndim != 3 or s.shape[2] != 3:
            raise InvalidArgument(f"samples must have shape (h, w, 3), not {s.shape}")
        shrink = 1 if rules == Rules.SPD else 0
        rgb = np.zeros((max(s.shape[0] - shrink, 0), max(s.shape[1] - shrink, 0), 3), dtype=np.float32)
        rc = self.lib.mprt_samples_to_image(int(rules), s.shape[1], s.shape[0], self._in("double", s),
                                            self._out("float", rgb), rgb.size)
        if rc != Status.OK:
            raise error_class(rc)(f"samples_to_image: {self.status_str(rc)}")
        return rgb

    def image_write_png(self, path, rgb: np.ndarray) -> None:
        """Write rgb (float32, C order, (H, W, 3)) as an 8-bit PNG."""
        if not isinstance(rgb, np.ndarray) or rgb.ndim != 3 or rgb.shape[2] != 3:
            raise InvalidArgument(f"rgb must have shape (h, w, 3), not {getattr(rgb, 'shape', type(rgb).__name__)}")
        rc = self.lib.mprt_image_write_png(os.fsencode(path), rgb.shape[1], rgb.shape[0],
                                           self._in("float", rgb, rgb.size))
        if rc != Status.OK:
            raise error_class(rc)(f"{os.fspath(path)}: cannot write PNG ({self.status_str(rc)})")

    def crc32_copy(self, src, crc: int = 0, dst=None) -> int:
        """zlib.crc32(src, crc) of a contiguous bytes-like object, and src's bytes copied to the
        start of dst (a writable bytes-like object at least as long, not overlapping src) in the
        same pass when dst is given; the library folds with carry-less multiplications where it
        can (several times zlib's speed) and lets other threads run meanwhile."""
        ffi = self.ffi
        s = ffi.from_buffer("char[]", src)
        d = ffi.NULL
        if dst is not None:
            d = ffi.from_buffer("char[]", dst, require_writable=True)
            if len(d) < len(s):
                raise InvalidArgument(f"crc32_copy: dst holds {len(d)} bytes, src {len(s)}")
        return int(self.lib.mprt_crc32_copy(d, s, len(s), int(crc) & 0xFFFFFFFF))

    def records_shift(self, src: np.ndarray, dst, offset: int, crc: int | None = None) -> int | None:
        """Copy the trace records src (a contiguous RAY_DTYPE or VISIT_DTYPE array) to the start of
        dst (a writable bytes-like object or array at least as long), their ray numbers moved on by
        offset (rays: id and parent unless negative; visits: ray), letting other threads run.
        With crc (zlib's running value) given, returns the CRC-32 of the bytes written, on from it."""
        if src.dtype not in (RAY_DTYPE, VISIT_DTYPE) or not src.flags.c_contiguous:
            raise InvalidArgument(f"records_shift: a contiguous array of trace records, not {src.dtype}")
        ffi = self.ffi
        s = ffi.from_buffer("char[]", src)
        d = ffi.from_buffer("char[]", dst, require_writable=True)
        if len(d) < len(s):
            raise InvalidArgument(f"records_shift: dst holds {len(d)} bytes, src {len(s)}")
        out = ffi.NULL if crc is None else ffi.new("uint32_t *", int(crc) & 0xFFFFFFFF)
        self.lib.mprt_trace_records_shift(int(src.dtype == VISIT_DTYPE), d, s, len(src), int(offset), out)
        return None if crc is None else int(out[0])


_BINDINGS = {"double": Binding(_mprt, "double"), "single": Binding(_mprt32, "single")}
PRECISIONS = tuple(_BINDINGS)
EXT_VERSION = _BINDINGS["double"].version


def binding(precision: str = "double") -> Binding:
    """The build of the library for ``precision`` ('double' or 'single')."""
    try:
        return _BINDINGS[precision]
    except (KeyError, TypeError):
        raise InvalidArgument(f"precision must be 'double' or 'single', not {precision!r}") from None
