"""Per-ray cost traces: agreement with the renderer, invariants, determinism."""
import dataclasses
import functools

import numpy as np
import pytest

import mprt
from mprt import Outcome, RayKind, Stage
from mprt.stats import trace_stats

SCENE_SIZES = {"balls": 1, "gears": 1, "mount": 2, "rings": 1, "tetra": 2, "tree": 4}


def traced(name, n=8, w=24, h=24, **kw):
    grid = mprt.Scene.spd(name, SCENE_SIZES[name]).grid(n)
    return grid, grid.trace(w, h, **kw)


@pytest.mark.parametrize("rules", ["paper", "spd"])
@pytest.mark.parametrize("name", mprt.SPD_SCENES)
def test_trace_agrees_with_render_and_keeps_its_invariants(name, rules):
    """A trace's image and counts equal the untraced render's, and its invariants hold."""
    grid, (img, tr) = traced(name, rules=rules)
    ref, c = grid.render(24, 24, rules=rules)
    assert np.array_equal(img, ref)
    st = tr.check()
    assert st["os_input_primary"] == c["eye_rays"]
    assert st["sc_made_shadow"] == c["shadow_rays"]
    assert st["sc_made_reflect"] == c["reflect_rays"] and st["sc_made_refract"] == c["refract_rays"]
    assert st["suppressed"] == c["suppressed_rays"]
    assert st["voxels_traversed"] == c["voxels_traversed"]
    assert st["tests_by_kind"] == c["tests"]
    assert st["ic_input"] == c["ic_visits"] and st["sc_input"] == c["sc_visits"]
    assert st["ic_to_sc"] + st["os_to_sc_late_hits"] + st["ic_kills"] == c["hits"]


def test_primary_rays_start_as_the_camera_rays_say():
    """The trace's primary rays are one per sample, in sample order within each tile, as many as camera_rays."""
    grid, (_, tr) = traced("balls", w=16, h=16, tile=8)
    primary = tr.rays[tr.rays["kind"] == RayKind.PRIMARY]
    assert len(primary) == len(grid.camera_rays(16, 16)[0])
    assert sorted(primary["pixel"]) == list(range(256))


def test_traces_are_the_same_bits_with_any_thread_count():
    """1 and 3 threads give identical ray and visit arrays."""
    grid = mprt.Scene.spd("mount", 2).grid(10)
    _, a = grid.trace(40, 40, threads=1, tile=8)
    _, b = grid.trace(40, 40, threads=3, tile=8)
    assert np.array_equal(a.rays, b.rays) and np.array_equal(a.visits, b.visits)


@functools.cache
def balls_trace():
    return traced("balls", w=12, h=12)[1][1]


def test_stats_in_chunks_equal_stats_in_one_pass():
    """Statistics computed 7 visits at a time (chunk edges split rays' visit runs) equal those in one pass."""
    tr = balls_trace()
    assert trace_stats(tr, chunk=7) == tr.stats()


def test_check_rejects_a_trace_missing_an_sc_visit():
    """Deleting a shaded SC visit breaks the invariants."""
    tr = balls_trace()
    v = tr.visits
    sc = np.flatnonzero((v["stage"] == Stage.SC) & (v["outcome"] == Outcome.SHADED))[0]
    with pytest.raises(mprt.TraceError):
        dataclasses.replace(tr, visits=np.delete(v, sc)).check()


def test_check_rejects_an_ic_visit_before_its_os_visit():
    """Swapping the first IC visit with the OS visit before it breaks the invariants."""
    tr = balls_trace()
    swapped = tr.visits.copy()
    i = np.flatnonzero(swapped["stage"] == Stage.IC)[0]
    swapped[[i - 1, i]] = swapped[[i, i - 1]]
    with pytest.raises(mprt.TraceError, match="does not start at OS|followed by"):
        dataclasses.replace(tr, visits=swapped).check()


