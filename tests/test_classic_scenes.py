"""Classic scenes render (issue 36, item 4).

A classic glass NFF file (a material with Ks + T over 1, tests/data/nff/classic_glass.nff: a glass
sphere in front of a mirror, beside a glass shell) renders under the default rules with one
warning saying what was done: read as written, its ray trees stopped at depth 5
(``Scene.default_max_depth``, SPD's depth) unless --max-depth is given.  --max-depth exists wherever
--max-rays does (render, trace, simulate), is recorded in the settings, and the budget error names
the options that change it.  --skip-unknown says what each skipped material line was replaced by.
"""
import json
import pathlib

import numpy as np
import pytest

import mprt
from mprt import options
from mprt.scene import OVER_ONE_MAX_DEPTH
from cli_run import cli_main

GLASS = pathlib.Path(__file__).resolve().parent / "data" / "nff" / "classic_glass.nff"


mprt_main = cli_main


def warnings_of(err: str) -> list:
    return [ln for ln in err.splitlines() if ln.startswith("mprt: warning: ")]


# -- the scene's depth limit (Python) -----------------------------------------------------------
def test_the_glass_scene_takes_depth_5_and_depth_64_outgrows_the_budget():
    """Default: the rules' depth becomes 5 for this scene (resolve, render), the same bits as
    asking for 5; asked for 64 (the paper rules' own), a sample's tree outgrows the budget and
    the error names the options that change it."""
    scene = mprt.Scene.from_nff(GLASS)
    assert scene.over_one() == 1 and scene.default_max_depth() == OVER_ONE_MAX_DEPTH == 5
    grid = scene.grid()
    for rules in ("paper", "paper1992", "spd"):
        assert grid.resolve(mprt.grid.render_desc(rules=rules))["max_depth"] == 5
    img, c = grid.render(threads=2)
    img5, c5 = grid.render(threads=1, max_depth=5)
    assert img.tobytes() == img5.tobytes() and c == c5
    assert c["reflect_rays"] > 1000 and c["refract_rays"] > 1000
    with pytest.raises(mprt.WorkLimitError) as e:
        grid.render(threads=2, max_depth=64)
    assert "needs more than 65536 rays" in str(e.value)
    assert str(e.value).endswith("(mprt's options: --threshold, --max-rays, --max-depth)")
    with pytest.raises(mprt.WorkLimitError, match=r"\(mprt's options: --max-rays, --max-depth\)$"):
        grid.render(rules="spd", max_depth=64)      # (no cutoff under spd: no --threshold to offer)
    _, c12 = grid.render(threads=2, max_depth=12)   # deeper than the default, within the budget
    assert c12["reflect_rays"] > c["reflect_rays"]


def test_the_trace_takes_the_same_depth():
    """A trace of the scene records depth 5 in its metadata and no ray deeper; the same rays as
    the render counts."""
    grid = mprt.Scene.from_nff(GLASS).grid()
    _, tr = grid.trace(16, 16, threads=2)
    assert tr.meta["max_depth"] == 5 and int(np.asarray(tr.rays["depth"]).max()) == 5
    _, c = grid.render(16, 16)
    assert len(tr.rays) == c["eye_rays"] + c["reflect_rays"] + c["refract_rays"] + c["shadow_rays"]


def test_scenes_without_such_a_surface_keep_the_rules_depth():
    """SPD scenes (Ks + T at most 1) keep the rules' depth; so does a file whose glass material no
    primitive takes (the note says so)."""
    for name in ("balls:1", "gears:1", "mount:1"):
        scene = mprt.Scene.load(name)
        grid = scene.grid(4)
        assert scene.over_one() == 0 and grid.resolve(mprt.grid.render_desc())["max_depth"] == 64
        assert grid.resolve(mprt.grid.render_desc(rules="spd"))["max_depth"] == 5
    unused = mprt.Scene.from_text("l 0 0 9\nf 1 1 1 1 0 0 0 1\ns 0 0 0 1\nf 1 1 1 0 .9 9 .9 1.5\n", "u.nff")
    assert len(unused.notes) == 1 and unused.over_one() == 0 and unused.default_max_depth() == 0
    assert options.command_line_note(unused, unused.notes[0]).endswith(
        "no surface takes such a material, so the rules' depth limit stands")


# -- the command line ----------------------------------------------------------------------------
def test_render_of_the_glass_file_has_one_warning_saying_what_was_done(capsys, tmp_path):
    """mprt render under the default rules: exit 0, one warning naming the file, the line, that the
    material is read as written and that the trees stop at depth 5 unless --max-depth; the JSON
    records depth 5 and the one such surface material."""
    out_json = tmp_path / "g.json"
    code, out, err = mprt_main(capsys, "render", GLASS, "--res", "24x24", "--json", out_json)
    assert code == 0, err
    warnings = warnings_of(err)
    assert len(warnings) == 1 and len(err.strip().splitlines()) == 1
    assert warnings[0].startswith(f"mprt: warning: {GLASS}:30: material: Ks 0.9 + T 0.9 = 1.8 is over 1 "
                                  "(1 such material in the file): read as written")
    assert "(--max-rays)" in warnings[0]
    assert warnings[0].endswith("they stop at depth 5 (SPD's; classic NFF renderers limit depth) unless "
                                "--max-depth is given")
    data = json.loads(out_json.read_text())
    assert data["settings"]["max_depth"] == 5 and data["scene_stats"]["ks_t_over_1"] == 1
    assert data["refract_rays"] > 0


