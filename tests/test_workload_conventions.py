"""Workload conventions (mprt.grid.LISTINGS, mprt.grid.CONVENTIONS) and the paper1992 preset, each
on a scene small enough to count by hand."""
import numpy as np
import pytest

import mprt
from mprt.grid import CONVENTIONS, LISTINGS


def one_sphere(light, ks=0.0, t=0.0, light_rgb=None):
    """A unit sphere at the origin (Kd 0.8) seen from +z through a 1-degree view, one light."""
    s = mprt.Scene()
    s.set_view((0, 0, 5), (0, 0, 0), (0, 1, 0), 1.0, 0.0, (4, 4))
    s.set_material((1, 1, 1), 0.8, ks, 10, t, 1.5)
    s.add_sphere((0, 0, 0), 1.0)
    s.add_light(light, light_rgb)
    return s


def render(scene, n=3, listing="exact", **kw):
    return scene.grid(n, listing=listing).render(4, 4, **kw)


def test_explicit_default_conventions_are_the_paper_rules():
    """Every convention set to its first choice renders balls exactly as the paper rules do."""
    g = mprt.Scene.spd("balls", 1).grid(6)
    img, c = g.render(24, 24)
    img2, c2 = g.render(24, 24, conventions={k: v[0] for k, v in CONVENTIONS.items()})
    assert np.array_equal(img, img2) and c == c2


def test_paper1992_is_paper_with_its_documented_conventions():
    """The preset resolves to lights behind skipped and both candidates on specular surfaces, the
    rest as paper rules; and renders as paper rules with those two conventions."""
    g = mprt.Scene.spd("balls", 1).grid(6)
    d = g.resolve(mprt.grid.render_desc(rules="paper1992"))
    chosen = {k: CONVENTIONS[k][d[k] - 1] for k in CONVENTIONS}
    assert chosen == {"offset": "scaled", "accept": "in_voxel", "behind": "skip", "candidates": "specular",
                      "shadow_term": "light"}
    img, c = g.render(24, 24, rules="paper1992")
    img2, c2 = g.render(24, 24, conventions={"behind": "skip", "candidates": "specular"})
    assert np.array_equal(img, img2) and c == c2


@pytest.mark.parametrize("behind, shadow, suppressed, blocked", [
    ("cutoff", 0, 16, 0),   # a candidate carrying 0: suppressed
    ("skip", 0, 0, 0),      # no candidate at all
    ("cast", 16, 0, 16),    # a shadow ray, which the sphere itself blocks
])
def test_a_light_behind_the_surface(behind, shadow, suppressed, blocked):
    """The light is behind the sphere (z = -10) for all 16 eye hits on its front."""
    _, c = render(one_sphere((0, 0, -10)), conventions={"behind": behind})
    assert c["eye_hits"] == 16
    assert (c["shadow_rays"], c["suppressed_rays"], c["hits"] - c["eye_hits"]) == (shadow, suppressed, blocked)


@pytest.mark.parametrize("ks, candidates, extra", [
    (0.0, "material", 0), (0.0, "specular", 0), (0.0, "all", 2),   # matte: specular adds nothing
    (0.5, "material", 0), (0.5, "specular", 1), (0.5, "all", 1),   # reflective: + a refraction of weight 0
])
def test_secondary_candidates(ks, candidates, extra):
    """Each eye hit of a sphere lit from the front counts `extra` more suppressed candidates of
    weight 0 than under the material's own rule; the rays made do not change."""
    scene = one_sphere((0, 0, 10), ks=ks)
    _, base = render(scene)
    _, c = render(scene, conventions={"candidates": candidates})
    assert c["suppressed_rays"] - base["suppressed_rays"] == 16 * extra
    assert c["reflect_rays"] == base["reflect_rays"] and c["shadow_rays"] == base["shadow_rays"] == 16


def test_the_shadow_term_with_or_without_the_light():
    """A dim light (intensity 0.001): N.L Kd contribution is about 0.8, over the threshold 1/512,
    but times the light's intensity it is under it."""
    scene = one_sphere((0, 0, 10), light_rgb=(0.001, 0.001, 0.001))
    _, light = render(scene)
    _, surface = render(scene, conventions={"shadow_term": "surface"})
    assert (light["shadow_rays"], light["suppressed_rays"]) == (0, 16)
    assert (surface["shadow_rays"], surface["suppressed_rays"]) == (16, 0)


