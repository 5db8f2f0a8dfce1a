"""The grid's and the renderer's C calls (grid.c, render.c, camera.c, png.c): the voxel grid,
its statistics and lists, the render description, rendering, intersecting, eye rays, tiles
traced into trace records, and images."""
from __future__ import annotations

import os

import numpy as np

from ..errors import InvalidArgument
from .core import KINDS, RAY_DTYPE, VISIT_DTYPE, Calls, Rules, Status, _plain, _struct_dict, error_class, points


class GridCalls(Calls):
    """Grid handles (mprt_grid_*), the render description, and images."""

    def _grid(self, h, rc):
        self._check(rc, self.lib.mprt_grid_errmsg, h)

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
