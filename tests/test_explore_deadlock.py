"""A design that deadlocks has no cycle count, and nothing the explorer, the prepass or the
sweep reports gives it one: before, the evaluator's stand-in (10^30 cycles, which keeps such
designs last in a search) reached the JSON, the printed report, the HTML page and the plot,
and a prepass on a machine that deadlocked everywhere chose a subdivision.  Every --json file
is standard JSON (no Infinity, no NaN)."""
import csv
import json
import math
from pathlib import Path

import pytest

import mprt
from mprt.cli import main
from mprt.explore.evaluate import DEADLOCK_CYCLES, Result, SceneEvaluator, TraceEvaluator
from mprt.explore.prepass import PrepassDeadlockError, prepass
from mprt.explore.problem import Problem
from mprt.explore.space import load_space
from mprt.machine import builtin
from mprt.options import json_safe, write_json

HERE = Path(__file__).parent
SMALL_SPACE = HERE / "data" / "explore" / "small_space.toml"

# Nested glass-like spheres (reflecting and refracting: Ks 0.5 + T 0.5) over a floor: their
# ray trees hold more rays than the 3MPPE's FIFOs, so it deadlocks even with one tree in flight
DEADLOCK_NFF = """v
from 0 -6 0
at 0 0 0
up 0 0 1
angle 30
hither 0.01
resolution 16 16
b 0.1 0.1 0.2
l 4 -6 6
f 0.9 0.9 0.9 0.2 0.5 20 0.5 1.5
s 0 0 0 1
s 0 0 0 0.8
s 0 0 0 0.6
s 0.3 -0.2 0.1 0.3
f 0.8 0.8 0.8 0.7 0.3 20 0 1
p 4
-5 -5 -1.2
5 -5 -1.2
5 5 -1.2
-5 5 -1.2
"""


def strict_json(path):
    """The file parsed as the JSON standard has it (Infinity and NaN refused)."""
    def refuse(c):
        raise ValueError(f"{path}: {c} is not JSON")
    return json.loads(Path(path).read_text(), parse_constant=refuse)


@pytest.fixture
def scene(tmp_path):
    p = tmp_path / "dl.nff"
    p.write_text(DEADLOCK_NFF)
    return p


def test_explore_reports_a_deadlocked_reference_without_cycles(scene, tmp_path, capsys):
    j, png, html = tmp_path / "e.json", tmp_path / "e.png", tmp_path / "e.html"
    assert main(["explore", str(scene), "--res", "16x16", "--space", str(SMALL_SPACE), "--budget", "2000",
                 "--json", str(j), "--plot", str(png), "--report", str(html)]) == 0
    out = capsys.readouterr().out
    rep = strict_json(j)
    refs = rep["references"]
    (r3,), (rs,) = refs["3mppe"]["per_scene"], refs["S"]["per_scene"]
    assert r3["deadlock"] and r3["cycles"] is None and refs["3mppe"]["cost"] > 0
    assert not rs["deadlock"] and rs["cycles"] > 0
    (row,) = rep["per_scene"]
    assert row["speedup"] is None and rep["best"]["speedup_geomean"] is None     # no figure over a deadlock
    line = next(x for x in out.splitlines() if "paper 3MPPE" in x)
    assert "deadlocks" in line and "cycles deadlocks" in line
    for row in rep["history"]:
        assert (row["cycles"] is None) == row["deadlock"], row
        assert row["cycles"] is None or row["cycles"] < DEADLOCK_CYCLES
        if row["deadlock"] and row["feasible"] and "objective" in row:
            assert row["objective"] is None
    page = html.read_text()
    assert "deadlocks" in page
    for text in (out, page):
        assert "1,000,000,000,000" not in text and "1e+30" not in text
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_history_and_front_give_deadlocked_designs_no_cycles():
    space = load_space(SMALL_SPACE)
    idxs = [space.canonical([i % v.size for v in space.variables]) for i in range(6)]
    idxs = list(dict.fromkeys(idxs))
    cost = {k: 100.0 + 10 * n for n, k in enumerate(idxs)}
    dead = set(idxs[::2])               # the cheapest among them deadlocks

    def run(points):
        out = []
        for p in points:
            k = next(k for k in idxs if space.point(k) == p)
            out.append(Result(cycles=DEADLOCK_CYCLES, level=3, cost=cost[k], bottleneck="deadlock") if k in dead
                       else Result(cycles=1e6 - cost[k], level=3, cost=cost[k], bottleneck="OS"))
        return out

    pr = Problem(space, run, "time", budget=1e4)
    pr.evaluate_many(idxs)
    rows = pr.history()
    assert [r["deadlock"] for r in rows] == [k in dead for k in idxs]
    for r, k in zip(rows, idxs):
        assert (r["cycles"] is None) == (k in dead) and (r["objective"] is None) == (k in dead)
    assert rows[0]["best_objective"] is None            # no design has run yet
    assert rows[1]["best_objective"] == pytest.approx(math.log(1e6 - cost[idxs[1]]))
    front = pr.front()
    assert front and not any(e.index in dead for e in front)
    assert front[0].index == idxs[1]                   # the cheapest that runs, not the cheapest


