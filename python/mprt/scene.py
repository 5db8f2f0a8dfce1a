"""Scene: primitives, materials, lights, view and background.

Build one from an NFF file, NFF text, an SPD generator or by hand; read it
back as a summary (``info``), as per-primitive arrays (``prim_table``) or as
NFF text.  ``Scene.grid(n)`` (a uniform voxel grid over the scene) is added by
``mprt.grid``, the layer above, so that this module does not depend on it.
"""
from __future__ import annotations

import hashlib
import os
import weakref

import numpy as np

from ._lowlevel import KINDS, binding
from .errors import InvalidArgument

SPD_SCENES = ("balls", "gears", "mount", "rings", "tetra", "tree")
SPD_DEFAULT_SIZES = {"balls": 4, "gears": 4, "mount": 6, "rings": 7, "tetra": 6, "tree": 11}
# The depth limit of the ray trees of a scene whose surfaces include a material with Ks + T over 1
# (the classic glass, "f .9 .9 .9 .1 .9 50 .9 1.33"), unless one is asked for: SPD's (its rules'
# depth 5, the eye ray at level 1), as the classic NFF renderers limit depth.  The reflection and
# refraction rays of such a surface may carry more light in all than their parent, so the
# contribution cutoff need not end its trees: glass facing glass or a mirror doubles them at every
# level up to the paper rules' safety depth of 64, far past any ray budget.  At depth 5 a
# sample's tree has at most 31 (1 + lights) rays.
OVER_ONE_MAX_DEPTH = 5
OVER_ONE_MARGIN = 1e-12     # Ks + T above 1 + this is over 1 (the NFF reader's margin for decimal text)


