"""The scene's C calls (scene.c, scene_query.c, nff.c, nff_write.c, spd.c): creating a scene,
reading and writing NFF, the SPD generators, adding what a scene holds, and its queries."""
from __future__ import annotations

import os

import numpy as np

from ..errors import InvalidArgument
from .core import Calls, Status, _plain, _struct_dict, points, vec3


class SceneCalls(Calls):
    """Scene handles: mprt_scene_*."""

    def _scene(self, h, rc):
        self._check(rc, self.lib.mprt_scene_errmsg, h)

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