def test_json_files_are_standard_json(tmp_path):
    data = {"a": math.inf, "b": [1.5, -math.inf, {"c": math.nan}], "d": (2, 3), "e": "x", "f": None}
    assert json_safe(data) == {"a": None, "b": [1.5, None, {"c": None}], "d": [2, 3], "e": "x", "f": None}
    p = tmp_path / "x.json"
    write_json(p, data)
    assert strict_json(p) == json_safe(data)


def test_prepass_on_a_machine_that_deadlocks_everywhere_fails_naming_it(scene, tmp_path, capsys):
    sc = mprt.Scene.load(str(scene))
    with pytest.raises(PrepassDeadlockError, match=r"machine 3mppe deadlocks at level 1 on every subdivision "
                                                   r"tried at 32x32 \(2x2x1, 4x4x1\)"):
        prepass(sc, 32, 32, candidates=[2, 4], design=builtin("3mppe"), level=1)
    assert main(["prepass", str(scene), "--res", "32x32", "--candidates", "2,4", "--level", "1",
                 "--model", "3mppe", "--json", str(tmp_path / "p.json")]) == 1
    err = capsys.readouterr().err
    assert "deadlocks at level 1 on every subdivision" in err and not (tmp_path / "p.json").exists()


def test_prepass_never_chooses_a_subdivision_that_deadlocks(monkeypatch, tmp_path, capsys):
    # tetra runs on the 3MPPE; here its best low-resolution candidate is made to deadlock there,
    # and then at full resolution in the check: the choice is the best that runs at both
    sc = mprt.Scene.load("tetra:1")
    base = prepass(sc, 64, 64, candidates=[2, 4, 8], level=1)
    order = sorted(base["candidates"], key=lambda c: c["predicted_cycles"])
    low_dead, full_dead = tuple(order[0]["subdivision"]), tuple(order[1]["subdivision"])
    run_config, run = TraceEvaluator.run_config, SceneEvaluator.run

    def low(self, cfg, level=1, *a, **k):
        if tuple(self.trace.meta["grid"]) == low_dead:
            return Result(cycles=DEADLOCK_CYCLES, level=level, cost=0.0, bottleneck="deadlock")
        return run_config(self, cfg, level, *a, **k)

    def full(self, point, *a, **k):
        if tuple(point.subdivision) == full_dead:
            return Result(cycles=DEADLOCK_CYCLES, level=1, cost=0.0, bottleneck="deadlock")
        return run(self, point, *a, **k)

    monkeypatch.setattr(TraceEvaluator, "run_config", low)
    monkeypatch.setattr(SceneEvaluator, "run", full)
    r = prepass(sc, 64, 64, candidates=[2, 4, 8], level=1, check=2)
    by = {tuple(c["subdivision"]): c for c in r["candidates"]}
    assert by[low_dead]["deadlock"] and by[low_dead]["predicted_cycles"] is None
    assert by[full_dead]["sampled_deadlock"] and by[full_dead]["sampled_cycles"] is None
    third = tuple(order[2]["subdivision"])
    assert tuple(r["subdivision"]) == third and by[third]["sampled_cycles"] > 0
    assert not by[third]["deadlock"] and not by[third]["sampled_deadlock"]


def test_sweep_rows_of_a_deadlocked_design_have_no_cycles(scene, tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text(f'scenes = ["{scene}"]\nres = "16x16"\nsubdivisions = [2]\nlevel = 1\n'
                    '[designs]\npaper = "3mppe"\nsingle = "S"\n')
    assert main(["sweep", str(spec), "--out", str(tmp_path / "sw"), "--workers", "0"]) == 0
    with open(tmp_path / "sw" / "sweep.csv") as f:
        rows = {r["design"]: r for r in csv.DictReader(f)}
    assert rows["paper"]["bottleneck"] == "deadlock" and rows["paper"]["cycles"] == ""
    assert rows["single"]["bottleneck"] != "deadlock" and float(rows["single"]["cycles"]) > 0