class Scene:
    """A scene held by the C library.

    ``precision`` selects the double (default) or the single-precision build
    of the library (float geometry, for the precision study).
    """

    def __init__(self, precision: str = "double"):
        self._ll = binding(precision)
        self.precision = precision
        self._h = self._ll.scene_create()
        self.name = "scene"
        self._grids = []     # weak references to the grids built over this scene
        self._hash = None

    # -- construction ---------------------------------------------------------------
    @classmethod
    def from_nff(cls, path, precision: str = "double", skip_unknown: bool = False) -> "Scene":
        """Load an NFF file.  An unknown entity (an extension line such as ``fp``, ``Q 0``) is an
        error naming it; ``skip_unknown`` reads the file without such entities (and the number
        lines after each), listing each with its count in ``notes``."""
        s = cls(precision)
        s._ll.scene_load_nff(s._h, path, skip_unknown)
        s.name = os.path.basename(os.fspath(path))
        return s

    @classmethod
    def from_text(cls, text: str, name: str = "<string>", precision: str = "double",
                  skip_unknown: bool = False) -> "Scene":
        """Parse NFF text; ``name`` appears in error messages (``skip_unknown``: as in from_nff)."""
        s = cls(precision)
        s._ll.scene_parse_nff(s._h, text, name, skip_unknown)
        s.name = name
        return s

    @property
    def notes(self) -> list:
        """The NFF reader's notes, one string each: a file's materials with Ks + T over 1 (read
        as written; the ray budget of a sample bounds their ray trees, and renders and traces
        limit their depth: ``default_max_depth``) and, under ``skip_unknown``, each unknown entity
        skipped with its count and first lines (for a material line such as 'fp', the material
        its surfaces take instead)."""
        return self._ll.scene_notes(self._h)

    def over_one(self) -> int:
        """How many of the materials that primitives use have Ks + T over 1 (the classic glass:
        read as written, and ``default_max_depth`` limits the depth of the scene's ray trees)."""
        m = self.materials()
        over = m["ks"] + m["t"] > 1 + OVER_ONE_MARGIN
        if not over.any():      # (the common case: no primitive table to read)
            return 0
        return int(np.count_nonzero(over[np.unique(self.prim_table()["material"])]))

    def default_max_depth(self) -> int:
        """The depth limit a render or trace of this scene takes when none is asked for (max_depth
        0): ``OVER_ONE_MAX_DEPTH`` (5, SPD's) when a surface's material has Ks + T over 1
        (``over_one``), else 0, the rules' own (paper and paper1992 64, spd 5)."""
        return OVER_ONE_MAX_DEPTH if self.over_one() else 0

    @classmethod
    def spd(cls, name: str, size: int | None = None, precision: str = "double") -> "Scene":
        """Generate SPD scene ``name`` at SPD size factor ``size`` (None: the SPD default)."""
        if name not in SPD_SCENES:
            raise InvalidArgument(f"unknown SPD scene {name!r}; choose one of {', '.join(SPD_SCENES)}")
        if size is not None and (not isinstance(size, (int, np.integer)) or size < 1):
            raise InvalidArgument(f"SPD size must be a positive integer, not {size!r}")
        s = cls(precision)
        s._ll.scene_spd(s._h, name, int(size or 0))
        s.name = f"{name}:{size or SPD_DEFAULT_SIZES[name]}"
        return s

    @classmethod
    def load(cls, spec: str, precision: str = "double") -> "Scene":
        """An SPD name with an optional size (``balls``, ``balls:2``: always the generator, even
        when a file of that name exists; ``./balls`` names the file), or an NFF path."""
        base, colon, size = spec.partition(":")
        if base in SPD_SCENES:
            if colon and not size.isdigit():
                raise InvalidArgument(f"SPD size in {spec!r} must be a positive integer")
            return cls.spd(base, int(size) if size else None, precision)
        if os.path.isdir(spec):
            raise InvalidArgument(f"scene {spec!r} is a directory, not an NFF file")
        if not os.path.exists(spec):
            raise InvalidArgument(
                f"scene {spec!r} is neither a file nor an SPD scene ({', '.join(SPD_SCENES)}[:size])"
            )
        return cls.from_nff(spec, precision)

    def _has_grids(self) -> bool:
        return any(g() is not None for g in self._grids)

    def _add_grid(self, grid) -> None:
        """Called by Grid: from now on the scene cannot change (the library refuses with
        SceneStateError), so its content hash can be cached."""
        self._grids.append(weakref.ref(grid))

    def set_view(self, eye, at, up, angle, hither=0.0, resolution=(512, 512)):
        self._ll.scene_set_view(self._h, eye, at, up, angle, hither, resolution[0], resolution[1])

    def set_background(self, rgb):
        self._ll.scene_set_background(self._h, rgb)

    def add_light(self, pos, rgb=None):
        self._ll.scene_add_light(self._h, pos, rgb)

    def set_material(self, rgb, kd, ks, shine, t, ior):
        self._ll.scene_set_material(self._h, rgb, kd, ks, shine, t, ior)

    def add_sphere(self, center, radius):
        self._ll.scene_add_sphere(self._h, center, radius)

    def add_polygon(self, vertices, normals=None):
        self._ll.scene_add_polygon(self._h, vertices, normals)

    def add_cone(self, base, base_radius, apex, apex_radius):
        self._ll.scene_add_cone(self._h, base, base_radius, apex, apex_radius)

    # -- queries --------------------------------------------------------------------
    def info(self) -> dict:
        """Counts by kind, bounding box, view and background."""
        i = self._ll.scene_get_info(self._h)
        i["count"] = dict(zip(KINDS, i["count"]))
        i["resolution"] = (i.pop("width"), i.pop("height"))
        i["warning"] = self._ll.scene_warning(self._h)
        return i

    def prim_table(self) -> dict:
        """Per primitive id: 'kind' (mprt.Kind), 'words' (shape data size in 32-bit words) and
        'material' (index), int32 arrays."""
        return self._ll.scene_get_prims(self._h, self.info()["prims"])

    def primitives(self) -> dict:
        """Every primitive as the library stores it (no NFF parsing):

        - 'kind', 'words', 'material': per primitive id, as ``prim_table``;
        - 'spheres': 'id', 'center' (n, 3), 'radius' (n,);
        - 'cones' (cylinders included; 'kind' tells them apart): 'id', 'base' (n, 3),
          'base_radius', 'apex' (n, 3), 'apex_radius';
        - 'polygons': 'id', 'vstart' (n + 1,), 'vertices' (m, 3): polygon k has the vertices
          vertices[vstart[k]:vstart[k + 1]].
        Shapes are in primitive-id order within each kind."""
        info = self.info()
        count = info["count"]
        out = self._ll.scene_get_prims(self._h, info["prims"])
        ids, s = self._ll.scene_get_spheres(self._h, count["sphere"])
        out["spheres"] = {"id": ids, "center": s[:, :3], "radius": s[:, 3]}
        ids, c = self._ll.scene_get_cones(self._h, count["cone"] + count["cylinder"])
        out["cones"] = {"id": ids, "base": c[:, :3], "base_radius": c[:, 3], "apex": c[:, 4:7], "apex_radius": c[:, 7]}
        ids, vstart, verts = self._ll.scene_get_polygons(self._h, count["polygon"], info["vertices"])
        out["polygons"] = {"id": ids, "vstart": vstart, "vertices": verts}
        return out

    def materials(self) -> dict:
        """The material table (``primitives()['material']`` indexes it): 'rgb' (n, 3), 'kd',
        'ks', 'shine', 't' (transmission), 'ior'."""
        m = self._ll.scene_get_materials(self._h, self.info()["materials"])
        return {"rgb": m[:, :3], "kd": m[:, 3], "ks": m[:, 4], "shine": m[:, 5], "t": m[:, 6], "ior": m[:, 7]}

    def lights(self) -> dict:
        """The point lights: 'position' (n, 3) and 'rgb' (n, 3), the intensity the renderer uses."""
        data = self._ll.scene_get_lights(self._h, self.info()["lights"])
        return {"position": data[:, :3], "rgb": data[:, 3:]}

    def content_hash(self) -> str:
        """SHA-256 of the scene's NFF text (cached once the scene has a grid,
        since it cannot change then): names the scene in traces."""
        if self._hash is None or not self._has_grids():
            self._hash = hashlib.sha256(self.to_nff().encode()).hexdigest()
        return self._hash

    def to_nff(self) -> str:
        """The scene as NFF text (full precision, reads back equal)."""
        return self._ll.scene_write_nff(self._h)

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