def test_max_depth_on_the_command_line(capsys, tmp_path):
    """--max-depth N reaches the render (recorded), 64 stops it with the options to change in the
    message (exit 1), out of range is refused with the range (exit 2)."""
    out_json = tmp_path / "g.json"
    code, _, err = mprt_main(capsys, "render", GLASS, "--res", "16x16", "--max-depth", "9", "--json", out_json)
    assert code == 0, err
    assert json.loads(out_json.read_text())["settings"]["max_depth"] == 9
    code, _, err = mprt_main(capsys, "render", GLASS, "--res", "24x24", "--max-depth", "64")
    assert code == 1
    assert "needs more than 65536 rays" in err and err.rstrip().endswith(
        "(mprt's options: --threshold, --max-rays, --max-depth)")
    for bad in ("0", "256", "x"):
        code, _, err = mprt_main(capsys, "render", GLASS, "--max-depth", bad)
        assert code == 2 and "1..255" in err, (bad, err)


def test_trace_takes_max_depth(capsys, tmp_path):
    out = tmp_path / "t.npz"
    code, _, err = mprt_main(capsys, "trace", GLASS, "--res", "8x8", "--max-depth", "3", "--max-rays", "5000",
                             "-o", out)
    assert code == 0, err
    tr = mprt.load_trace(out)
    assert tr.meta["max_depth"] == 3 and tr.meta["max_rays"] == 5000
    assert int(np.asarray(tr.rays["depth"]).max()) == 3


def test_simulate_traces_a_scene_with_the_limits(capsys, tmp_path):
    """simulate SCENE takes --max-depth and --max-rays for its trace (recorded in the settings);
    given with a trace file, they are refused (the file was traced with its own)."""
    out = tmp_path / "s.json"
    code, _, err = mprt_main(capsys, "simulate", GLASS, "--res", "8x8", "--max-depth", "4", "--max-rays", "900",
                             "--threads", "1", "--json", out)
    assert code == 0, err
    settings = json.loads(out.read_text())["settings"]
    assert settings["max_depth"] == 4 and settings["max_rays"] == 900
    trace_file = tmp_path / "t.npz"
    assert mprt_main(capsys, "trace", "tetra:1", "--res", "8x8", "-o", trace_file)[0] == 0
    code, _, err = mprt_main(capsys, "simulate", trace_file, "--max-depth", "4")
    assert code == 2 and "--max-depth set how a scene is traced" in err


@pytest.mark.parametrize("command", ["render", "trace", "simulate"])
def test_max_depth_beside_max_rays_in_help(command, capsys):
    """Wherever --max-rays is, --max-depth is, with its range and the defaults in --help."""
    code, out, _ = mprt_main(capsys, command, "--help")
    text = " ".join(out.split())
    assert code == 0 and "--max-rays N" in text and "--max-depth N" in text
    assert "1..255 (default: the rules' paper 64, spd 5, paper1992 64; 5 for a scene with a surface whose " \
           "Ks + T is over 1" in text


def test_the_shared_group_is_one_call():
    """add_trace_limits adds both options to any parser or group with one call; trace_limits gives
    the keywords of Grid.render / Grid.trace / SceneEvaluator (0 and None when not given)."""
    import argparse

    p = argparse.ArgumentParser()
    options.add_trace_limits(p.add_argument_group("tracing"))
    assert options.trace_limits(p.parse_args([])) == {"max_rays": None, "max_depth": 0}
    assert options.trace_limits(p.parse_args(["--max-depth", "7", "--max-rays", "10"])) == \
        {"max_rays": 10, "max_depth": 7}
    assert options.trace_limits(argparse.Namespace()) == {"max_rays": None, "max_depth": 0}


def test_the_help_defaults_are_the_library_s():
    """The rules' depths in --help are read from the library (resolve), not written again."""
    grid = mprt.Scene.load("tetra:1").grid(2)
    for rules, depth in options.default_depths().items():
        assert grid.resolve(mprt.grid.render_desc(rules=rules))["max_depth"] == depth


# -- --skip-unknown ------------------------------------------------------------------------------
SKIPPING = """l 0 -5 5
fp 0.5 0.5 0.5 0.8 0.2 10 0 1
s -2 0 0 1
f 1 0 0 1 0 0 0 1
s 0 0 0 1
fp 0 1 0 0.8 0.2 10 0 1
s 2 0 0 1
Q 1
fp 0 0 1 0.8 0.2 10 0 1
s 4 0 0 1
"""


def test_skip_unknown_says_what_each_skipped_material_line_was_replaced_by(capsys, tmp_path):
    """One warning per entity: the 'fp' material lines with their count and lines and the
    material their surfaces take instead (before any 'f': the default; after: the 'f' of that
    line), which is what the scene holds; 'Q' with its line."""
    f = tmp_path / "skip.nff"
    f.write_text(SKIPPING)
    code, out, err = mprt_main(capsys, "render", f, "--skip-unknown", "--res", "8x8")
    assert code == 0, err
    warnings = warnings_of(err)
    assert warnings == [
        f"mprt: warning: {f}: 3 'fp' material lines skipped (lines 2, 6, 9), with the number lines after each: "
        "the surfaces after them take the last 'f' material before them: the default white diffuse material "
        "(no 'f' before) for line 2; the 'f' of line 4 for lines 6, 9",
        f"mprt: warning: {f}: 1 'Q' line skipped (line 8), with the number lines after it"]
    scene = mprt.Scene.from_nff(f, skip_unknown=True)
    m, prims = scene.materials(), scene.prim_table()["material"]
    assert list(prims) == [0, 1, 1, 1]
    assert list(m["rgb"][0]) == [1, 1, 1] and m["kd"][0] == 1          # the default white diffuse
    assert list(m["rgb"][1]) == [1, 0, 0]                               # the 'f' of line 4
