"""mprt explore and mprt prepass from the command line, and the prepass's search."""
import argparse
import json
from pathlib import Path

import numpy as np
import pytest

import mprt
from mprt.explore.cli import add_parsers
from mprt.explore.evaluate import TraceEvaluator, grid_dims
from mprt.explore.prepass import prepass

SMALL = Path(__file__).parent / "data" / "explore" / "small_space.toml"


def run(*argv):
    p = argparse.ArgumentParser(prog="mprt")
    add_parsers(p.add_subparsers(dest="cmd", required=True))
    a = p.parse_args([str(x) for x in argv])
    return a.func(a)


def test_explore_json_report(tmp_path, capsys):
    out, png = tmp_path / "e.json", tmp_path / "e.png"
    assert run("explore", "tetra:1", "--res", "16x16", "--space", SMALL, "--budget", "400", "--json", out,
               "--plot", png, "--max-evals", "40", "--threads", "1", "--workers", "0") == 0
    r = json.loads(out.read_text())
    best, (row,) = r["best"], r["per_scene"]
    assert row["scene"] == "tetra:1" and len(row["subdivision"]) == 3
    assert all(isinstance(n, int) for n in row["subdivision"])
    assert best["cost"] <= 400 and best["feasible"] is True
    assert r["seconds"] > 0 and r["evaluations"]["machines"] > 0
    # --level auto: everything runs at the ladder's lowest level within the tolerance
    lv = r["level"]
    ok = [x["level"] for x in lv["ladder"] if x["error_top_worst"] <= r["tolerance"]]
    want = min(ok) if ok else lv["ladder"][-1]["level"]
    assert lv["asked"] == "auto" and lv["verify"] == want and lv["search"] == want and row["level"] == want
    assert {h["level"] for h in r["history"]} == {want}
    # a workload of one: the answer is its own best, and its speed-up is over the 3MPPE's run
    assert row["sharing"] == 1.0 and row["own_best"]["machine"] == "workload"
    ref = r["references"]["3mppe"]["per_scene"][0]
    assert row["speedup"] == pytest.approx(ref["cycles"] / row["cycles"])
    # the machine replays to the same cycles on its own, at that level, on the whole frame
    tr = mprt.Scene.spd("tetra", 1).grid(tuple(row["subdivision"])).trace(16, 16)[1]
    from mprt.explore import Design
    assert TraceEvaluator(tr).run(Design.from_dict(best["design"]), want).cycles == row["cycles"]
    assert png.stat().st_size > 10000
    text = capsys.readouterr().out
    for words in ("answer", "processors in", "speedup", "model S", "level"):
        assert words in text


def test_explore_fixed_level(tmp_path):
    """--level 1: searched and reported at level 1 (the compiled replay), no ladder measured."""
    out = tmp_path / "e.json"
    assert run("explore", "balls:1", "--res", "16x16", "--space", SMALL, "--level", "1", "--json", out,
               "--max-evals", "30", "--workers", "0") == 0
    r = json.loads(out.read_text())
    assert r["level"] == {"asked": 1, "search": 1, "verify": 1}
    assert {h["level"] for h in r["history"]} == {1}


def test_explore_pareto_front(tmp_path):
    out = tmp_path / "p.json"
    assert run("explore", "balls:1", "--res", "16x16", "--space", SMALL, "--objective", "pareto", "--json", out,
               "--max-evals", "60", "--level", "1", "--workers", "0") == 0
    r = json.loads(out.read_text())
    front = r["front"]
    assert len(front) >= 2
    costs = [f["cost"] for f in front]
    figure = [f["objective"] for f in front]
    assert costs == sorted(costs) and all(b < a for a, b in zip(figure, figure[1:]))
    # nothing evaluated beats a front point in both cost and figure (a machine that deadlocked has
    # none, and is on no front)
    ran = [h for h in r["history"] if not h["deadlock"] and h["phase"] == "search"]
    assert all(h["cycles"] is not None for h in ran)
    for f in front:
        assert not any(h["cost"] <= f["cost"] and h["cycles"] < f["objective"] for h in ran)
    # the knee marked once, the answer; each row shows the design fields that differ along the front
    (knee,) = [f for f in front if f["knee"]]
    assert r["best"]["design"] == knee["design"]
    keys = set(front[0]["differs"])
    assert keys and all(set(f["differs"]) == keys for f in front)
    assert all(len({repr(f["differs"][k]) for f in front}) > 1 for k in keys)
    assert not any(f["budget_best"] for f in front)             # (no budget given)


