"""Memory estimates before long work (mprt.memory_estimate): simulate, explore and sweep refuse,
exit 2 with one line of figures, what cannot fit the memory available (MPRT_MEMORY_LIMIT here);
a run that fits is not refused; --engine auto falls back to SimPy where the compiled replay
refuses the caches (more than 2^28 entries) and SimPy's estimate fits (issue 19)."""
import os
import zipfile

import numpy as np
import pytest

import mprt
from mprt import memory_estimate as me
from mprt.cli import main
from mprt.explore.memory import check_sweep
from mprt.fidelity import evaluate
from mprt.machine import CacheConfig, ConfigError, GlobalMemoryConfig, LocalMemoryConfig, builtin, simulate
from mprt.trace import IC, LEFT, OS, PRIMARY, RAY_DTYPE, RETURN, TO_IC, VISIT_DTYPE

HERE = os.path.dirname(os.path.abspath(__file__))
GOLDEN = os.path.join(HERE, "data", "golden", "balls-g9.npz")


def refused(capsys, argv, *words):
    """``mprt argv`` exits 2 with one line holding each of words; returns the line."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "needs " in err and " available (" in err, err
    for w in words:
        assert w in err, err
    return err


@pytest.mark.parametrize("text, n", [("123", 123), ("512M", 512 << 20), ("8G", 8 << 30), ("1.5GiB", 3 << 29),
                                     ("2 kB", 2048), ("1T", 1 << 40)])
def test_sizes(text, n):
    assert me.parse_size(text) == n


def test_bad_limit_is_one_line(monkeypatch, capsys):
    monkeypatch.setenv(me.ENV, "lots")
    assert main(["simulate", GOLDEN, "--model", "M"]) == 2
    assert "MPRT_MEMORY_LIMIT='lots'" in capsys.readouterr().err


def test_available_reads_the_override_or_the_machine(monkeypatch):
    monkeypatch.setenv(me.ENV, "3G")
    assert me.available() == (3 << 30, me.ENV)
    monkeypatch.delenv(me.ENV)
    have, source = me.available()
    assert have > 0 and source in ("MemAvailable", "free pages", "unknown")


def test_simulate_refuses_a_trace_on_a_small_limit_with_its_figures(monkeypatch, capsys):
    t = mprt.load_trace(GOLDEN)
    monkeypatch.setenv(me.ENV, "1M")
    err = refused(capsys, ["simulate", GOLDEN, "--model", "M", "--engine", "compiled"], "1.0 MiB available")
    assert f"visits {me.size_text(len(t.visits) * me.VISIT)}" in err
    assert "simulate" not in capsys.readouterr().out       # refused before the replay's output


def header_only(tmp_path, visits: int, rays: int):
    """The golden trace with visits.npy and rays.npy replaced by headers that claim ``visits`` and
    ``rays`` records (an 8192x8192-class trace: its records are never read)."""
    path = tmp_path / "huge.npz"
    with zipfile.ZipFile(GOLDEN) as zi, zipfile.ZipFile(path, "w") as zo:
        for info in zi.infolist():
            name = info.filename
            if name in ("visits.npy", "rays.npy"):
                dt, n = (VISIT_DTYPE, visits) if name == "visits.npy" else (RAY_DTYPE, rays)
                import io
                b = io.BytesIO()
                np.lib.format.write_array_header_2_0(b, {"descr": np.lib.format.dtype_to_descr(dt),
                                                         "fortran_order": False, "shape": (n,)})
                zo.writestr(name, b.getvalue())
            else:
                zo.writestr(info, zi.read(name))
    return path


def test_simulate_refuses_an_8192_class_trace_before_reading_it(tmp_path, monkeypatch, capsys):
    path = header_only(tmp_path, 5 << 30, 320 << 20)       # 75 visits a pixel at 8192x8192
    monkeypatch.setenv(me.ENV, "8G")
    err = refused(capsys, ["simulate", str(path), "--model", "M"], "8.0 GiB available", "visits 240.0 GiB")
    assert "costs" in err and "replay" in err and "reading" not in err     # the copy read is gone by then


def test_simulate_of_a_scene_refuses_the_frame_before_tracing(monkeypatch, capsys):
    monkeypatch.setenv(me.ENV, "4G")
    refused(capsys, ["simulate", "balls:1", "--grid", "4", "--res", "65536x65536", "--model", "M"],
            "needs at least about", "visits 192.0 GiB", "4.0 GiB available")
    assert "traced" not in capsys.readouterr().out


def test_simulate_refuses_many_simpy_processors(tmp_path, monkeypatch, capsys):
    cfg = tmp_path / "wide.toml"
    cfg.write_text('base = "M"\npes = 512\n[[stage]]\nsubtasks = ["OS"]\nreplicas = 256\n[[stage]]\n'
                   'subtasks = ["IC"]\nreplicas = 256\n[[stage]]\nsubtasks = ["SC"]\nreplicas = 256\n')
    monkeypatch.setenv(me.ENV, "1G")
    err = refused(capsys, ["simulate", GOLDEN, "--config", str(cfg), "--engine", "simpy"], "replay 1.5 GiB")
    assert "1.0 GiB available" in err


def test_a_normal_run_is_not_refused(monkeypatch, capsys, tmp_path):
    t = mprt.load_trace(GOLDEN)
    c = me.file_counts(GOLDEN)
    assert (c["visits"], c["rays"], c["prims"]) == (len(t.visits), len(t.rays), len(t.prim_kind))
    e = me.for_replay(c, builtin("3mppe"), "compiled")
    monkeypatch.setenv(me.ENV, str(e.total + (64 << 20)))
    assert main(["simulate", GOLDEN, "--model", "3mppe", "--json", str(tmp_path / "r.json")]) == 0
    monkeypatch.delenv(me.ENV)
    assert main(["simulate", "tetra:1", "--grid", "4", "--res", "12x10", "--model", "M"]) == 0


def test_the_estimate_grows_with_what_it_counts():
    c = me.file_counts(GOLDEN)
    m = builtin("M")
    base = me.for_replay(c, m, "compiled").total
    assert me.for_replay(dict(c, visits=2 * c["visits"]), m, "compiled").total > base
    assert me.for_replay(c, m, "compiled", timeline=True).parts["timeline"] == c["visits"] * me.TIMELINE
    wide = m.replace(pes=256)
    assert me.for_replay(c, wide, "simpy").parts["replay"] - me.for_replay(c, m, "simpy").parts["replay"] == \
        (256 - m.pes) * sum(s.replicas for s in m.stages) * me.SIMPY_PROC


def test_sweep_refuses_a_huge_resolution(tmp_path, monkeypatch, capsys):
    spec = tmp_path / "s.toml"
    spec.write_text('scenes = ["balls:1"]\nres = "65536x65536"\nsubdivisions = [4]\n[designs]\npaper = "3mppe"\n')
    monkeypatch.setenv(me.ENV, "16G")
    refused(capsys, ["sweep", str(spec), "--out", str(tmp_path / "out"), "--workers", "2"],
            "needs at least about", "for 2 workers", "16.0 GiB available")
    assert not os.path.exists(tmp_path / "out" / "sweep.csv")


def test_sweep_estimate_of_a_small_spec_fits():
    spec = {"scenes": ["balls:1"], "width": 32, "height": 32, "subdivisions": [(4,)], "shape": "cube"}
    e = check_sweep(spec, 2)
    assert 0 < e.total < 64 << 20 and e.floor


def test_explore_refuses_a_huge_resolution(monkeypatch, capsys):
    monkeypatch.setenv(me.ENV, "16G")
    # the records a frame makes measured on a small trace of it and scaled: a visit and a ray
    # record each, their costs, and the samples (96 GiB of colours alone)
    refused(capsys, ["explore", "balls:1", "--res", "65536x65536", "--budget", "800", "--workers", "1"],
            "needs about", "for balls:1's 65536x65536 frame", "visits", "16.0 GiB available")


# ---- the compiled replay's cache limit and --engine auto -----------------------------------

def big_cache_trace(n=1024, words=1 << 18):
    """n primaries, one of which visits IC once, reading one primitive of ``words`` words."""
    r = np.zeros(n, RAY_DTYPE)
    r["id"], r["parent"], r["kind"], r["pixel"], r["light"], r["contribution"] = np.arange(n), -1, PRIMARY, \
        np.arange(n), -1, 1.0
    v = np.zeros(n + 2, VISIT_DTYPE)
    v["ray"] = np.r_[0, 0, np.arange(n)]
    v["stage"] = np.r_[OS, IC, np.full(n, OS)]
    v["outcome"] = np.r_[TO_IC, RETURN, np.full(n, LEFT)]
    v["voxel_id"] = np.r_[-1, 0, np.full(n, -1)]
    v["prim"] = -1
    v["tests"][1] = 1
    side = int(np.sqrt(n))
    arrays = {"rays": r, "visits": v, "voxel_start": np.array([0, 1], np.uint32), "voxel_ids": np.zeros(1, np.int32),
              "prim_kind": np.zeros(1, np.int32), "prim_words": np.array([words], np.int32),
              "prim_material": np.zeros(1, np.int32), "samples": np.zeros((side, side, 3))}
    meta = {"scene": "big cache", "grid": [1, 1, 1], "width": side, "height": side, "samples_w": side,
            "samples_h": side, "rules": "paper", "threshold": 0.0, "lights": 1, "tiles": [0], "tiles_total": 1}
    return mprt.Trace.from_arrays(meta, arrays)


BIG = dict(ic_memory=LocalMemoryConfig(0, CacheConfig(1 << 21, 4, 1)), icgm=GlobalMemoryConfig(1, 4, False))
BIG_TOML = ('base = "M"\npes = 1024\n[ic_memory]\nresident = 0\ncache = { size = 2097152, line = 4, ways = 1 }\n'
            '[icgm]\nlatency = 1\nbandwidth = 4\ncontention = false\n')


def test_auto_falls_back_to_simpy_past_the_compiled_cache_limit():
    tr = big_cache_trace()
    cfg = builtin("M").replace(pes=1024, **BIG)          # 1024 PEs x 262146 entries > 2^28
    with pytest.raises(ConfigError, match=r"more than 2\^28"):
        evaluate(tr, cfg, 3, engine="compiled")
    e = evaluate(tr, cfg, 3)
    assert e.engine == "simpy" and e.cycles == simulate(tr, cfg).cycles
    half = cfg.replace(pes=512)                          # under the limit: both engines, the same cycles
    assert evaluate(tr, half, 3).engine == "compiled"
    assert evaluate(tr, half, 3).cycles == evaluate(tr, half, 3, engine="simpy").cycles


def test_auto_refuses_past_the_limit_when_simpy_cannot_hold_it(monkeypatch):
    monkeypatch.setenv(me.ENV, "10M")
    with pytest.raises(ConfigError) as e:
        evaluate(big_cache_trace(), builtin("M").replace(pes=1024, **BIG), 3)
    msg = str(e.value)
    assert "2^28" in msg and "SimPy model would need about" in msg and "10.0 MiB available" in msg and "\n" not in msg


def test_simulate_cli_falls_back_or_refuses(tmp_path, monkeypatch, capsys):
    path, cfg = tmp_path / "big.npz", tmp_path / "big.toml"
    big_cache_trace().save(path)
    cfg.write_text(BIG_TOML)
    monkeypatch.setenv(me.ENV, "64G")     # SimPy's estimate fits whatever this machine has free now
    assert main(["simulate", str(path), "--config", str(cfg)]) == 0
    assert "on the simpy engine" in capsys.readouterr().out
    assert main(["simulate", str(path), "--config", str(cfg), "--engine", "compiled"]) == 2
    assert "2^28" in capsys.readouterr().err
    monkeypatch.setenv(me.ENV, "10M")
    assert main(["simulate", str(path), "--config", str(cfg)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "needs about" in err and "caches" in err, err


def test_huge_caches_are_counted(tmp_path, monkeypatch, capsys):
    """512 PEs x 262146 entries: under the compiled replay's 2^28, but 2 GiB of cache arrays."""
    path, cfg = tmp_path / "big.npz", tmp_path / "half.toml"
    big_cache_trace().save(path)
    cfg.write_text(BIG_TOML.replace("pes = 1024", "pes = 512"))
    monkeypatch.setenv(me.ENV, "1G")
    refused(capsys, ["simulate", str(path), "--config", str(cfg), "--engine", "compiled"], "caches 2.0 GiB",
            "1.0 GiB available")


