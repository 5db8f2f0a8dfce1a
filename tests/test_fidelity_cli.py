"""``mprt simulate``'s fidelity options (--level, --engine, --sample, --tolerance)."""
import json
import os

import pytest

import mprt
from mprt.fidelity.cli import main
from mprt.machine import builtin, simulate

HERE = os.path.dirname(os.path.abspath(__file__))
BALLS = os.path.join(HERE, "data", "golden", "balls-g9.npz")


def run(tmp_path, *args):
    out = tmp_path / "out.json"
    rc = main(["simulate", *args, "--json", str(out)])
    return rc, (json.loads(out.read_text()) if rc == 0 else None)


def test_default_is_the_configurations_own_level_on_the_compiled_engine(tmp_path):
    rc, d = run(tmp_path, BALLS, "--model", "M")
    assert rc == 0
    assert (d["level"], d["engine"], d["sampled"]) == (1, "compiled", 1.0)
    truth = simulate(mprt.load_trace(BALLS), "M")
    assert d["cycles"] == truth.cycles and d["cycles_interval"] == [truth.cycles, truth.cycles]
    assert d["stages"]["IC"]["waiting"] == truth.stages["IC"]["waiting"]


def test_engines_give_the_same_cycles(tmp_path):
    _, a = run(tmp_path, BALLS, "--model", "3mppe", "--level", "1", "--engine", "simpy")
    _, b = run(tmp_path, BALLS, "--model", "3mppe", "--level", "1", "--engine", "compiled")
    assert a["engine"] == "simpy" and b["engine"] == "compiled" and a["cycles"] == b["cycles"]
    _, c = run(tmp_path, BALLS, "--model", "3mppe")
    assert (c["level"], c["engine"]) == (3, "compiled")
    _, s = run(tmp_path, BALLS, "--model", "3mppe", "--engine", "simpy")
    assert (s["level"], s["engine"]) == (3, "simpy")
    assert c["cycles"] == s["cycles"] == simulate(mprt.load_trace(BALLS), builtin("3mppe")).cycles
    assert c["memory"] == s["memory"] and c["links"] == s["links"]


def test_compiled_engine_runs_every_level(tmp_path, capsys):
    rc, c = run(tmp_path, BALLS, "--model", "3mppe", "--engine", "compiled")
    assert rc == 0 and (c["level"], c["engine"]) == (3, "compiled")
    _, a = run(tmp_path, BALLS, "--model", "3mppe", "--level", "2", "--engine", "simpy")
    _, b = run(tmp_path, BALLS, "--model", "3mppe", "--level", "2", "--engine", "compiled")
    assert (a["level"], b["level"], b["engine"]) == (2, 2, "compiled") and a["cycles"] == b["cycles"]


def test_level0_and_auto(tmp_path, capsys):
    _, z = run(tmp_path, BALLS, "--model", "S", "--level", "0")
    assert (z["level"], z["engine"]) == (0, "analytical")
    assert z["cycles"] == simulate(mprt.load_trace(BALLS), "S").cycles     # exact for one processor
    rc, a = run(tmp_path, BALLS, "--model", "3mppe", "--level", "auto", "--tolerance", "50%")
    # every level is within 50% here: the fastest of them
    assert rc == 0 and a["level"] in (0, 1, 2, 3)
    rc, b = run(tmp_path, BALLS, "--model", "3mppe", "--level", "auto", "--tolerance", "0")
    assert rc == 0 and b["level"] in (2, 3)     # only the ring's level is exact
    assert "cheapest within 0%" in capsys.readouterr().out


def test_auto_measures_on_runs_of_a_large_frame(tmp_path, capsys):
    """A frame of 64 tiles: --level auto measures the levels on runs holding a sixteenth of
    its visits (at most), not on the whole frame."""
    rc, d = run(tmp_path, "tetra", "--grid", "4", "--res", "64x64", "--tile", "8", "--model", "M", "--level", "auto")
    assert rc == 0 and d["level"] in (0, 1)
    out = capsys.readouterr().out
    share = float(out.split("levels  measured on ")[1].split("%")[0])
    assert 0 < share < 100