def test_explore_pareto_marks_the_budgets_best(tmp_path, capsys):
    out = tmp_path / "p.json"
    assert run("explore", "balls:1", "--res", "16x16", "--space", SMALL, "--objective", "pareto", "--budget", "300",
               "--json", out, "--max-evals", "60", "--level", "1", "--workers", "0") == 0
    front = json.loads(out.read_text())["front"]
    (best,) = [f for f in front if f["budget_best"]]
    assert best["objective"] == min(f["objective"] for f in front if f["cost"] <= 300)
    text = capsys.readouterr().out
    assert "+ the best within the budget" in text and "* the knee" in text


@pytest.mark.parametrize("argv, message", [
    (["explore", "balls:1", "--space", "nowhere.toml"], "cannot read the space file"),
    (["explore", "balls:1", "--json", "no/such/dir/x.json"], "does not exist"),
    (["prepass", "balls:1", "--json", "no/such/dir/x.json"], "does not exist"),
])
def test_errors_before_work(argv, message, capsys):
    with pytest.raises((mprt.MprtError, OSError), match=message):
        run(*argv)


@pytest.mark.parametrize("argv", [["explore", "balls", "--res", "0x64"], ["explore", "balls", "--budget", "-3"],
                                  ["explore", "balls", "--tolerance", "150%"], ["prepass", "balls", "--range", "9:3"],
                                  ["prepass", "balls", "--candidates", "4,x"], ["explore", "balls", "--level", "7"],
                                  ["explore", "balls", "--objective", "time"]])
def test_bad_options_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as e:
        run(*argv)
    assert e.value.code == 2
    assert "error" in capsys.readouterr().err


def test_prepass_search_finds_the_best_of_every_candidate():
    """The ladder-then-golden search over n finds the n that evaluating every
    n in the range finds (on the same low-resolution traces)."""
    scene = mprt.Scene.spd("tetra", 1)
    r = prepass(scene, 64, 64, n_range=(2, 30), fraction=4, check=0, axes=False)
    every = prepass(scene, 64, 64, candidates=[(n,) for n in range(2, 31)], fraction=4, check=0)
    assert r["subdivision"] == every["subdivision"]
    assert len(r["candidates"]) < len(every["candidates"]) / 2
    # predictions are the low-resolution cycles scaled by the pixel ratio
    dims = tuple(r["subdivision"])
    from mprt.machine.config import builtin
    lw, lh = r["low_resolution"]            # 64/4 = 16, raised to the floor of 32 per axis
    assert (lw, lh) == (32, 32)
    low = TraceEvaluator(scene.grid(dims).trace(lw, lh)[1]).run_config(builtin("3mppe"), 1).cycles
    assert r["predicted_cycles"] == pytest.approx(low * 64 * 64 / (lw * lh))


def test_prepass_cli_json(tmp_path):
    out = tmp_path / "p.json"
    assert run("prepass", "balls:1", "--res", "64x64", "--candidates", "3,6,12/8x8x2", "--json", out) == 0
    r = json.loads(out.read_text())
    scene = mprt.Scene.spd("balls", 1)
    want = [list(grid_dims(scene, (n,), "proportional")) for n in (3, 6, 12)] + [[8, 8, 2]]
    assert sorted(c["subdivision"] for c in r["candidates"]) == sorted(want)
    best = min(r["candidates"], key=lambda c: c["predicted_cycles"])
    assert r["subdivision"] == best["subdivision"]
    assert np.all(np.array([c["predicted_cycles"] for c in r["candidates"]]) > 0)


def test_prepass_check_replays_the_best_candidates_at_full_resolution():
    """--check: the best predictions are replayed at full resolution (here the sample is the
    whole 64x64 frame, 16 tiles) and the choice is the best of those replays."""
    from mprt.machine.config import builtin
    scene = mprt.Scene.spd("tetra", 1)
    r = prepass(scene, 64, 64, n_range=(2, 30), fraction=4, check=2)
    assert r["check_sample"] == "stratified:1:1"
    checked = [c for c in r["candidates"] if "sampled_cycles" in c]
    assert len(checked) == 2
    by_prediction = sorted(r["candidates"], key=lambda c: (c["predicted_cycles"], c["subdivision"]))
    assert [c["subdivision"] for c in checked] == sorted(c["subdivision"] for c in by_prediction[:2])
    for c in checked:
        full = scene.grid(tuple(c["subdivision"])).trace(64, 64)[1]
        assert c["sampled_cycles"] == TraceEvaluator(full).run_config(builtin("3mppe"), 1).cycles
    assert r["subdivision"] == min(checked, key=lambda c: c["sampled_cycles"])["subdivision"]


