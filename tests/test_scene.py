"""Scenes from Python: SPD generation, NFF round trip, errors."""
import os

import numpy as np
import pytest

import mprt

# Counts from shared/spd-reference/README.md: sphere, polygon, cylinder, cone, lights.
REFERENCE_COUNTS = {
    "balls": (7381, 1, 0, 0, 3),
    "gears": (0, 9345, 0, 0, 5),
    "mount": (4, 8192, 0, 0, 1),
    "rings": (4200, 1, 4200, 0, 3),
    "tetra": (0, 4096, 0, 0, 1),
    "tree": (4095, 1, 0, 4095, 7),
}


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_spd_default_scene_has_the_reference_counts(name):
    """Each SPD scene at its default size has the reference file's primitive and light counts."""
    info = mprt.Scene.spd(name).info()
    c = info["count"]
    assert (c["sphere"], c["polygon"], c["cylinder"], c["cone"], info["lights"]) == REFERENCE_COUNTS[name]
    assert info["resolution"] == (512, 512)
    assert info["background"] == pytest.approx([0.078, 0.361, 0.753])


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_spd_scene_matches_reference_file_geometry(name, spd_ref):
    """The generated scene's NFF reads back to the reference file's numbers within print precision."""
    ours = mprt.Scene.spd(name)
    ref = mprt.Scene.from_nff(os.path.join(spd_ref, f"{name}.nff"))
    a, b = ours.info(), ref.info()
    for key in ("prims", "vertices", "lights", "materials"):
        assert a[key] == b[key], key
    np.testing.assert_allclose(a["lo"], b["lo"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(a["hi"], b["hi"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(a["from"], b["from"], rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_nff_round_trip_is_exact(name):
    """Writing a scene as NFF and reading it back gives the same NFF text."""
    s = mprt.Scene.spd(name, 1)
    text = s.to_nff()
    again = mprt.Scene.from_text(text, "roundtrip.nff").to_nff()
    assert text == again


@pytest.mark.parametrize(
    "text, line, words",
    [
        ("s 0 0 0\n", 1, "expected"),
        ("v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0\nresolution 8 8\ns 0 0 0 nan\n", 8, "finite"),
        ("s 0 0 0 0\n", 1, "radius"),
        ("s 0 0 0 -1\n", 1, "radius"),
        ("p 3\n0 0 0\n1 0 0\n", 3, "end of file"),
        ("q 1 2 3\n", 1, "q"),
        ("c 0 0 0 1 0 0 0 1\n", 1, "coincide"),
        ("p 4\n0 0 0\n1 0 0\n1 1 0\n0 1 1\n", 1, "planar"),
    ],
)
def test_bad_nff_names_the_line(text, line, words):
    """Malformed NFF raises SceneParseError naming the file, the line and the problem."""
    with pytest.raises(mprt.SceneParseError) as e:
        mprt.Scene.from_text(text, "bad.nff")
    msg = str(e.value)
    assert f"bad.nff:{line}" in msg
    assert words in msg


def test_zero_area_polygon_is_dropped_with_a_warning():
    """A zero-area polygon is dropped, counted and reported with its line."""
    s = mprt.Scene.from_text("s 0 0 0 1\np 3\n0 0 0\n1 1 1\n2 2 2\n", "flat.nff")
    info = s.info()
    assert info["dropped"] == 1 and info["prims"] == 1
    assert "flat.nff:2" in info["warning"]


def test_missing_nff_file_is_an_os_error_naming_it(tmp_path):
    """A missing NFF file is an OSError naming it."""
    with pytest.raises(OSError, match="nope.nff"):
        mprt.Scene.from_nff(tmp_path / "nope.nff")


def test_unknown_spd_scene_lists_the_choices():
    """An unknown SPD name is an InvalidArgument listing the SPD scenes."""
    with pytest.raises(mprt.InvalidArgument, match="balls"):
        mprt.Scene.spd("teapot")


def test_scene_spec_that_is_neither_file_nor_spd_name_is_an_error():
    """'teapot:3' is neither a file nor an SPD scene: InvalidArgument saying so."""
    with pytest.raises(mprt.InvalidArgument, match="neither a file nor an SPD scene"):
        mprt.Scene.load("teapot:3")


@pytest.mark.parametrize("add, words", [
    (lambda s: s.add_sphere((0, 0, 0), 0), "radius"),
    (lambda s: s.add_sphere((0, float("nan"), 0), 1), "NaN"),
    (lambda s: s.add_cone((0, 0, 0), 1, (0, 0, 0), 0.5), "coincide"),
    (lambda s: s.add_polygon([(0, 0, 0), (1, 0, 0), (2, 0, 0)]), "zero area"),
    (lambda s: s.add_polygon([(0, 0), (1, 0), (1, 1)]), "shape"),
], ids=["zero radius", "NaN centre", "coincident cone ends", "collinear polygon", "2-D vertices"])
def test_scene_api_rejects_a_bad_primitive_and_stays_empty(add, words):
    """A degenerate or malformed primitive is an InvalidArgument naming the problem, and is not added."""
    s = mprt.Scene()
    with pytest.raises(mprt.InvalidArgument, match=words):
        add(s)
    assert s.info()["prims"] == 0


def test_scene_cannot_change_while_it_has_a_grid():
    """Adding to a scene that has a grid is a SceneStateError."""
    s = mprt.Scene()
    s.add_sphere((0, 0, 0), 1)
    g = s.grid(2)
    with pytest.raises(mprt.SceneStateError):
        s.add_sphere((1, 0, 0), 1)
    del g


def hand_built_scene():
    s = mprt.Scene()
    for _ in range(50):
        s.set_view((2.1, 1.3, 1.7), (0, 0, 0), (0, 0, 1), 45, 0.01, (64, 48))
        s.add_cone((0, 0, 0), 1, (0, 0, 5), 0.5)
    s.set_material((1, 0.5, 0.25), 0.7, 0.3, 10, 0, 1)
    s.add_light((4, 3, 2), (0.5, 0.6, 0.7))
    s.add_sphere((1, 2, 3), 0.5)
    s.add_polygon([(0, 0, 0), (1, 0, 0), (1, 1, 0)], normals=[(0, 0, 1)] * 3)
    return s


def test_scene_built_by_hand_keeps_every_argument():
    """Vectors passed to the scene API arrive intact (no temporary is freed early)."""
    info = hand_built_scene().info()
    assert info["from"] == [2.1, 1.3, 1.7] and info["at"] == [0, 0, 0] and info["resolution"] == (64, 48)
    assert info["count"] == {"sphere": 1, "polygon": 1, "cylinder": 0, "cone": 50} and info["patches"] == 1


def test_primitives_return_the_shapes_as_added():
    """Scene.primitives() gives back each shape's numbers and primitive id exactly as they were added."""
    p = hand_built_scene().primitives()
    assert list(p["kind"][:50]) == [mprt.Kind.CONE] * 50 and list(p["kind"][50:]) == [mprt.Kind.SPHERE,
                                                                                   mprt.Kind.POLYGON]
    assert list(p["cones"]["id"]) == list(range(50))
    assert np.all(p["cones"]["base"] == 0) and np.all(p["cones"]["apex"] == [0, 0, 5])
    assert np.all(p["cones"]["base_radius"] == 1) and np.all(p["cones"]["apex_radius"] == 0.5)
    assert list(p["spheres"]["id"]) == [50] and p["spheres"]["center"].tolist() == [[1, 2, 3]]
    assert p["spheres"]["radius"].tolist() == [0.5]
    assert list(p["polygons"]["id"]) == [51] and list(p["polygons"]["vstart"]) == [0, 3]
    assert p["polygons"]["vertices"].tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0]]


def test_materials_and_lights_return_what_was_set():
    """Scene.materials() and Scene.lights() give back the material and the light as set; the sphere uses it."""
    s = hand_built_scene()
    m, lights = s.materials(), s.lights()
    k = s.primitives()["material"][50]
    assert m["rgb"][k].tolist() == [1, 0.5, 0.25]
    assert (m["kd"][k], m["ks"][k], m["shine"][k], m["t"][k], m["ior"][k]) == (0.7, 0.3, 10, 0, 1)
    assert lights["position"].tolist() == [[4, 3, 2]] and lights["rgb"].tolist() == [[0.5, 0.6, 0.7]]


def test_nff_text_of_a_hand_built_scene_lists_its_entities():
    """The NFF writer prints the cone, sphere and light with the numbers given."""
    text = hand_built_scene().to_nff()
    assert "c 0 0 0 1 0 0 5 0.5" in text and "s 1 2 3 0.5" in text and "l 4 3 2 0.5 0.6 0.7" in text
