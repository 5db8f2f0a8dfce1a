"""``mprt simulate``'s passes over the visits cut down: level 3's memory keys made while the
records are checked (recordcheck.check's ``keys``, c/src/tracecheck.c) equal the keys of their
own pass (mprt_visit_keys), are left out wherever that pass would refuse them or the records
fail, and the command's answer does not move."""
import json
from pathlib import Path

import numpy as np
import pytest

from mprt import load_trace, recordcheck, tracevalid
from mprt._lowlevel import binding
from mprt.fidelity.memdata import MemoryData

GOLDEN = Path(__file__).parent / "data" / "golden"
NAMES = ("balls-g4", "balls-g9", "gears-g4", "gears-g9")


def arrays_of(name):
    tr = load_trace(GOLDEN / f"{name}.npz", mmap=False)
    return tr, tr.meta, {k: np.array(v) for k, v in tr.arrays().items()}


def own_pass(arrays, meta):
    mat = np.asarray(arrays["prim_material"], np.int64)
    nvox = meta["grid"][0] * meta["grid"][1] * meta["grid"][2]
    return binding("double").visit_keys(arrays["visits"], mat, nvox, int(mat.max()) + 1)


def fused(meta, arrays, chunk=recordcheck.CHUNK, invariants=True, mat=None):
    nvox = meta["grid"][0] * meta["grid"][1] * meta["grid"][2]
    want = recordcheck.memory_keys(arrays["prim_material"] if mat is None else mat, nvox)
    rc, _ = recordcheck.check(recordcheck.limits(meta, arrays, invariants), arrays["rays"], arrays["visits"], chunk,
                              keys=want)
    return rc, want


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("chunk", [1, 977, recordcheck.CHUNK])
def test_keys_made_in_the_check_equal_their_own_pass(name, chunk):
    _, meta, a = arrays_of(name)
    rc, got = fused(meta, a, chunk)
    keys, vref, mref = own_pass(a, meta)
    assert rc == recordcheck.SOUND
    assert got["keys"].dtype == np.int32 and got["voxel_refs"].dtype == np.int64
    assert np.array_equal(got["keys"], keys) and np.array_equal(got["voxel_refs"], vref)
    assert np.array_equal(got["material_refs"], mref)
    assert (keys >= 0).any() and (keys <= -2).any()       # both memories' keys are there


@pytest.mark.parametrize("invariants", [False, True])
def test_no_keys_from_records_that_fail(invariants):
    _, meta, a = arrays_of("balls-g4")
    a["visits"]["voxel_id"][len(a["visits"]) - 3] = 1 << 40          # a range fault near the end
    rc, got = fused(meta, a, chunk=1000, invariants=invariants)
    assert rc == recordcheck.RANGE and "keys" not in got
    _, meta, a = arrays_of("balls-g4")
    v = a["visits"]
    i = int(np.flatnonzero((v["stage"] == 2) & (v["made"] > 0))[-1])   # an invariant broken: made
    v["made"][i] -= 1
    rc, got = fused(meta, a, invariants=True)
    assert rc == recordcheck.INVARIANT and "keys" not in got


