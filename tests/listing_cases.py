"""Scenes and rays built to meet voxel boundaries exactly: the cases on which a listing that
leaves out the voxels a primitive meets only on their boundary (``listing="occupied"``) must be
judged (tests/test_listing.py, studies/08_grid_shape/listing.py).

Each hand-made scene lies in the box [0, 4]^3, fixed by two small spheres in its corners, so
that the grids of ``GRIDS`` put voxel planes on whole (and half) numbers, where the scenes put
vertices, edges, faces and tangent points.  Rays go exactly through those points from many
directions, along the voxel planes and along voxel edges.  The reference is the one-voxel grid
(every primitive tested: brute force).
"""
from __future__ import annotations

import itertools

import numpy as np

import mprt

# subdivisions whose voxel planes fall on the scenes' whole numbers (4: every one; 2, 8 and
# (4, 8, 2) some or more), and 3, whose planes miss them (a control)
GRIDS = (2, 4, 8, (4, 8, 2), 3)
CASES = ("edge_pair", "corner_tetras", "face_squares", "tangent_spheres")


# per case a view (eye, at, up) whose middle row or column of pixel rays runs exactly through
# the case's voxel edges or tangent points (33 x 33 pixels: the middle ones on the axis)
VIEWS = {
    "edge_pair": ((-1.0, -1.0, 1.5), (2.0, 2.0, 1.5), (0.0, 0.0, 1.0)),
    "corner_tetras": ((-1.0, -1.0, 2.5), (3.0, 3.0, 2.5), (0.0, 0.0, 1.0)),
    "face_squares": ((2.0, 2.0, -6.0), (2.0, 2.0, 2.0), (0.0, 1.0, 0.0)),
    "tangent_spheres": ((-3.0, 1.5, 2.0), (1.5, 1.5, 2.0), (0.0, 0.0, 1.0)),
}


def _scene(case):
    s = mprt.Scene()
    s.set_view(*VIEWS[case], 40.0, resolution=(33, 33))
    s.set_background((0.1, 0.2, 0.3))
    s.add_light((2.0, 2.0, -3.0))
    s.add_light((4.0, 0.0, -2.0))
    s.set_material((0.9, 0.5, 0.3), 0.6, 0.4, 20.0, 0.0, 1.0)
    return s


def _frame(s):
    """The two corner spheres that make the grid's box [0, 4]^3."""
    s.set_material((0.2, 0.9, 0.2), 0.8, 0.0, 1.0, 0.0, 1.0)
    s.add_sphere((0.05, 0.05, 0.05), 0.05)
    s.add_sphere((3.95, 3.95, 3.95), 0.05)


def _tetra(s, a, b, c, d):
    """A closed tetrahedron (four triangles)."""
    for tri in ((a, b, c), (a, d, b), (a, c, d), (b, d, c)):
        s.add_polygon(tri)


