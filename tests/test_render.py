"""Rendering: grid independence, thread determinism, rule sets, counters."""
import numpy as np
import pytest

import mprt

GRID_INDEPENDENT = ("eye_rays", "eye_hits", "reflect_rays", "refract_rays", "shadow_rays", "suppressed_rays", "hits",
                    "sc_visits")


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
@pytest.mark.parametrize("rules", ["paper", "spd"])
def test_image_and_ray_counts_do_not_depend_on_the_grid(name, rules):
    """Image bits and every count not describing the grid are identical at every subdivision."""
    scene = mprt.Scene.spd(name, 1 if name != "tree" else 4)
    ref_img, ref_c = scene.grid(3).render(40, 40, rules=rules)
    for n in (8, (5, 13, 2), 24):
        img, c = scene.grid(n).render(40, 40, rules=rules)
        assert np.array_equal(img, ref_img), f"grid {n}: image differs"
        for k in GRID_INDEPENDENT:
            assert c[k] == ref_c[k], f"grid {n}: {k} {c[k]} != {ref_c[k]}"


@pytest.mark.parametrize("rules", ["paper", "spd"])
def test_threads_give_the_same_bits(rules):
    """1, 2 and 5 threads give the same image and counters, bit for bit."""
    g = mprt.Scene.spd("mount", 2).grid(20)
    ref = g.render(72, 56, rules=rules, threads=1, tile=8)
    for th in (2, 5):
        img, c = g.render(72, 56, rules=rules, threads=th, tile=8)
        assert np.array_equal(img, ref[0])
        assert c == ref[1]


def test_spd_rules_trace_pixel_corners_and_never_cut_off():
    """SPD rules trace (W+1)(H+1) eye rays and suppress only rays past depth 5."""
    g = mprt.Scene.spd("balls", 1).grid(10)
    _, spd = g.render(32, 32, rules="spd")
    _, paper = g.render(32, 32, rules="paper")
    assert spd["eye_rays"] == 33 * 33 and paper["eye_rays"] == 32 * 32
    _, deep = g.render(32, 32, rules="spd", max_depth=50)
    # balls' spheres reflect (Ks 0.5): depth 5 cuts some trees, depth 50 more rays
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


def test_tetra_has_no_secondary_rays_and_mount_refracts():
    """Tetra is matte (no reflection/refraction); mount's glass spheres refract."""
    _, t = mprt.Scene.spd("tetra", 2).grid(10).render(40, 40)
    assert t["reflect_rays"] == 0 and t["refract_rays"] == 0 and t["shadow_rays"] > 0
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


def test_bad_render_arguments_are_errors():
    """Unknown rules, negative thresholds and bad sizes are InvalidArgument."""
    g = mprt.Scene.spd("balls", 1).grid(4)
    with pytest.raises(mprt.InvalidArgument):
        g.render(8, 8, rules="fast")
    with pytest.raises(mprt.InvalidArgument, match="threshold"):
        g.render(8, 8, threshold=-1)
    with pytest.raises(mprt.InvalidArgument):
        g.render(-3, 8)
