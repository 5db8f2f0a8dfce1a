"""Listings at voxel boundaries: the default ('exact': every voxel whose closed box, grown by the
margin, the surface touches) is watertight on rays made to meet voxel corners, edges and faces
exactly; 'occupied' (only the voxels whose interior the surface meets) lists fewer entries but
is not, and these tests pin both (studies/08_grid_shape/README.md, "Occupied voxels only").

The cases are in listing_cases.py; the reference is the one-voxel grid (brute force).
"""
import functools

import numpy as np
import pytest

import listing_cases as L
import mprt
from mprt import cli
from test_render import GRID_INDEPENDENT


@functools.cache
def case(name):
    """A hand-made case: scene, rays through its boundary points, their brute-force hits and
    its brute-force render."""
    s, pts = L.scene(name)
    o, d = L.rays(pts)
    ref = s.grid(1).intersect(o, d)
    return s, o, d, ref, s.grid(1).render()


@functools.cache
def tetra():
    s, o, d = L.tetra_rays()
    return s, o, d, s.grid(1).intersect(o, d)


@pytest.mark.parametrize("n", L.GRIDS, ids=str)
@pytest.mark.parametrize("name", L.CASES)
def test_exact_listing_hits_voxel_corners_edges_and_faces_as_brute_force(name, n):
    """Rays exactly through voxel corners, edges, faces and tangent points, and along voxel
    planes, hit what the one-voxel grid hits (t and primitive, bit for bit); the image and every
    grid-independent count equal the one-voxel grid's."""
    s, o, d, (t0, p0), (ref_img, ref_c) = case(name)
    assert np.isfinite(t0).sum() > 200, "too few hits to mean anything"
    t, p = s.grid(n).intersect(o, d)
    assert np.array_equal(p, p0), f"{np.sum(p != p0)} of {len(p)} rays hit another primitive"
    assert np.array_equal(t, t0)
    img, c = s.grid(n).render()
    assert np.array_equal(img, ref_img), f"{np.sum(np.any(img != ref_img, axis=2))} pixels differ"
    for k in GRID_INDEPENDENT:
        assert c[k] == ref_c[k], f"{k} {c[k]} != {ref_c[k]}"


@pytest.mark.parametrize("n", (8, 16, 32, (8, 16, 32)), ids=str)
def test_exact_listing_hits_tetra_vertices_and_edges_on_voxel_planes_as_brute_force(n):
    """SPD tetra with every vertex on a voxel plane: rays through each vertex and edge midpoint
    hit what the one-voxel grid hits."""
    s, o, d, (t0, p0) = tetra()
    assert np.isfinite(t0).sum() > 200
    t, p = s.grid(n).intersect(o, d)
    assert np.array_equal(p, p0) and np.array_equal(t, t0)


def voxel_sets(grid):
    """Per primitive id, the set of voxels listing it."""
    start, ids = grid.lists()
    vox = np.repeat(np.arange(len(start) - 1), np.diff(start.astype(np.int64)))
    out = {}
    for v, i in zip(vox.tolist(), ids.tolist()):
        out.setdefault(i, set()).add(v)
    return out


@pytest.mark.parametrize("name, n", [("tetra", 16), ("gears", 9), ("balls", (5, 13, 2)), ("rings", 12)])
def test_occupied_lists_a_primitive_in_some_of_the_voxels_exact_lists_it_in(name, n):
    """Every primitive is listed by 'occupied' in a non-empty subset of the voxels 'exact' lists
    it in; on tetra (vertices on voxel planes) the subset is strictly smaller."""
    s = mprt.Scene.spd(name, 4 if name == "tetra" else 1)
    ex, oc = voxel_sets(s.grid(n)), voxel_sets(s.grid(n, listing="occupied"))
    assert set(oc) == set(ex) == set(range(s.info()["prims"]))
    assert all(oc[i] <= ex[i] for i in ex)
    refs = {k: s.grid(n, listing=k).stats()["refs"] for k in ("exact", "occupied")}
    assert refs["occupied"] == sum(len(v) for v in oc.values())
    if name == "tetra":
        assert refs["occupied"] < refs["exact"]


def test_occupied_listing_leaks_through_a_voxel_edge():
    """Why 'occupied' is not the default: a ray through a voxel edge visits three of the four
    voxels around it, so a triangle meeting the edge from the fourth (listed there alone) is
    never tested; the ray through the shared edge of a coplanar pair, which the watertight test
    gives to that triangle, then misses the pair altogether, and pixels change."""
    s, o, d, (t0, p0), (ref_img, _) = case("edge_pair")
    for n in (2, 4, 8):
        t, p = s.grid(n, listing="occupied").intersect(o, d)
        leaks = np.isfinite(t0) & ~np.isfinite(t)
        assert leaks.sum() > 0, f"grid {n}: no ray leaks"
        img, _ = s.grid(n, listing="occupied").render()
        assert not np.array_equal(img, ref_img)
    # on a grid whose planes miss the edges, nothing changes
    t, p = s.grid(3, listing="occupied").intersect(o, d)
    assert np.array_equal(t, t0) and np.array_equal(p, p0)


def test_listing_option_of_the_command_line(tmp_path, capsys):
    """mprt render --listing occupied renders; an unknown listing is refused naming the choices."""
    out = tmp_path / "a.png"
    assert cli.main(["render", "tetra:3", "--res", "8x8", "--grid", "8", "--listing", "occupied", "-o", str(out)]) == 0
    assert out.stat().st_size > 0
    capsys.readouterr()
    with pytest.raises(SystemExit) as e:
        cli.main(["render", "tetra:3", "--listing", "closed"])
    assert e.value.code == 2
    assert "occupied" in capsys.readouterr().err