@pytest.mark.parametrize("field, text", [("replicas", "[[stage]]\nsubtasks = ['OS', 'IC', 'SC']\nreplicas = 1000000\n"),
                                         ("size", "[ic_memory]\ncache = { size = 1152921504606846976, line = 32, "
                                                  "ways = 4 }\n[icgm]\nlatency = 1\nbandwidth = 8\n")])
def test_replicas_and_cache_sizes_beyond_the_bounds_are_refused_first(tmp_path, capsys, field, text):
    cfg = tmp_path / "c.toml"
    cfg.write_text('base = "M"\n' + text)
    assert main(["simulate", GOLDEN, "--config", str(cfg)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and field in err and "at most" in err, err


@pytest.mark.parametrize("engine", ["compiled", "simpy"])
def test_a_huge_cache_on_a_small_trace_is_not_refused(tmp_path, monkeypatch, engine):
    """Both engines size a cache by the data it can hold, and so does the estimate."""
    cfg = tmp_path / "c.toml"
    cfg.write_text('base = "3mppe"\npes = 8\n[ic_memory]\nresident = 0\n'
                   'cache = { size = 1099511627776, line = 32, ways = 4 }\n')
    monkeypatch.setenv(me.ENV, "1G")
    assert main(["simulate", GOLDEN, "--config", str(cfg), "--engine", engine]) == 0
