"""``mprt simulate`` (python/mprt/machine/cli.py)."""
import json
import os

import pytest

import mprt
from mprt.machine import simulate
from mprt.machine.cli import main

HERE = os.path.dirname(os.path.abspath(__file__))
TRACE = os.path.join(HERE, "data", "golden", "tetra-g4.npz")


def test_json_fields(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["simulate", TRACE, "--model", "M", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    t = mprt.load_trace(TRACE)
    st = t.stats()
    assert d["cycles"] == simulate(t, "M").cycles
    assert d["model"] == "M" and d["level"] == 2 and d["engine"] == "simpy" and d["sampled"] == 1.0
    assert d["cycles_interval"] == [d["cycles"], d["cycles"]]
    for s, key in (("OS", "os_input"), ("IC", "ic_input"), ("SC", "sc_input")):
        assert set(d["stages"][s]) >= {"processing", "communication", "waiting", "rays_in"}
        assert d["stages"][s]["rays_in"] == st[key]
        assert sum(d["stages"][s][k] for k in ("processing", "communication", "waiting")) == d["cycles"]
    assert sum(d["rays"].values()) == st["rays"] and d["rays"]["primary"] == st["os_input_primary"]
    assert d["visits"] == st["visits"] and d["wall_seconds"] > 0
    s = d["settings"]
    assert s["scene"] == t.meta["scene"] and s["scene_sha256"] == t.meta["scene_sha256"]
    assert s["grid"] == t.meta["grid"] and s["resolution"] == [t.meta["width"], t.meta["height"]]
    assert s["rules"] == "paper" and s["threshold"] == t.meta["threshold"]
    assert s["mprt_version"] == mprt.__version__ and d["config"]["name"] == "M"
    assert "model M (level 2)" in capsys.readouterr().out


def test_scene_is_traced_first_with_a_plot(tmp_path, capsys):
    png, js = tmp_path / "p.png", tmp_path / "r.json"
    assert main(["simulate", "tetra:1", "--grid", "4", "--res", "12x10", "--threads", "1", "--model", "3mppe",
                 "--pes", "3", "--plot", str(png), "--json", str(js)]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    d = json.loads(js.read_text())
    assert d["settings"]["resolution"] == [12, 10] and d["settings"]["grid"] == [4, 4, 4]
    assert d["level"] == 3 and d["settings"]["pes"] == 3 and len(d["pes"]) == 3
    assert "traced  tetra:1" in capsys.readouterr().out


def test_invalid_configuration_exit_2(tmp_path, capsys):
    cfg = tmp_path / "bad.toml"
    cfg.write_text('base = "M"\n[[stage]]\nsubtasks = ["OS", "IC", "SC"]\nreceive_fifo = 0\n')
    assert main(["simulate", TRACE, "--config", str(cfg)]) == 2
    err = capsys.readouterr().err
    assert "bad.toml: stage[0].receive_fifo: a FIFO holds at least 1 packet, not 0" in err


def test_more_pes_than_pixels_leave_pes_idle(tmp_path, capsys):
    from mprt.cli import main as mprt_main

    # (refused before, exit 2): the PEs that get no primary ray stay idle, on either engine
    for source, extra in ((TRACE, []), ("tetra:1", ["--res", "4x4"])):
        got = {}
        for pes in ("1", "17"):
            for engine in ("compiled", "simpy"):
                out = tmp_path / f"{pes}{engine}.json"
                assert mprt_main(["simulate", source, *extra, "--pes", pes, "--engine", engine,
                                  "--json", str(out)]) == 0
                got[pes, engine] = json.loads(out.read_text())
        capsys.readouterr()
        r = got["17", "compiled"]
        assert r["cycles"] == got["17", "simpy"]["cycles"] and r["pes"] == got["17", "simpy"]["pes"]
        assert len(r["pes"]) == 17
        idle = [p for p in r["pes"] if p["primaries"] == 0]
        assert idle and all(p["rays"] == 0 and p["end"] == 0 for p in idle)
        assert sum(p["primaries"] for p in r["pes"]) == sum(p["primaries"] for p in got["1", "compiled"]["pes"])


def test_tracing_options_with_a_trace_file_exit_2(capsys):
    assert main(["simulate", TRACE, "--grid", "8", "--threshold", "0.1"]) == 2
    assert "--grid, --threshold set how a scene is traced" in capsys.readouterr().err


def test_unknown_model_exit_2(capsys):
    with pytest.raises(SystemExit) as e:
        main(["simulate", TRACE, "--model", "Q"])
    assert e.value.code == 2 and "invalid choice: 'Q'" in capsys.readouterr().err


def test_outputs_checked_before_any_work(tmp_path, capsys):
    """Bad output or input locations are usage errors (exit 2), found before any tracing."""
    assert main(["simulate", "tetra:1", "--res", "8x8", "--json", str(tmp_path / "no" / "r.json")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "--json" in err and "does not exist" in err
    (tmp_path / "d.png").mkdir()
    assert main(["simulate", TRACE, "--plot", str(tmp_path / "d.png")]) == 2
    assert "is a directory" in capsys.readouterr().err
    assert main(["simulate", TRACE, "--plot", str(tmp_path / "p.jpg")]) == 2
    assert "ending in .png" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "missing.npz")]) == 2
    assert "missing.npz: no such file" in capsys.readouterr().err


def test_threshold_with_spd_rules_refused(capsys):
    """--threshold under spd rules would be ignored: refused (exit 2) instead."""
    assert main(["simulate", "tetra:1", "--res", "8x8", "--rules", "spd", "--threshold", "0.1"]) == 2
    assert "paper and paper1992 rules only" in capsys.readouterr().err


def test_deadlock_exit_1(tmp_path, capsys):
    cfg = tmp_path / "tight.toml"
    cfg.write_text('base = "3mppe"\nwindow = 64\n')
    assert main(["simulate", TRACE.replace("tetra-g4", "balls-g9"), "--config", str(cfg)]) == 1
    err = capsys.readouterr().err
    assert "deadlock: the machine stopped with" in err and "receive FIFO" in err
