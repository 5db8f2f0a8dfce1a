"""Rendering: grid independence, thread determinism, rule sets, counters."""
import functools

import numpy as np
import pytest

import mprt

GRID_INDEPENDENT = ("eye_rays", "eye_hits", "reflect_rays", "refract_rays", "shadow_rays", "suppressed_rays", "hits",
                    "sc_visits")


@functools.cache
def reference_render(name, rules):
    """A 40x40 render with a 3^3 grid, and its scene."""
    scene = mprt.Scene.spd(name, 1 if name != "tree" else 4)
    return scene, scene.grid(3).render(40, 40, rules=rules)


@pytest.mark.parametrize("n", (8, (5, 13, 2), 24), ids=str)
@pytest.mark.parametrize("rules", ["paper", "spd"])
@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_image_and_ray_counts_do_not_depend_on_the_grid(name, rules, n):
    """Image bits and every count not describing the grid are identical to those of a 3^3 grid."""
    scene, (ref_img, ref_c) = reference_render(name, rules)
    img, c = scene.grid(n).render(40, 40, rules=rules)
    assert np.array_equal(img, ref_img), "image differs"
    for k in GRID_INDEPENDENT:
        assert c[k] == ref_c[k], f"{k} {c[k]} != {ref_c[k]}"


@functools.cache
def mount_grid():
    return mprt.Scene.spd("mount", 2).grid(20)


@pytest.mark.parametrize("threads", [2, 5])
@pytest.mark.parametrize("rules", ["paper", "spd"])
def test_threads_give_the_same_bits(rules, threads):
    """2 and 5 threads give the image and counters of 1 thread, bit for bit."""
    g = mount_grid()
    ref_img, ref_c = g.render(72, 56, rules=rules, threads=1, tile=8)
    img, c = g.render(72, 56, rules=rules, threads=threads, tile=8)
    assert np.array_equal(img, ref_img)
    assert c == ref_c


@pytest.mark.parametrize("rules, eye_rays", [("spd", 33 * 33), ("paper", 32 * 32)])
def test_spd_rules_trace_pixel_corners_and_paper_rules_pixel_centres(rules, eye_rays):
    """A 32x32 render makes 33x33 eye rays under spd rules (pixel corners), 32x32 under paper rules."""
    _, c = mprt.Scene.spd("balls", 1).grid(10).render(32, 32, rules=rules)
    assert c["eye_rays"] == eye_rays


def test_spd_rules_cut_ray_trees_at_depth_5():
    """SPD rules stop at depth 5: allowing depth 50 makes more reflection rays in balls (Ks 0.5)."""
    g = mprt.Scene.spd("balls", 1).grid(10)
    _, spd = g.render(32, 32, rules="spd")
    _, deep = g.render(32, 32, rules="spd", max_depth=50)
    assert deep["reflect_rays"] > spd["reflect_rays"]


def test_contribution_threshold_suppresses_rays():
    """A higher contribution threshold traces fewer rays and suppresses more."""
    g = mprt.Scene.spd("balls", 1).grid(10)
    _, low = g.render(48, 48, threshold=0.0)
    _, high = g.render(48, 48, threshold=0.2)
    assert high["reflect_rays"] < low["reflect_rays"]
    assert high["suppressed_rays"] > low["suppressed_rays"]
    assert high["eye_hits"] == low["eye_hits"]


def test_counts_are_consistent():
    """Hits, shadow and secondary rays relate as the 3MPRT flow says."""
    g = mprt.Scene.spd("rings", 1).grid(12)
    _, c = g.render(48, 48)
    assert c["eye_hits"] <= c["eye_rays"]
    assert c["tests"]["cylinder"] > 0 and c["tests"]["cone"] == 0
    # every traced ray visits OS at least once; each IC visit follows an OS visit
    traced = c["eye_rays"] + c["reflect_rays"] + c["refract_rays"] + c["shadow_rays"]
    assert c["os_visits"] >= traced
    assert c["ic_visits"] <= c["os_visits"]
    # SC sees every non-shadow hit and every unblocked shadow ray
    assert c["sc_visits"] <= c["hits"] + c["shadow_rays"]


def test_tetra_has_no_secondary_rays():
    """Tetra is matte: no reflection or refraction rays, but shadow rays."""
    _, t = mprt.Scene.spd("tetra", 2).grid(10).render(40, 40)
    assert t["reflect_rays"] == 0 and t["refract_rays"] == 0 and t["shadow_rays"] > 0


def test_mount_refracts():
    """Mount's glass spheres make refraction rays."""
    _, m = mprt.Scene.spd("mount", 3).grid(10).render(96, 96)
    assert m["refract_rays"] > 0


def test_background_where_nothing_is_hit():
    """A ray that hits nothing shows the background colour."""
    s = mprt.Scene.from_text(
        "v\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 30\nhither 1\nresolution 9 9\n"
        "b 0.25 0.5 0.75\nl 0 0 10\nf 1 0 0 1 0 1 0 1\ns 100 0 0 1\n", "bg.nff")
    img, c = s.grid(2).render()
    assert c["eye_hits"] == 0
    np.testing.assert_allclose(img[4, 4], [0.25, 0.5, 0.75], rtol=1e-6)


@pytest.mark.parametrize("options, words", [
    ({"rules": "fast"}, "rules"),
    ({"threshold": -1}, "threshold"),
    ({"width": -3}, "resolution"),
    ({"threads": 65}, "threads"),
    ({"max_depth": 256}, "max_depth"),
])
def test_bad_render_arguments_are_errors(options, words):
    """Unknown rules, a negative threshold, a negative size, too many threads or too deep a tree
    are each an InvalidArgument naming the setting."""
    g = mprt.Scene.spd("balls", 1).grid(4)
    args = dict({"width": 8, "height": 8}, **options)
    with pytest.raises(mprt.InvalidArgument, match=words):
        g.render(**args)