def scene(case: str):
    """(scene, points): a hand-made scene and the points of it on voxel boundaries that rays
    are aimed at."""
    if case not in CASES:
        raise ValueError(f"unknown case {case!r}; choose from {', '.join(CASES)}")
    s = _scene(case)
    pts = []
    if case == "edge_pair":
        # coplanar triangle pairs whose shared edge lies on a voxel edge, one triangle in each of
        # two diagonal quadrants around it (the lower id in the quadrant a diagonal walk skips)
        for ax in range(3):
            u, v = (ax + 1) % 3, (ax + 2) % 3
            def p(a, uu, vv):
                q = [0.0, 0.0, 0.0]
                q[ax], q[u], q[v] = a, uu, vv
                return tuple(q)
            s.add_polygon([p(1.2, 2, 2), p(1.8, 2, 2), p(1.5, 1.5, 2.5)])
            s.add_polygon([p(1.8, 2, 2), p(1.2, 2, 2), p(1.5, 2.5, 1.5)])
            pts += [p(1.5, 2, 2), p(1.3, 2, 2), p(1.7, 2, 2)]
    elif case == "corner_tetras":
        # SPD tetra's pattern: tetrahedra inscribed in voxels, meeting at voxel corners; every
        # edge lies in a voxel face
        verts = []
        for c, sg in (((2, 2, 2), 1), ((2, 2, 2), -1), ((1, 3, 1), 1), ((3, 1, 2), 1)):
            c = np.array(c, float)
            t = [c, c + sg * np.array([1, 1, 0.]), c + sg * np.array([1, 0, 1.]), c + sg * np.array([0, 1, 1.])]
            _tetra(s, *[tuple(x) for x in t])
            verts.append(t)
        for t in verts:
            for a, b in itertools.combinations(range(4), 2):
                pts += [tuple(t[a]), tuple((t[a] + t[b]) / 2)]
            pts.append(tuple(sum(t) / 4))
    elif case == "face_squares":
        # axis-aligned squares lying in the voxel plane z = 2, voxel by voxel (as quads and as
        # triangle pairs), and a larger one in x = 2 crossing several voxels
        for i, j in itertools.product((1, 2), (1, 2)):
            q = [(i, j, 2.0), (i + 1, j, 2.0), (i + 1, j + 1, 2.0), (i, j + 1, 2.0)]
            if (i + j) % 2:
                s.add_polygon(q)
            else:
                s.add_polygon([q[0], q[1], q[2]])
                s.add_polygon([q[0], q[2], q[3]])
            pts += [(i, j, 2.0), (i + 0.5, j, 2.0), (i, j + 0.5, 2.0), (i + 0.5, j + 0.5, 2.0)]
        s.add_polygon([(2.0, 0.5, 0.5), (2.0, 3.5, 0.5), (2.0, 3.5, 1.5), (2.0, 0.5, 1.5)])
        pts += [(2.0, 1.0, 1.0), (2.0, 2.0, 1.0), (2.0, 1.5, 1.0), (3.0, 3.0, 2.0)]
    else:  # tangent_spheres
        # spheres tangent to voxel faces (and, through their tangent points, to edges)
        for c, r in (((1.5, 1.5, 1.5), 0.5), ((2.0, 2.0, 3.0), 1.0), ((3.0, 1.5, 2.5), 0.5), ((1.0, 3.0, 1.0), 1.0)):
            s.add_sphere(c, r)
            for ax, sg in itertools.product(range(3), (-1, 1)):
                q = list(c)
                q[ax] += sg * r
                pts.append(tuple(q))
    _frame(s)
    return s, np.array(pts, float)


def rays(points, seed: int = 1):
    """Rays exactly through each point: from the axes' and the diagonals' directions (both
    ways), along voxel planes (in-plane directions) and from random directions, each starting
    a little over 6 units away, so that they cross the box."""
    dirs = [np.array(d, float) for d in itertools.product((-1, 0, 1), repeat=3) if any(d)]
    dirs += [np.array(d, float) for d in ((1, 2, 0), (2, -1, 0), (0, 1, 3), (3, 0, -1), (1, 2, 3), (-3, 1, 2))]
    rng = np.random.default_rng(seed)
    dirs += list(rng.normal(size=(8, 3)))
    o, d = [], []
    for p in points:
        for v in dirs:
            o.append(p - 6.25 * v / np.max(np.abs(v)))
            d.append(v)
    return np.array(o), np.array(d)


def mismatches(s, o, d, n, listing: str, reference=None) -> int:
    """Rays whose closest hit (t and primitive) through grid n with ``listing`` differs from the
    one-voxel grid's."""
    t0, p0 = reference if reference is not None else s.grid(1).intersect(o, d)
    t, p = s.grid(n, listing=listing).intersect(o, d)
    return int(np.sum((t != t0) | (p != p0)))


def tetra_rays(size: int = 4, seed: int = 5):
    """SPD tetra (size 4: every vertex on the voxel planes of 8, 16 and 32 per axis) and rays
    from random points outside its box exactly through every vertex and edge midpoint."""
    s = mprt.Scene.spd("tetra", size)
    polys = s.primitives()["polygons"]
    v = polys["vertices"]
    pts = [v]
    for k in range(len(polys["vstart"]) - 1):
        a, b = polys["vstart"][k], polys["vstart"][k + 1]
        tri = v[a:b]
        pts.append((tri + np.roll(tri, 1, axis=0)) / 2)
    pts = np.unique(np.vstack(pts), axis=0)
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(len(pts), 3))
    return s, pts - 4 * d / np.linalg.norm(d, axis=1)[:, None], d
