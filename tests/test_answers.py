"""An answer is what it says (issue 20, item 1): a budget no design in the space meets is refused
before any work, naming the cheapest design's cost; a report says whether its best meets the
budget (``feasible``) and a best over it is an error."""
import argparse
import itertools
import json
from pathlib import Path

import pytest

from mprt.explore import cli as explore_cli
from mprt.explore.hwcost import UnitCosts, cheapest_design, hardware_cost
from mprt.explore.space import default_space, parse_space
from cli_run import cli_main

SMALL = Path(__file__).parent / "data" / "explore" / "small_space.toml"


main = cli_main


def brute_force_cheapest(space):
    costs = UnitCosts.from_table(space.cost)
    return min(hardware_cost(space.point(idx).design, costs)
               for idx in itertools.product(*(range(v.size) for v in space.variables)))


@pytest.mark.parametrize("text", [
    SMALL.read_text(),
    # choices out of order, a costly mapping only, a [cost] table that makes FIFOs dear
    SMALL.read_text().replace('mapping = { choices = ["OS|IC|SC", "OS+SC|IC", "OS|IC+SC", "OS+IC+SC"] }',
                              'mapping = { choices = ["OS|IC+SC", "OS|IC|SC"] }')
                     .replace("fifo = 16", "fifo = { choices = [64, 16, 32] }")
    + "[cost]\nfifo_word = 5.0\n",
])
def test_the_cheapest_design_is_the_least_cost_of_every_design(text):
    """cheapest_design (no trace) equals the least cost over every point of the space."""
    space = parse_space(text, "t.toml")
    cost, design = cheapest_design(space, UnitCosts.from_table(space.cost))
    assert cost == pytest.approx(brute_force_cheapest(space))
    assert hardware_cost(design, UnitCosts.from_table(space.cost)) == cost


def test_a_budget_below_the_cheapest_design_is_refused_before_any_work(monkeypatch, capsys):
    """--budget 1 on the built-in space: exit 2, naming the cheapest design's cost; no scene is
    traced and no search runs."""
    import mprt.explore.explorer as explorer

    def no_work(*a, **k):
        raise AssertionError("explore ran")
    monkeypatch.setattr(explorer, "explore", no_work)
    monkeypatch.setattr("mprt.options.load_scene", no_work)
    cheapest = cheapest_design(default_space())[0]
    code, out, err = main(capsys, "explore", "tetra:1", "--res", "16x16", "--budget", "1")
    assert code == 2 and out == ""
    assert f"--budget 1 kGE: no design in the space meets it; the cheapest costs {cheapest:.1f} kGE" in err
    # a budget the cheapest design meets passes the check
    explore_cli.check_budget(default_space(), cheapest, "time")
    # the pareto objective has no budget to check
    explore_cli.check_budget(default_space(), 1, "pareto")


def _report(cost, budget, objective="geomean"):
    from mprt.explore.explorer import ExploreResult, processor_table
    from mprt.machine import builtin
    util = {"OS+IC+SC": 1.0}
    cfg = builtin("S")
    ref = {"cost": 50.0, "per_scene": [{"scene": "t", "subdivision": [1, 1, 1], "cycles": 10.0, "deadlock": False,
                                        "utilisation": util, "bottleneck": "OS+IC+SC"}], "cycles": 10.0}
    row = {"scene": "t", "weight": 1.0, "resolution": [8, 8], "subdivision": [1, 1, 1], "level": 1, "cycles": 5.0,
           "speedup": 2.0, "bottleneck": "OS+IC+SC", "utilisation": util, "own_best": {"cycles": 5.0},
           "sharing": 1.0}
    best = {"described": "d", "design": None, "machine": cfg.to_dict(), "processors": processor_table(cfg),
            "cost": cost, "cost_breakdown": {"processors": cost}, "speedup_geomean": 2.0, "speedup_worst": 2.0,
            "sharing_geomean": 1.0, "total_cycles": 5.0,
            "feasible": budget is None or cost <= budget}
    rep = {"objective": objective, "budget": budget, "seconds": 0.1, "tolerance": 0.01,
           "level": {"asked": 1, "search": 1, "verify": 1}, "settings": {"scenes": [], "grid": None},
           "evaluations": {"machines": 1, "replayed": 1, "reused_from_cache": 0, "worker_restarts": 0}}
    return ExploreResult(best, [row], {"3mppe": ref, "M": ref, "S": ref}, [], [], rep, cfg)


