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
        ("v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0\nresolution 8 8\ns 0 0 0 nan\n", 8, ""),
        ("s 0 0 0 0\n", 1, "radius"),
        ("s 0 0 0 -1\n", 1, "radius"),
        ("p 3\n0 0 0\n1 0 0\n", 3, "end of file"),
        ("q 1 2 3\n", 1, "q"),
        ("c 0 0 0 1 0 0 0 1\n", 1, ""),
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


def test_missing_file_and_unknown_scene_are_clear_errors(tmp_path):
    """A missing NFF file is an OSError naming it; an unknown SPD name lists the choices."""
    with pytest.raises(OSError, match="nope.nff"):
        mprt.Scene.from_nff(tmp_path / "nope.nff")
    with pytest.raises(mprt.InvalidArgument, match="balls"):
        mprt.Scene.spd("teapot")
    with pytest.raises(mprt.InvalidArgument):
        mprt.Scene.load("teapot:3")


def test_scene_api_rejects_bad_primitives():
    """NaN, non-positive radius and coincident cone ends are rejected by the scene API."""
    s = mprt.Scene()
    with pytest.raises(mprt.InvalidArgument, match="radius"):
        s.add_sphere((0, 0, 0), 0)
    with pytest.raises(mprt.InvalidArgument, match="NaN"):
        s.add_sphere((0, float("nan"), 0), 1)
    with pytest.raises(mprt.InvalidArgument):
        s.add_cone((0, 0, 0), 1, (0, 0, 0), 0.5)
    with pytest.raises(mprt.InvalidArgument):
        s.add_polygon([(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    assert s.info()["prims"] == 0


def test_scene_cannot_change_while_it_has_a_grid():
    """Adding to a scene that has a grid is a SceneStateError."""
    s = mprt.Scene()
    s.add_sphere((0, 0, 0), 1)
    g = s.grid(2)
    with pytest.raises(mprt.SceneStateError):
        s.add_sphere((1, 0, 0), 1)
    del g


def test_scene_built_by_hand_keeps_every_argument():
    """Vectors passed to the scene API arrive intact (no temporary is freed early)."""
    s = mprt.Scene()
    for _ in range(50):
        s.set_view((2.1, 1.3, 1.7), (0, 0, 0), (0, 0, 1), 45, 0.01, (64, 48))
        s.add_cone((0, 0, 0), 1, (0, 0, 5), 0.5)
    s.set_material((1, 0.5, 0.25), 0.7, 0.3, 10, 0, 1)
    s.add_light((4, 3, 2), (0.5, 0.6, 0.7))
    s.add_sphere((1, 2, 3), 0.5)
    s.add_polygon([(0, 0, 0), (1, 0, 0), (1, 1, 0)], normals=[(0, 0, 1)] * 3)
    info = s.info()
    assert info["from"] == [2.1, 1.3, 1.7] and info["at"] == [0, 0, 0] and info["resolution"] == (64, 48)
    assert info["count"] == {"sphere": 1, "polygon": 1, "cylinder": 0, "cone": 50} and info["patches"] == 1
    text = s.to_nff()
    assert "c 0 0 0 1 0 0 5 0.5" in text and "s 1 2 3 0.5" in text and "l 4 3 2 0.5 0.6 0.7" in text