def test_check_rejects_a_wrong_child_count():
    """An SC visit claiming one child more than the trace holds breaks the 'made' invariant."""
    tr = balls_trace()
    made = tr.visits.copy()
    sc = np.flatnonzero((made["stage"] == Stage.SC) & (made["outcome"] == Outcome.SHADED))[0]
    made["made"][sc] += 1
    with pytest.raises(mprt.TraceError, match="made"):
        dataclasses.replace(tr, visits=made).check()


@functools.cache
def rings_subset(sample):
    """rings at 32x32 in 8x8 tiles: the full trace, and a subset."""
    grid = mprt.Scene.spd("rings", 1).grid(8)
    return grid.trace(32, 32, tile=8)[1], grid.trace(32, 32, tile=8, sample=sample)[1]


def test_regular_subset_holds_the_same_records_as_the_full_trace():
    """'regular:3' traces the tile nearest the centre of each block of about 3 tiles (2x2 blocks
    of the 4x4 tiling: tiles 1, 3, 9, 11; the grammar of every --sample, issue 20) with the
    records those tiles have in the full trace."""
    full, part = rings_subset("regular:3")
    assert part.meta["tiles"] == [1, 3, 9, 11] and part.meta["subset"] == "regular:3"
    tile_of = (full.rays["pixel"] // 32 // 8) * 4 + (full.rays["pixel"] % 32) // 8
    keep = np.isin(tile_of, part.meta["tiles"])
    assert np.array_equal(full.rays["pixel"][keep], part.rays["pixel"])
    fv = full.visits[np.isin(full.visits["ray"], np.flatnonzero(keep))]
    for f in ("stage", "outcome", "steps", "tests", "prim", "made", "suppressed"):
        assert np.array_equal(fv[f], part.visits[f]), f
    part.check()


def test_random_subset_traces_the_asked_number_of_tiles():
    """'random:5:42' traces 5 distinct tiles."""
    _, part = rings_subset("random:5:42")
    assert len(set(part.meta["tiles"])) == 5


def test_unknown_sample_form_is_an_invalid_argument():
    """'every:2' is not a sample form: InvalidArgument naming the accepted ones."""
    grid = mprt.Scene.spd("rings", 1).grid(8)
    with pytest.raises(mprt.InvalidArgument, match="regular:K"):
        grid.trace(32, 32, tile=8, sample="every:2")


@functools.cache
def tree_trace():
    return traced("tree", w=16, h=16)[1][1]


def test_shadow_rays_are_never_shaded_as_hits():
    """No IC visit of a shadow ray accepts a hit for shading."""
    tr = tree_trace()
    v = tr.visits
    shadow = tr.rays["kind"][v["ray"]] == RayKind.SHADOW
    assert np.all(v["outcome"][shadow & (v["stage"] == Stage.IC)] != Outcome.HIT)


def test_some_shadow_rays_are_blocked_at_ic():
    """In tree some shadow rays are blocked by an IC visit."""
    tr = tree_trace()
    v = tr.visits
    shadow = tr.rays["kind"][v["ray"]] == RayKind.SHADOW
    assert np.sum(shadow & (v["stage"] == Stage.IC) & (v["outcome"] == Outcome.BLOCKED)) > 0


def test_unblocked_shadow_rays_reach_sc_lit():
    """Every SC visit of a shadow ray is 'lit'."""
    tr = tree_trace()
    v = tr.visits
    shadow = tr.rays["kind"][v["ray"]] == RayKind.SHADOW
    assert np.sum(shadow & (v["stage"] == Stage.SC)) > 0
    assert np.all(v["outcome"][shadow & (v["stage"] == Stage.SC)] == Outcome.LIT)


def test_enums_are_the_headers():
    """The Python enums carry the C header's values (spot checks against mprt.h's definitions)."""
    assert [s.name for s in Stage] == ["OS", "IC", "SC"]
    assert Outcome.LATE_HIT == 8 and Outcome.TO_IC == 0 and RayKind.SHADOW == 3
    assert mprt.KINDS == ("sphere", "polygon", "cylinder", "cone")