@pytest.mark.parametrize("name", ["balls", "tetra"])
def test_prepass_stops_one_rung_past_the_best(name):
    """Walking one rung past the ladder's best (the default) brackets the same minimum as two: the
    same choice, from a subset of the candidates (the large grids left unbuilt)."""
    scene = mprt.Scene.spd(name, 1)
    one, two = prepass(scene, 128, 128, past=1), prepass(scene, 128, 128, past=2)
    assert one["subdivision"] == two["subdivision"]
    c1 = {tuple(c["subdivision"]) for c in one["candidates"]}
    c2 = {tuple(c["subdivision"]) for c in two["candidates"]}
    assert c1 <= c2 and len(c1) <= len(c2)


def test_prepass_parabola_step_evaluates_the_vertex_of_the_bracket():
    """refine='parabola': the ladder as for the golden section, then exactly one more candidate,
    strictly inside the bracket around the ladder's best, and the choice is the best evaluated."""
    scene = mprt.Scene.spd("rings", 1)         # its ladder's best, 22, is inside the ladder (4..40)
    none = prepass(scene, 64, 64, fraction=2, refine="none", axes=False)
    para = prepass(scene, 64, 64, fraction=2, refine="parabola", axes=False)
    ladder = {tuple(c["subdivision"]): c["predicted_cycles"] for c in none["candidates"]}
    got = {tuple(c["subdivision"]): c["predicted_cycles"] for c in para["candidates"]}
    assert set(ladder) <= set(got) and len(got) <= len(ladder) + 1
    best = tuple(none["subdivision"])
    (n,) = set(got) - set(ladder)
    below = [d for d in ladder if d[0] < best[0]]
    above = [d for d in ladder if d[0] > best[0]]
    assert below and above and max(below)[0] < n[0] < min(above)[0]
    assert para["subdivision"] == list(min(got, key=lambda d: (got[d], d)))
    with pytest.raises(ValueError, match="refine"):
        prepass(scene, 64, 64, n_range=(2, 30), fraction=4, refine="brent")


@pytest.mark.parametrize("name", ["balls", "tetra"])
def test_prepass_then_descends_each_axis_to_a_point_no_axis_step_improves(name):
    """The subdivision is free per axis: from the best of the rule's line, each axis moves on its
    own while the time falls; the choice is at least as fast as the line's, and no single step of
    one axis (x or / 1.25) from it is faster (on the same low-resolution traces)."""
    from mprt.explore.prepass import AXIS_STEP
    scene = mprt.Scene.spd(name, 1)
    line = prepass(scene, 64, 64, fraction=2, level=1, axes=False)
    free = prepass(scene, 64, 64, fraction=2, level=1)
    assert free["per_axis"] and not line["per_axis"]
    got = {tuple(c["subdivision"]): c["predicted_cycles"] for c in free["candidates"]}
    best = tuple(free["subdivision"])
    assert got[best] <= min(c["predicted_cycles"] for c in line["candidates"])
    for axis in range(3):
        for k in (max(best[axis] + 1, round(best[axis] * AXIS_STEP)), min(best[axis] - 1, int(best[axis] / AXIS_STEP))):
            if k >= 1:
                nb = list(best)
                nb[axis] = k
                assert tuple(nb) in got and got[tuple(nb)] >= got[best]


@pytest.mark.parametrize("objective", ["geomean", "pareto"])
def test_the_explore_figure_reads_at_a_glance(tmp_path, objective):
    """The figure on a report page (1160 px of content): no text under 12 px, no overlapping
    labels, nothing past its edges (mprt.util.figures.check), for a workload and for the front."""
    from mprt.explore.plots import figure
    from mprt.util import figures
    out = tmp_path / "e.json"
    assert run("explore", "tetra:1", "balls:1", "--res", "16x16", "--space", SMALL, "--budget", "400", "--level", "1",
               "--objective", objective, "--max-evals", "40", "--workers", "0", "--json", out) == 0
    fig = figure(json.loads(out.read_text()))
    assert figures.check(fig) == []
    assert fig.get_figwidth() * figures.DPI <= figures.CONTENT_PX + 1      # shown at its natural size