def test_a_sample_of_tiles_of_a_scene_is_refused(tmp_path, capsys):
    """Issue 20: the tile-sampled interval does not hold (tests/test_answers.py), so simulate
    refuses it before any work."""
    with pytest.raises(SystemExit) as e:
        run(tmp_path, "tetra", "--grid", "4", "--res", "32x32", "--tile", "8", "--model", "M",
            "--sample", "stratified:4:1")
    assert e.value.code == 2 and "a sample of tiles gives no trustworthy 95% interval" in capsys.readouterr().err


def test_sample_of_runs(tmp_path):
    """runs: the whole frame is traced, a quarter of its visits replayed, and the estimate
    scaled by the frame's level 0 (within a few percent of the whole replay on this small
    frame: 2 runs)."""
    rc, d = run(tmp_path, "tetra", "--grid", "4", "--res", "48x48", "--model", "M", "--sample", "runs:4:1:100")
    assert rc == 0 and d["sample"] == "runs:4:1:100"
    assert 0.1 < d["sampled_visits"] <= 0.25 + 0.02 and 0 < d["sampled"] < 1
    lo, hi = d["cycles_interval"]
    assert lo <= d["cycles"] <= hi and d["sample_cycles"] < d["cycles"]
    rc, w = run(tmp_path, "tetra", "--grid", "4", "--res", "48x48", "--model", "M")
    assert abs(d["cycles"] / w["cycles"] - 1) < 0.05


@pytest.mark.parametrize("args,msg", [(["--sample", "random:3"], "sample must be"),
                                      (["--sample", "runs:4"], "runs:K:SEED"),
                                      (["--tolerance", "2"], "tolerance must be in"),
                                      (["--level", "5"], "invalid choice"),
                                      (["--level", "auto", "--engine", "simpy"], "leave --engine out")])
def test_bad_options_exit_2(tmp_path, capsys, args, msg):
    with pytest.raises(SystemExit) as e:
        rc = main(["simulate", BALLS, *args])
        raise SystemExit(rc)
    assert e.value.code == 2
    assert msg in capsys.readouterr().err


def test_the_probe_samples_whole_trees_from_stretches_of_the_file():
    """The phase estimate's sample reads only stretches of the trace: whole trees, renumbered,
    a valid trace of about 1/PROBE_RUNS of the visits that the compiled replay takes."""
    import numpy as np

    from mprt import tracecheck
    from mprt.fidelity import cli as fcli
    from mprt.fidelity.compiled import Compiled, costs_for

    t = mprt.load_trace(BALLS)
    s = fcli._probe_sample(t)
    assert s is not None and 0 < len(s.visits) <= len(t.visits) // fcli.PROBE_RUNS
    tracecheck.check(s)                                     # ids 0..n-1, whole trees, parents renumbered
    assert np.array_equal(s.rays["id"], np.arange(len(s.rays)))
    cfg = builtin("3mppe")
    assert Compiled(s, costs_for(s, cfg)).cycles(cfg) > 0


def test_a_short_replay_is_not_probed_and_a_long_one_is(monkeypatch, capsys):
    """The phases' estimate comes from typical rates unless they put the run over PROBE_FROM
    seconds: only then is a sample of the trees replayed first (it costs about 5% of the run)."""
    from mprt import cli
    from mprt.fidelity import cli as fcli
    probed = []
    real = fcli._probe
    monkeypatch.setattr(fcli, "PHASE_VISITS", 0)
    monkeypatch.setattr(fcli, "_probe", lambda *a: probed.append(1) or real(*a))
    argv = ["simulate", "balls:1", "--res", "24x24", "--model", "M", "--threads", "1"]
    assert cli.main(argv) == 0
    assert not probed and "at a typical" in capsys.readouterr().err
    monkeypatch.setattr(fcli, "PROBE_FROM", 0.0)
    assert cli.main(argv) == 0
    assert probed and f"a 1/{fcli.PROBE_RUNS} sample of its trees" in capsys.readouterr().err