@pytest.mark.parametrize("cost, budget, feasible, code", [(104.0, 60.0, False, 1), (52.0, 60.0, True, 0),
                                                           (104.0, None, True, 0)])
def test_the_report_says_whether_its_best_meets_the_budget(monkeypatch, tmp_path, capsys, cost, budget,
                                                           feasible, code):
    """The JSON's ``feasible`` (top level and in ``best``) is whether the best meets the budget;
    a best over it is printed as such and the command exits 1."""
    import mprt.explore.explorer as explorer
    monkeypatch.setattr(explorer, "explore", lambda *a, **k: _report(cost, budget))
    out = tmp_path / "e.json"
    argv = ["explore", "tetra:1", "--res", "8x8", "--json", out] + (["--budget", budget] if budget else [])
    c, text, err = main(capsys, *argv)
    assert c == code
    r = json.loads(out.read_text())
    assert r["best"]["feasible"] is feasible
    assert ("OVER THE BUDGET" in text) is (not feasible)
    assert ("found no machine within the budget of 60 kGE (its best costs 104 kGE)" in err) is (not feasible)


# -- every trace version the README promises loads ------------------------------------------------
V1 = Path(__file__).parent / "data" / "trace_v1" / "tetra-g4-sha256.npz"


def test_a_version_1_trace_with_sha256_checksums_loads():
    """A golden trace of the first trace format (commit 56c9cd8: version 1, SHA-256 checksums,
    visit fields 'voxel' and 'voxels'), committed as it was written: it loads, passes the
    invariant check and gives the statistics that commit wrote beside it."""
    import mprt
    t = mprt.load_trace(V1)
    t.check()
    want = json.loads(V1.with_suffix(".stats.json").read_text())
    assert t.stats() == want


def test_a_version_1_trace_with_a_wrong_sha256_is_refused(tmp_path):
    """The SHA-256 is checked, not skipped: one byte changed in the rays is refused."""
    import zipfile
    import mprt
    from mprt.errors import TraceError
    bad = tmp_path / "bad.npz"
    with zipfile.ZipFile(V1) as z, zipfile.ZipFile(bad, "w") as out:
        for info in z.infolist():
            data = z.read(info)
            if info.filename == "rays.npy":
                data = data[:-1] + bytes([data[-1] ^ 1])
            out.writestr(info, data)
    with pytest.raises(TraceError, match=r"array 'rays' does not match its checksum \(tampered or damaged\)"):
        mprt.load_trace(bad)


def test_the_stats_command_reads_a_version_1_trace(capsys):
    code, out, err = main(capsys, "stats", V1)
    assert code == 0, err
    assert "tetra:1" in out and "1541" in out


# -- the sampled estimate: runs by default, samples of tiles refused ------------------------------
@pytest.mark.parametrize("spec", ["random:64:1", "stratified:16:1", "regular:4"])
def test_a_sample_of_tiles_is_refused_before_any_work(spec, monkeypatch, capsys):
    """simulate --sample random|stratified|regular: exit 2 before any tracing, saying why and
    what to use instead."""
    monkeypatch.setattr("mprt.options.load_scene", lambda *a, **k: pytest.fail("a scene was loaded"))
    code, out, err = main(capsys, "simulate", "balls:1", "--res", "16x16", "--model", "M", "--sample", spec)
    assert code == 2
    assert f"{spec}: a sample of tiles gives no trustworthy 95% interval" in err
    assert "covered the full replay in 15 to 20 of 20 seeds" in err and "use runs:K:SEED" in err


@pytest.mark.parametrize("given, want", [("runs:8:3", "runs:8:3"), ("8", "runs:8:1"), ("8:3", "runs:8:3"),
                                         ("8:3:100", "runs:8:3:100"), (None, "runs:16:1")])
