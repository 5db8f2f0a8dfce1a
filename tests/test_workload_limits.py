"""Bounded work and clear errors from Python: the inputs a fuzzer found hanging the tracer fail
fast with the line at fault, a ray tree that does not end stops at the ray budget in a render
and in a trace, and a directory or a scene of dropped primitives says so."""
import time

import pytest

import mprt
from mprt.errors import WorkLimitError

# The two hangs of issue 10: Ks 5 and T 9 (every child outweighs its parent), and Ks + T = 1.4
# with an index of refraction of 5.5 (rays bounce inside the glass above any threshold).
HANG_27_BYTES = "f 1 1 1 1 5 5 9 5\ns 0 0 0 1"
HANG_58_BYTES = "l 0 0 10\nf 1 1 1 0.1 0.5 50 0.9 5.5\ns 0 0 0 1\ns 0 0 3 1\n"

# The 58-byte scene with Ks + T = 1, seen along the axis of its two spheres: both children of
# a hit near the axis hit a sphere again, so without a cutoff the tree doubles to depth 64.
ENDLESS = ("v\nfrom 0 0 -3\nat 0 0 0\nup 0 1 0\nangle 10\nhither 0\nresolution 8 8\n"
           "l 0 0 10\nf 1 1 1 0.1 0.1 50 0.9 5.5\ns 0 0 0 1\ns 0 0 3 1\n")


def test_the_fuzz_hang_with_weights_over_1_is_refused_at_its_line():
    """The input that hung the tracer with Ks 5 and T 9 is refused while reading, naming the line
    and the weights."""
    with pytest.raises(mprt.SceneParseError) as e:
        mprt.Scene.from_text(HANG_27_BYTES, "hang.nff")
    assert "hang.nff:1: material: Kd 1, Ks 5 and T 9 must each be in [0, 1]" in str(e.value)


@pytest.mark.parametrize("rules", ["paper", "spd"])
def test_the_fuzz_hang_with_ks_plus_t_over_1_is_read_and_ends(rules):
    """The other input (Ks + T = 1.4, ior 5.5) is read since issue 20, with a note; no child
    outweighs its parent (TIR carries at most 1), so its render ends (at the cutoff, the depth
    limit or the ray budget), the same for 1 and 2 threads."""
    scene = mprt.Scene.from_text(HANG_58_BYTES, "hang.nff")
    assert len(scene.notes) == 1 and scene.notes[0].startswith("hang.nff:2: material: Ks 0.5 + T 0.9 = 1.4 is over 1")
    grid = scene.grid(4)
    results = []
    for threads in (1, 2):
        try:
            img, c = grid.render(8, 8, rules=rules, threads=threads)
            results.append((img.tobytes(), c))
        except WorkLimitError as e:
            results.append(str(e))
    assert results[0] == results[1]


@pytest.mark.parametrize("rules", ["paper", "spd"])
@pytest.mark.parametrize("mode", ["render", "trace"])
def test_a_tree_that_does_not_end_stops_at_the_budget(mode, rules):
    """Without a cutoff (paper at threshold 0, spd allowed depth 200) the scene's trees double at
    every level; an 8x8 render or trace stops at the first sample over the budget, within
    seconds, naming the sample."""
    grid = mprt.Scene.from_text(ENDLESS, "endless.nff").grid(4)
    options = {"threshold": 0.0} if rules == "paper" else {"max_depth": 200}
    start = time.perf_counter()
    with pytest.raises(WorkLimitError, match=r"sample \(\d+, \d+\) needs more than 65536 rays"):
        getattr(grid, mode)(8, 8, rules=rules, threads=2, **options)
    assert time.perf_counter() - start < 10


def test_the_same_scene_ends_with_its_cutoff():
    """At the default threshold every tree of that scene ends well inside the budget."""
    grid = mprt.Scene.from_text(ENDLESS, "endless.nff").grid(4)
    _, c = grid.render(8, 8)
    assert 0 < c["reflect_rays"] + c["refract_rays"] < 64 * 65536


def test_a_directory_is_not_a_scene(tmp_path):
    """A directory given as a scene file says it is a directory."""
    with pytest.raises(OSError, match="is a directory, not an NFF file"):
        mprt.Scene.from_nff(tmp_path)
    with pytest.raises((OSError, ValueError), match="is a directory"):
        mprt.Scene.load(str(tmp_path))


def test_a_scene_of_dropped_primitives_names_them(tmp_path):
    """A scene whose only polygon is collinear says, at the grid, which was dropped and where."""
    path = tmp_path / "flat.nff"
    path.write_text("l 0 0 5\np 3\n0 0 0\n1 0 0\n2 0 0\n")
    scene = mprt.Scene.from_nff(path)
    with pytest.raises(mprt.SceneStateError, match=r"no primitives: 1 was dropped while reading it "
                                                   r"\(.*flat.nff:2: polygon with zero area dropped\)"):
        scene.grid(4)


def test_max_rays_sets_the_budget_of_a_sample():
    """A budget below what a sample's tree needs stops the render, naming the budget; one that
    covers the tree gives the same image and counts as the default budget."""
    grid = mprt.Scene.from_text(ENDLESS, "endless.nff").grid(4)
    img, c = grid.render(8, 8)
    with pytest.raises(WorkLimitError, match=r"needs more than 3 rays"):
        grid.render(8, 8, max_rays=3)
    img2, c2 = grid.render(8, 8, max_rays=100000)
    assert (img == img2).all() and c == c2


def test_cli_max_rays_and_paper1992(capsys, tmp_path):
    """mprt render --max-rays N reaches the library (the error names it and exits 1), is checked
    for range (exit 2), and is recorded in --stats; --rules paper1992 takes --threshold."""
    from mprt import cli
    nff = tmp_path / "endless.nff"
    nff.write_text(ENDLESS)

    def run(*args):
        try:
            code = cli.main([str(x) for x in args])
        except SystemExit as e:
            code = e.code
        return code, capsys.readouterr()

    code, out = run("render", nff, "--res", "8x8", "--max-rays", "3")
    assert code == 1 and "needs more than 3 rays" in out.err
    code, out = run("render", nff, "--res", "8x8", "--max-rays", "0")
    assert code == 2 and "max-rays 0 is not in 1..16777216" in out.err
    stats = tmp_path / "s.json"
    code, out = run("render", "balls:1", "--res", "8x8", "--rules", "paper1992", "--threshold", "0.01",
                    "--max-rays", "500", "--stats", stats)
    assert code == 0
    import json
    settings = json.loads(stats.read_text())["settings"]
    assert settings["rules"] == "paper1992" and settings["threshold"] == 0.01 and settings["max_rays"] == 500
