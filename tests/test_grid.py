"""Grid walking and intersection against brute force, hard cases, scale."""
import numpy as np
import pytest

import mprt


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


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_grid_hits_equal_brute_force(name):
    """For every SPD scene, closest hits through several grids equal the one-voxel grid's (brute force), bit for bit."""
    scene = mprt.Scene.spd(name, 2 if name != "tree" else 5)
    o, d = random_rays(scene, 4000, seed=hash(name) % 1000)
    co, cd = scene.camera_rays(48, 48)
    o, d = np.vstack([o, co]), np.vstack([d, cd])
    t_ref, p_ref = scene.grid(1).intersect(o, d)
    assert np.isfinite(t_ref).sum() > 500, "too few hits to mean anything"
    for n in (4, 17, (3, 29, 8), 60):
        t, p = scene.grid(n).intersect(o, d)
        assert np.array_equal(p, p_ref), f"grid {n}: {np.sum(p != p_ref)} rays hit another primitive"
        assert np.array_equal(t, t_ref), f"grid {n}"


def polygon_groups(scene):
    """Polygons of the scene's NFF text, grouped by material (one group per 'f' line)."""
    groups, i = [], 0
    lines = scene.to_nff().splitlines()
    while i < len(lines):
        parts = lines[i].split()
        if parts and parts[0] == "f":
            groups.append([])
        if parts and parts[0] == "p":
            n = int(parts[1])
            groups[-1].append(np.array([[float(v) for v in lines[i + 1 + k].split()] for k in range(n)]))
            i += n + 1
        else:
            i += 1
    return groups


def edge_points(polys):
    """Every vertex and every edge midpoint of the polygons."""
    pts = [v for p in polys for v in p]
    pts += [(p[k] + p[(k + 1) % len(p)]) / 2 for p in polys for k in range(len(p))]
    return np.unique(np.array(pts), axis=0)


def closed_solids(name):
    scene = mprt.Scene.spd(name, 4 if name == "tetra" else 3)
    groups = polygon_groups(scene)
    if name == "tetra":  # one material; every 4 consecutive triangles close a tetrahedron
        polys = groups[0]
        return scene, [polys[k:k + 4] for k in range(0, len(polys), 4)]
    return scene, groups[1:]  # gears: one material per gear; the first group is the floor


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
    terrain = polygon_groups(scene)[1]
    pts = edge_points(terrain)
    inner = (np.abs(pts[:, 0]) < 1 - 1e-9) & (np.abs(pts[:, 1]) < 1 - 1e-9)
    pts = pts[inner]
    o = pts.copy()
    o[:, 2] = 10.0
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    t, p = scene.grid(9).intersect(o, d)
    assert len(o) > 1000
    assert int(np.sum(~np.isfinite(t))) == 0, "rays slipped between terrain triangles"


def test_tangent_and_grazing_rays_on_a_sphere():
    """Rays tangent to a sphere and grazing past it are decided consistently by grid and brute force."""
    s = mprt.Scene()
    s.add_sphere((0, 0, 0), 1.0)
    s.add_sphere((3, 0, 0), 0.5)
    y = np.linspace(0.999999, 1.000001, 201)
    o = np.stack([np.full_like(y, -5), y, np.zeros_like(y)], axis=1)
    d = np.tile([1.0, 0, 0], (len(y), 1))
    t1, p1 = s.grid(1).intersect(o, d)
    t9, p9 = s.grid(9).intersect(o, d)
    assert np.array_equal(p1, p9) and np.array_equal(t1, t9)
    assert np.all(p1[y < 1] == 0) and np.all(p1[y > 1.0000001] != 0)
    hit = y < 1
    np.testing.assert_allclose(t1[hit], 5 - np.sqrt(1 - y[hit] ** 2), rtol=0, atol=2e-6)


@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_scaled_scene_hits_the_same_primitives(scale):
    """The same scene scaled by 1e-6 or 1e6 gives the same hit primitives and scaled distances."""
    base = mprt.Scene.spd("balls", 2)
    text = base.to_nff()
    out = []
    for line in text.splitlines():
        parts = line.split()
        if parts and parts[0] == "s":
            x, yy, z, r = map(float, parts[1:])
            out.append(f"s {x * scale!r} {yy * scale!r} {z * scale!r} {r * scale!r}")
        elif parts and parts[0] in ("from", "at"):
            out.append(parts[0] + " " + " ".join(repr(float(v) * scale) for v in parts[1:]))
        elif parts and parts[0] == "hither":
            out.append(f"hither {float(parts[1]) * scale!r}")
        elif len(parts) == 3 and parts[0][0] in "-0123456789":
            out.append(" ".join(repr(float(v) * scale) for v in parts))
        elif parts and parts[0] == "l":
            out.append("l " + " ".join(repr(float(v) * scale) for v in parts[1:4]))
        else:
            out.append(line)
    scaled = mprt.Scene.from_text("\n".join(out) + "\n", "scaled.nff")
    o, d = base.camera_rays(64, 64)
    so, sd = scaled.camera_rays(64, 64)
    t0, p0 = base.grid(12).intersect(o, d)
    t1, p1 = scaled.grid(12).intersect(so, sd)
    assert np.mean(p0 == p1) > 0.999
    both = (p0 == p1) & np.isfinite(t0)
    np.testing.assert_allclose(t1[both] / scale, t0[both], rtol=1e-9)


def test_grid_stats_and_bad_subdivisions():
    """Grid statistics add up, and impossible subdivisions are clear errors."""
    scene = mprt.Scene.spd("balls", 1)
    st = scene.grid((4, 5, 6)).stats()
    assert st["voxels"] == 120 and st["n"] == [4, 5, 6]
    assert 0 < st["nonempty"] <= 120
    assert st["mean_len"] == pytest.approx(st["refs"] / st["nonempty"])
    with pytest.raises(mprt.InvalidArgument, match="1..1024"):
        scene.grid(2000)
    with pytest.raises(MemoryError, match="allowed"):
        scene.grid(1024, max_bytes=1 << 20)


def test_intersect_rejects_nan_and_zero_directions():
    """A NaN origin or a zero direction is an InvalidArgument naming the ray."""
    scene = mprt.Scene.spd("balls", 1)
    g = scene.grid(4)
    with pytest.raises(mprt.InvalidArgument, match="ray 1"):
        g.intersect([[0, 0, 5], [np.nan, 0, 5]], [[0, 0, -1], [0, 0, -1]])
    with pytest.raises(mprt.InvalidArgument, match="ray 0"):
        g.intersect([[0, 0, 5]], [[0, 0, 0]])
