"""Grid walking and intersection against brute force, hard cases, scale."""
import functools
import zlib

import numpy as np
import pytest

import mprt

SUBDIVISIONS = (4, 17, (3, 29, 8), 60)


def random_rays(scene, n, seed):
    """Rays from random points around the scene's box toward random points inside it."""
    info = scene.info()
    lo, hi = np.array(info["lo"]), np.array(info["hi"])
    ext = hi - lo
    rng = np.random.default_rng(seed)
    o = lo - 0.25 * ext + 1.5 * ext * rng.random((n, 3))
    target = lo + ext * rng.random((n, 3))
    d = target - o
    # a fifth of the rays run exactly along axes, another fifth from inside
    k = n // 5
    d[:k] = 0
    d[np.arange(k), rng.integers(0, 3, k)] = rng.choice([-1.0, 1.0], k)
    o[k:2 * k] = lo + ext * rng.random((k, 3))
    return o, d


@functools.cache
def brute_force(name):
    """A scene, random and camera rays, and their closest hits through a one-voxel grid (every
    primitive tested: brute force).  The seed comes from the name, stable across runs."""
    scene = mprt.Scene.spd(name, 2 if name != "tree" else 5)
    o, d = random_rays(scene, 4000, seed=zlib.crc32(name.encode()))
    brute = scene.grid(1)
    co, cd = brute.camera_rays(48, 48)
    o, d = np.vstack([o, co]), np.vstack([d, cd])
    t, p = brute.intersect(o, d)
    return scene, o, d, t, p


@pytest.mark.parametrize("n", SUBDIVISIONS, ids=str)
@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_grid_hits_equal_brute_force(name, n):
    """For every SPD scene, closest hits through a grid equal the one-voxel grid's (brute force), bit for bit."""
    scene, o, d, t_ref, p_ref = brute_force(name)
    assert np.isfinite(t_ref).sum() > 500, "too few hits to mean anything"
    t, p = scene.grid(n).intersect(o, d)
    assert np.array_equal(p, p_ref), f"{np.sum(p != p_ref)} rays hit another primitive"
    assert np.array_equal(t, t_ref)


def polygons_by_material(scene):
    """The scene's polygons (vertex arrays), grouped by material index, from the library."""
    prims = scene.primitives()
    polys = prims["polygons"]
    groups = {}
    for k, pid in enumerate(polys["id"]):
        verts = polys["vertices"][polys["vstart"][k]:polys["vstart"][k + 1]]
        groups.setdefault(int(prims["material"][pid]), []).append(verts)
    return groups


def edge_points(polys):
    """Every vertex and every edge midpoint of the polygons."""
    pts = [v for p in polys for v in p]
    pts += [(p[k] + p[(k + 1) % len(p)]) / 2 for p in polys for k in range(len(p))]
    return np.unique(np.array(pts), axis=0)


def closed_solids(name):
    scene = mprt.Scene.spd(name, 4 if name == "tetra" else 3)
    groups = polygons_by_material(scene)
    if name == "tetra":  # one material; every 4 consecutive triangles close a tetrahedron
        polys = groups[0]
        return scene, [polys[k:k + 4] for k in range(0, len(polys), 4)]
    return scene, [groups[m] for m in sorted(groups)[1:]]  # gears: one material per gear; material 0 is the floor


@pytest.mark.parametrize("name", ["tetra", "gears"])
def test_rays_from_inside_a_closed_mesh_through_its_edges_and_vertices_never_leak(name):
    """From inside each closed solid, rays aimed exactly at its vertices and edge midpoints hit it: 0 leaks."""
    scene, solids = closed_solids(name)
    grid = scene.grid(13)
    origins, dirs = [], []
    for polys in solids:
        pts = edge_points(polys)
        centre = np.mean(np.vstack(polys), axis=0)
        origins.append(np.broadcast_to(centre, pts.shape))
        dirs.append(pts - centre)
        # and from outside, through the same points, toward the centre: the rays enter the solid there
        origins.append(pts - 2 * (centre - pts))
        dirs.append(centre - pts)
    o, d = np.vstack(origins), np.vstack(dirs)
    t, _ = grid.intersect(o, d)
    # the inside rays must stop by t = 1 (the target point); the outside ones by t = 2
    limit = np.concatenate([np.full(len(x), 1.0 if k % 2 == 0 else 2.0) for k, x in enumerate(dirs)])
    leaks = int(np.sum(~(t <= limit * (1 + 1e-12))))
    assert len(o) > 500
    assert leaks == 0, f"{leaks} of {len(o)} rays slipped through the mesh"


def test_vertical_rays_through_the_mount_heightfield_never_leak():
    """Vertical rays through every interior vertex and edge midpoint of mount's terrain hit it: 0 leaks."""
    scene = mprt.Scene.spd("mount", 5)
    terrain = polygons_by_material(scene)[1]  # material 0: the spheres
    pts = edge_points(terrain)
    inner = (np.abs(pts[:, 0]) < 1 - 1e-9) & (np.abs(pts[:, 1]) < 1 - 1e-9)
    pts = pts[inner]
    o = pts.copy()
    o[:, 2] = 10.0
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    t, p = scene.grid(9).intersect(o, d)
    assert len(o) > 1000
    assert int(np.sum(~np.isfinite(t))) == 0, "rays slipped between terrain triangles"


def grazing_rays():
    """Two spheres and rays along x at heights 1 +- 1e-6 past the unit sphere at the origin."""
    s = mprt.Scene()
    s.add_sphere((0, 0, 0), 1.0)
    s.add_sphere((3, 0, 0), 0.5)
    y = np.linspace(0.999999, 1.000001, 201)
    o = np.stack([np.full_like(y, -5), y, np.zeros_like(y)], axis=1)
    d = np.tile([1.0, 0, 0], (len(y), 1))
    return s, y, o, d