def slanted_scene():
    """A red sphere of radius 0.3 at x = -2 in front of a long slanted blue quad (z = x / 4) that
    spans the grid; the eye on the x axis looks along +x."""
    s = mprt.Scene()
    s.set_view((-5, 0, 0), (0, 0, 0), (0, 0, 1), 2.0, 0.0, (1, 1))
    s.set_material((1, 0, 0), 1, 0, 0, 0, 1)
    s.add_sphere((-2, 0, 0), 0.3)
    s.set_material((0, 0, 1), 1, 0, 0, 0, 1)
    s.add_polygon([(-4, -1, -1), (4, -1, 1), (4, 1, 1)])
    s.add_polygon([(-4, -1, -1), (4, 1, 1), (-4, 1, -1)])
    return s


def test_ic_accepting_a_hit_beyond_its_voxel_can_miss_a_nearer_one():
    """The eye ray meets the sphere first, at x = -2.3, and the slanted quad at x = 0.  On a grid of
    8 voxels along x, IC in the first voxel (x from -4 to -3, where the quad is listed) already
    finds the quad's hit beyond it: accepting that (listed) shows the quad's blue, accepting only
    within the voxel (in_voxel) the sphere's red; so the listed convention depends on the grid."""
    scene = slanted_scene()
    g = scene.grid((8, 1, 1))
    red, _ = g.render(1, 1, ambient=1.0)
    blue, _ = g.render(1, 1, ambient=1.0, conventions={"accept": "listed"})
    assert red[0, 0, 0] > 0 and red[0, 0, 2] == 0
    assert blue[0, 0, 2] > 0 and blue[0, 0, 0] == 0
    one, _ = scene.grid(1).render(1, 1, ambient=1.0, conventions={"accept": "listed"})
    assert np.array_equal(one, red)    # in one voxel, the nearest hit of the list is the sphere


def test_listing_by_box_lists_more_and_renders_the_same():
    """Box listing lists every primitive in at least the voxels exact listing does (outward: in
    more), tests more, and (IC accepting in its voxel only) renders the same image and rays."""
    scene = mprt.Scene.spd("tetra", 2)
    out = {}
    for listing in LISTINGS:
        g = scene.grid(12, listing=listing)
        img, c = g.render(32, 32)
        out[listing] = (g.stats()["refs"], sum(c["tests"].values()), img, c)
    assert out["exact"][0] < out["box"][0] < out["box_outward"][0]
    assert out["exact"][1] < out["box"][1] < out["box_outward"][1]
    for listing in ("box", "box_outward"):
        assert np.array_equal(out[listing][2], out["exact"][2])
        assert out[listing][3]["shadow_rays"] == out["exact"][3]["shadow_rays"]


def test_unknown_conventions_are_refused_by_name():
    """A misspelt convention, choice or listing names the allowed ones."""
    g = mprt.Scene.spd("balls", 1).grid(4)
    with pytest.raises(mprt.InvalidArgument, match="offset, accept"):
        g.render(8, 8, conventions={"ofset": "none"})
    with pytest.raises(mprt.InvalidArgument, match="cutoff, skip, cast"):
        g.render(8, 8, conventions={"behind": "ignore"})
    with pytest.raises(mprt.InvalidArgument, match="'exact' or 'box'"):
        mprt.Scene.spd("balls", 1).grid(4, listing="boxes")


def test_a_paper1992_trace_agrees_with_its_render_and_names_its_conventions():
    """A trace under paper1992 has the render's image and counts, keeps its invariants, and its
    meta records the rules, the listing and every convention by name."""
    g = mprt.Scene.spd("balls", 1).grid(5)
    ref, c = g.render(16, 16, rules="paper1992")
    img, tr = g.trace(16, 16, rules="paper1992")
    assert np.array_equal(img, ref)
    st = tr.check()
    assert st["suppressed"] == c["suppressed_rays"] and st["sc_made_shadow"] == c["shadow_rays"]
    assert tr.meta["rules"] == "paper1992" and tr.meta["listing"] == "exact"
    assert tr.meta["conventions"]["behind"] == "skip" and tr.meta["conventions"]["candidates"] == "specular"


def test_the_cost_model_calibrates_on_paper1992_traces_not_spd():
    """The reproduction study calibrates on paper1992 traces (the paper's own workload, reproduced);
    spd traces are another workload and are refused, naming the rules."""
    from mprt.cost.calibrate import counts_row
    from mprt.errors import MprtError
    grid = mprt.Scene.spd("balls", 4).grid(20)
    _, t1992 = grid.trace(8, 8, rules="paper1992")
    _, tpaper = grid.trace(8, 8, rules="paper")
    a, b = counts_row(t1992), counts_row(tpaper)
    assert a["scene"] == "balls" and a.keys() == b.keys()
    _, tspd = grid.trace(8, 8, rules="spd")
    with pytest.raises(MprtError, match="uses rules 'spd'"):
        counts_row(tspd)