def test_a_key_their_own_pass_refuses_is_left_to_it():
    """A material the keys cannot hold: the check still passes, the keys are left out, and
    their own pass names the visit (what MemoryData then says)."""
    _, meta, a = arrays_of("gears-g4")
    mat = np.asarray(a["prim_material"], np.int64).copy()
    v = a["visits"]
    sc = v[(v["stage"] == 2) & (v["prim"] >= 0)]
    mat[int(sc["prim"][len(sc) // 2])] = -5
    rc, got = fused(meta, a, mat=mat)
    assert rc == recordcheck.SOUND and "keys" not in got
    with pytest.raises(ValueError, match="memory keys: visit"):
        binding("double").visit_keys(v, mat, len(a["voxel_start"]) - 1, int(mat.max()) + 1)


def test_load_trace_keeps_the_keys_and_memory_data_takes_them():
    path = GOLDEN / "gears-g9.npz"
    tr = load_trace(path, invariants=True, memory_keys=True)
    plain = load_trace(path, invariants=True)
    assert getattr(plain, "memory_keys", None) is None
    md = MemoryData(tr)
    assert md.keys is tr.memory_keys[0]
    fresh = MemoryData(plain)
    assert np.array_equal(md.keys, fresh.keys)
    assert np.array_equal(md.layout.voxel_refs, fresh.layout.voxel_refs)
    assert np.array_equal(md.layout.material_refs, fresh.layout.material_refs)
    for tag in ("ic", "sc"):
        a, b = md.get(tag, 256, 32)[0], fresh.get(tag, 256, 32)[0]
        assert all(np.array_equal(a[k], b[k]) for k in ("items", "resident", "line_start", "lines"))


def test_check_arrays_fills_the_keys_only_when_asked():
    _, meta, a = arrays_of("balls-g9")
    keys = {}
    assert tracevalid.check_arrays(meta, a, invariants=True, keys=keys) == ""
    assert np.array_equal(keys["keys"], own_pass(a, meta)[0])


@pytest.mark.parametrize("level", ["1", "3"])
def test_simulate_answers_alike_with_keys_made_apart(tmp_path, monkeypatch, level):
    """The whole command's JSON (but its times) with the keys made in the check and in a pass
    of their own."""
    from mprt.fidelity.cli import main
    from mprt.machine import cli as machine_cli

    def run(name):
        out = tmp_path / f"{name}.json"
        assert main(["simulate", str(GOLDEN / "balls-g9.npz"), "--engine", "compiled", "--model", "3mppe",
                     "--pes", "2", "--level", level, "--json", str(out)]) == 0
        d = json.loads(out.read_text())
        for k in ("wall_seconds", "replay_seconds"):
            d.pop(k)
        return d

    asked = []
    wants = machine_cli._wants_memory_keys
    monkeypatch.setattr(machine_cli, "_wants_memory_keys", lambda a: asked.append(wants(a)) or asked[-1])
    made = run("fused")
    assert asked == [level == "3"]          # level 3 reads the keys: made in the check
    monkeypatch.setattr(machine_cli, "_wants_memory_keys", lambda a: False)
    assert run("apart") == made
    assert made["level"] == int(level) and made["cycles"] > 0


def test_the_cost_table_is_made_on_a_thread_while_the_trace_is_read(tmp_path, monkeypatch):
    """The kernels' schedules for the run's processors are made while the records are checked
    (a thread of their own, joined before the trace is used); the answer is the same without."""
    import threading

    from mprt.cost import CostModel, model
    from mprt.fidelity import cli as fcli
    from mprt.fidelity.cli import main

    where = []
    table = CostModel.cost_table
    monkeypatch.setattr(CostModel, "cost_table",
                        lambda self, procs: where.append(threading.current_thread().name) or table(self, procs))

    def run(name):
        model._cycles.cache_clear()
        out = tmp_path / f"{name}.json"
        assert main(["simulate", str(GOLDEN / "gears-g9.npz"), "--engine", "compiled", "--model", "3mppe",
                     "--level", "3", "--json", str(out)]) == 0
        d = json.loads(out.read_text())
        for k in ("wall_seconds", "replay_seconds"):
            d.pop(k)
        return d

    warm = run("warm")
    assert where[0] == "mprt-warm-costs"
    assert not any(t.name == "mprt-warm-costs" for t in threading.enumerate())     # joined
    where.clear()
    monkeypatch.setattr(fcli, "_warm_cost_model", lambda a: None)
    assert run("cold") == warm and "mprt-warm-costs" not in where


def test_simulate_parses_as_before_without_the_explorer():
    """``mprt simulate`` builds the parser without the explorer's commands (nor their imports):
    its options, help and errors are those of the whole parser's."""
    import subprocess
    import sys

    from mprt import cli

    def sim(p):
        return p._subparsers._group_actions[0].choices["simulate"]

    whole, lean = cli.build_parser(), cli.build_parser(only="simulate")
    assert "explore" in whole._subparsers._group_actions[0].choices
    assert "explore" not in lean._subparsers._group_actions[0].choices
    assert sim(whole).format_help() == sim(lean).format_help()
    argv = ["simulate", str(GOLDEN / "balls-g4.npz"), "--engine", "compiled", "--level", "1"]
    assert vars(whole.parse_args(argv)).keys() == vars(lean.parse_args(argv)).keys()
    code = ("import sys; from mprt.cli import main; rc = main(%r); "
            "print(rc, any(m.startswith('mprt.explore') for m in sys.modules))" % argv)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.splitlines()[-1] == "0 False"