def test_tangent_and_grazing_rays_are_decided_alike_by_grid_and_brute_force():
    """Rays tangent to a sphere and grazing past it hit the same primitives at the same t with 1 or 9^3 voxels."""
    s, _, o, d = grazing_rays()
    t1, p1 = s.grid(1).intersect(o, d)
    t9, p9 = s.grid(9).intersect(o, d)
    assert np.array_equal(p1, p9) and np.array_equal(t1, t9)


def test_grazing_rays_hit_the_sphere_exactly_below_its_radius():
    """Rays below height 1 hit the unit sphere where geometry says; rays clearly above miss it."""
    s, y, o, d = grazing_rays()
    t, p = s.grid(1).intersect(o, d)
    assert np.all(p[y < 1] == 0) and np.all(p[y > 1.0000001] != 0)
    hit = y < 1
    np.testing.assert_allclose(t[hit], 5 - np.sqrt(1 - y[hit] ** 2), rtol=0, atol=2e-6)


def scaled_copy(scene, scale):
    """The scene (spheres and polygons) with every length multiplied by scale, built through
    the scene API from the library's own arrays."""
    info, prims, mats, lights = scene.info(), scene.primitives(), scene.materials(), scene.lights()
    out = mprt.Scene()
    out.set_view(np.array(info["from"]) * scale, np.array(info["at"]) * scale, info["up"], info["angle"],
                 info["hither"] * scale, info["resolution"])
    out.set_background(info["background"])
    for pos, rgb in zip(lights["position"], lights["rgb"]):
        out.add_light(pos * scale, rgb)
    shapes = {int(i): ("sphere", k) for k, i in enumerate(prims["spheres"]["id"])}
    shapes.update({int(i): ("polygon", k) for k, i in enumerate(prims["polygons"]["id"])})
    assert len(shapes) == info["prims"] and info["patches"] == 0, "the copy handles spheres and flat polygons only"
    current = None
    for pid in range(info["prims"]):
        m = int(prims["material"][pid])
        if m != current:
            out.set_material(mats["rgb"][m], mats["kd"][m], mats["ks"][m], mats["shine"][m], mats["t"][m],
                             mats["ior"][m])
            current = m
        kind, k = shapes[pid]
        if kind == "sphere":
            out.add_sphere(prims["spheres"]["center"][k] * scale, prims["spheres"]["radius"][k] * scale)
        else:
            p = prims["polygons"]
            out.add_polygon(p["vertices"][p["vstart"][k]:p["vstart"][k + 1]] * scale)
    return out


@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_scaled_scene_hits_the_same_primitives(scale):
    """The same scene scaled by 1e-6 or 1e6 gives the same hit primitives and scaled distances."""
    base = mprt.Scene.spd("balls", 2)
    scaled = scaled_copy(base, scale)
    g0, g1 = base.grid(12), scaled.grid(12)
    o, d = g0.camera_rays(64, 64)
    so, sd = g1.camera_rays(64, 64)
    t0, p0 = g0.intersect(o, d)
    t1, p1 = g1.intersect(so, sd)
    assert np.mean(p0 == p1) > 0.999
    both = (p0 == p1) & np.isfinite(t0)
    np.testing.assert_allclose(t1[both] / scale, t0[both], rtol=1e-9)


def test_grid_stats_add_up():
    """A 4x5x6 grid has 120 voxels, some non-empty, and mean list length refs / non-empty."""
    st = mprt.Scene.spd("balls", 1).grid((4, 5, 6)).stats()
    assert st["voxels"] == 120 and st["n"] == [4, 5, 6]
    assert 0 < st["nonempty"] <= 120
    assert st["mean_len"] == pytest.approx(st["refs"] / st["nonempty"])


def test_subdivision_over_1024_is_an_invalid_argument():
    """A subdivision of 2000 is InvalidArgument naming the allowed range."""
    with pytest.raises(mprt.InvalidArgument, match="1..1024"):
        mprt.Scene.spd("balls", 1).grid(2000)


def test_grid_over_its_memory_bound_is_a_memory_error():
    """A 1024^3 grid within 1 MiB is a MemoryError saying what is allowed."""
    with pytest.raises(MemoryError, match="allowed"):
        mprt.Scene.spd("balls", 1).grid(1024, max_bytes=1 << 20)


def test_intersect_rejects_a_nan_origin_naming_the_ray():
    """A NaN in ray 1's origin is an InvalidArgument naming ray 1."""
    g = mprt.Scene.spd("balls", 1).grid(4)
    with pytest.raises(mprt.InvalidArgument, match="ray 1"):
        g.intersect([[0, 0, 5], [np.nan, 0, 5]], [[0, 0, -1], [0, 0, -1]])


def test_intersect_rejects_a_zero_direction_naming_the_ray():
    """A zero direction in ray 0 is an InvalidArgument naming ray 0."""
    g = mprt.Scene.spd("balls", 1).grid(4)
    with pytest.raises(mprt.InvalidArgument, match="ray 0"):
        g.intersect([[0, 0, 5]], [[0, 0, 0]])


def test_camera_rays_of_spd_rules_go_through_pixel_corners():
    """Under spd rules a WxH render has (W+1)(H+1) eye rays, under paper rules WxH, all from the eye."""
    g = mprt.Scene.spd("balls", 1).grid(4)
    po, pd = g.camera_rays(8, 6)
    so, sd = g.camera_rays(8, 6, rules="spd")
    assert len(po) == 48 and len(so) == 63
    assert np.all(po == g.scene.info()["from"]) and np.all(so == g.scene.info()["from"])
    np.testing.assert_allclose(np.linalg.norm(sd, axis=1), 1, rtol=1e-15)