def test_runs_are_the_default_sampling(given, want):
    """--sample K[:SEED] means runs; --sample alone is runs:16:1."""
    from mprt.fidelity import cli as fcli
    p = argparse.ArgumentParser()
    sub = p.add_subparsers()
    fcli.add_parser(sub)
    a = p.parse_args(["simulate", "x.npz", "--sample"] + ([given] if given else []))
    assert str(a.sample) == want


def test_simulate_with_runs_reports_an_interval_around_its_estimate(tmp_path, capsys):
    """--sample 4 on a small frame: runs are replayed and the JSON's interval holds the estimate."""
    out = tmp_path / "s.json"
    code, text, err = main(capsys, "simulate", "balls:1", "--grid", "6", "--res", "48x48", "--model", "M",
                           "--level", "1", "--sample", "4:2", "--json", out)
    assert code == 0, err
    r = json.loads(out.read_text())
    assert r["sample"] == "runs:4:2" and r["cycles_interval"][0] <= r["cycles"] <= r["cycles_interval"][1]
    assert 0 < r["sampled_visits"] < 0.5


# -- replay checks for other people's CI (item 6) -------------------------------------------------
GOLDEN = Path(__file__).parent / "data" / "golden"
PINNED = [("tetra-g4", "M"), ("balls-g9", "3mppe")]


@pytest.mark.parametrize("trace, model", PINNED)
def test_the_golden_replays_match_their_baselines(trace, model, capsys):
    """The project's own pins (make baselines runs the same in CI): exit 0 at tolerance 0."""
    code, out, err = main(capsys, "simulate", GOLDEN / f"{trace}.npz", "--model", model,
                          "--baseline", GOLDEN / "baselines" / f"{trace}.{model}.json", "--tolerance", "0")
    assert code == 0, err
    assert "+0.00%, within the tolerance of 0%" in out


def _moved_baseline(tmp_path, trace, model, stage, figure, factor):
    b = json.loads((GOLDEN / "baselines" / f"{trace}.{model}.json").read_text())
    b["cycles"] = int(b["cycles"] * factor)
    b["stages"][stage][figure] = int(b["stages"][stage][figure] * factor)
    path = tmp_path / "moved.json"
    path.write_text(json.dumps(b))
    return path, b


@pytest.mark.parametrize("trace, model", PINNED)
def test_cycles_beyond_the_tolerance_exit_3_naming_the_stage(tmp_path, capsys, trace, model):
    """A baseline whose cycles and IC processing were 5% lower: exit 3 at 1%, naming IC's
    processing first; within 10% it passes."""
    path, b = _moved_baseline(tmp_path, trace, model, "IC", "processing", 1 / 1.05)
    args = ["simulate", GOLDEN / f"{trace}.npz", "--model", model, "--baseline", path]
    code, out, err = main(capsys, *args, "--tolerance", "1%")
    assert code == 3
    lines = [ln.strip() for ln in err.splitlines()]
    first = next(i for i, ln in enumerate(lines) if ln.startswith("moved"))
    assert "beyond the tolerance of 1%" in lines[first]
    assert lines[first + 1].startswith("IC processing +5.0")
    code, out, err = main(capsys, *args, "--tolerance", "10%")
    assert code == 0 and "within the tolerance of 10%" in out


@pytest.mark.parametrize("content, message", [(None, "cannot read it"), ("{", "not JSON"),
                                              ('{"stages": {}}', "no positive 'cycles'")])
def test_a_bad_baseline_exits_2_before_any_work(tmp_path, capsys, monkeypatch, content, message):
    monkeypatch.setattr("mprt.machine.cli._load_source", lambda a: pytest.fail("traced"))
    path = tmp_path / "b.json"
    if content is not None:
        path.write_text(content)
    code, out, err = main(capsys, "simulate", "balls:1", "--res", "8x8", "--baseline", path)
    assert code == 2 and f"--baseline {path}: {message}" in err


def test_tolerance_with_a_baseline_does_not_choose_the_level(capsys):
    """--tolerance with --baseline is the allowed move: the replay stays at the model's own level."""
    code, out, err = main(capsys, "simulate", GOLDEN / "tetra-g4.npz", "--model", "M", "--baseline",
                          GOLDEN / "baselines" / "tetra-g4.M.json", "--tolerance", "1%")
    assert code == 0 and "levels  measured" not in out
