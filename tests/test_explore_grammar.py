"""explore and prepass speak the grammar of every command that traces (issue 20, item 4):
--rules, --threshold and --grid, with the same names, meanings and syntax, reach every trace
they make; and the prepass's candidate ladder does not collapse at tiny resolutions."""
import argparse
import json
from pathlib import Path

import pytest

from mprt import tracing
from mprt.explore.cli import add_parsers
from mprt.explore.prepass import prepass, low_resolution
from mprt.scene import Scene

SMALL = Path(__file__).parent / "data" / "explore" / "small_space.toml"


def run(*argv):
    p = argparse.ArgumentParser(prog="mprt")
    add_parsers(p.add_subparsers(dest="cmd", required=True))
    a = p.parse_args([str(x) for x in argv])
    return a.func(a)


@pytest.fixture
def traces(monkeypatch):
    """The (rules, threshold, grid dims) of every trace made in this process."""
    made = []
    real = tracing.trace

    def spy(grid, width=0, height=0, rules="paper", threshold=None, **kw):
        made.append((rules, threshold))
        return real(grid, width, height, rules, threshold, **kw)

    monkeypatch.setattr(tracing, "trace", spy)
    return made


def test_explore_passes_rules_threshold_and_grid_to_every_trace(tmp_path, traces, capsys):
    out = tmp_path / "e.json"
    assert run("explore", "tetra:1", "--res", "16x16", "--space", SMALL, "--level", "1", "--max-evals", "20",
               "--workers", "0", "--threads", "1", "--rules", "paper1992", "--threshold", "1/256", "--grid", "4",
               "--json", out, "--report", tmp_path / "e.html") == 0
    r = json.loads(out.read_text())
    html = (tmp_path / "e.html").read_text()
    reproduce = html[html.index('id="reproduce"'):]
    assert "paper1992" in reproduce and "threshold" in reproduce and "0.00390625" in reproduce
    (scene,) = r["settings"]["scenes"]
    assert scene["rules"] == "paper1992"
    assert scene["threshold"] == 1 / 256
    assert r["settings"]["grid"] == [4, 4, 4]
    assert r["per_scene"][0]["subdivision"] == [4, 4, 4]              # the space's n = 9 held at 4
    assert {tuple(map(tuple, h["subdivisions"])) for h in r["history"] if "subdivisions" in h} == {((4, 4, 4),)}
    assert traces and set(traces) == {("paper1992", 1 / 256)}
    assert "subdivision fixed at 4x4x4" in capsys.readouterr().out


def test_explore_settings_show_the_default_rules_and_cutoff(tmp_path, traces):
    from mprt.options import default_threshold
    out = tmp_path / "e.json"
    assert run("explore", "tetra:1", "--res", "16x16", "--space", SMALL, "--level", "1", "--max-evals", "10",
               "--workers", "0", "--threads", "1", "--json", out) == 0
    s = json.loads(out.read_text())["settings"]
    (scene,) = s["scenes"]
    assert (scene["rules"], scene["threshold"], s["grid"]) == ("paper", default_threshold(), None)
    assert {ru for ru, _ in traces} == {"paper"}


def test_prepass_passes_rules_and_threshold_and_takes_grid_as_its_one_candidate(tmp_path, traces, capsys):
    out = tmp_path / "p.json"
    assert run("prepass", "balls:1", "--res", "64x64", "--level", "1", "--threads", "1", "--rules", "spd",
               "--grid", "5,6,7", "--json", out) == 0
    r = json.loads(out.read_text())
    assert [c["subdivision"] for c in r["candidates"]] == [[5, 6, 7]] and r["subdivision"] == [5, 6, 7]
    assert r["settings"]["rules"] == "spd" and r["settings"]["threshold"] is None
    assert traces and set(traces) == {("spd", None)}


@pytest.mark.parametrize("argv, words", [
    (["prepass", "balls:1", "--grid", "4", "--candidates", "3,5"], "leave out --candidates"),
    (["prepass", "balls:1", "--grid", "4", "--range", "2:9"], "leave out --range"),
    (["prepass", "balls:1", "--rules", "spd", "--threshold", "0.01"], "--threshold applies to the paper"),
    (["explore", "balls:1", "--rules", "spd", "--threshold", "0.01"], "--threshold applies to the paper"),
    (["explore", "balls:1", "--grid", "0"], "voxels per axis 0 is not in 1..1024"),
    (["prepass", "balls:1", "--rules", "fast"], "invalid choice"),
])
def test_contradictions_and_bad_values_exit_2(argv, words, capsys):
    from mprt import cli
    try:
        code = cli.main(argv)
    except SystemExit as e:
        code = e.code
    assert code == 2
    assert words in capsys.readouterr().err


# -- the prepass at tiny resolutions (issue 20: 16x16 tried only 2x2x2 and 3x3x3, traced at 8x8) -------
def test_low_resolution_has_a_floor_but_never_exceeds_the_frame():
    assert low_resolution(16, 16, 16) == (16, 16)          # not 8x8: the whole (tiny) frame
    assert low_resolution(512, 512, 16) == (32, 32)
    assert low_resolution(640, 480, 16) == (40, 32)
    assert low_resolution(4, 300, 16) == (4, 32)


def test_prepass_tries_a_ladder_at_a_tiny_resolution(capsys):
    r = prepass(Scene.spd("tetra", 1), 16, 16, level=1)
    assert r["low_resolution"] == [16, 16]
    assert len(r["candidates"]) >= 4
    every = prepass(Scene.spd("tetra", 1), 16, 16, level=1, candidates=[tuple(c["subdivision"])
                                                                         for c in r["candidates"]])
    assert r["subdivision"] == every["subdivision"]
