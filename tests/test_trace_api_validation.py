"""A Trace built in memory is validated by the Python API (``tracevalid.check_trace``) before the
cost model or an engine reads it: records that ``stats --check`` rejects in a file get the same
one-line TraceError through ``simulate``, ``System``, ``Compiled``, ``replay``, ``costs_for``
and ``evaluate`` (issue 19).  (``CostModel.visit_costs`` keeps its own checks, ``cannot cost
this trace: ...``, and its other record layouts: tests/test_cost_fast.py.)"""
import functools
import json

import numpy as np
import pytest

import mprt
from mprt import tracefile, tracevalid
from mprt.fidelity import evaluate
from mprt.fidelity.compiled import Compiled, costs_for, replay
from mprt.machine import System, builtin, simulate


@functools.cache
def source():
    return mprt.Scene.spd("balls", 1).grid(5).trace(12, 10, tile=4)[1]


def damaged(member, field, index, value):
    """A Trace in memory, a copy of the source with one value changed."""
    t = source()
    arrays = {k: np.array(v) for k, v in t.arrays().items()}
    if field is None:
        arrays[member][index] = value
    else:
        arrays[member][field][index] = value
    return mprt.Trace(json.loads(json.dumps(t.meta)), **arrays)


def file_error(tmp_path, trace):
    """The message ``load_trace`` (as ``stats --check``) gives for the same records in a file,
    without the file's name."""
    path = tmp_path / "t.npz"
    tracefile.write(path, trace.meta, trace.arrays())
    with pytest.raises(mprt.TraceError) as e:
        mprt.load_trace(path, invariants=True)
    return str(e.value).split(": ", 1)[1]


ENTRY_POINTS = {
    "simulate": lambda t: simulate(t, "M"),
    "System": lambda t: System(t, builtin("M")),
    "replay": lambda t: replay(t, "M"),
    "Compiled": lambda t: Compiled(t, costs_for(source(), builtin("M"))),
    "costs_for": lambda t: costs_for(t, builtin("M")),
    "evaluate": lambda t: evaluate(t, "3mppe", 3),
}

BAD = [("visits", "ray", 3, 1 << 62), ("visits", "stage", 3, 7), ("rays", "kind", 2, 9),
       ("prim_kind", None, 0, 99), ("prim_kind", None, 0, -1)]


@pytest.mark.parametrize("member, field, index, value", BAD)
def test_in_memory_records_get_the_file_readers_error(tmp_path, member, field, index, value):
    tr = damaged(member, field, index, value)
    want = file_error(tmp_path, tr)
    assert (field or member) in want and str(value) in want
    for name, call in ENTRY_POINTS.items():
        with pytest.raises(mprt.TraceError) as e:
            call(tr)
        assert str(e.value) == want, name


def test_arrays_of_the_wrong_dtype_are_named():
    t = source()
    arrays = dict(t.arrays(), rays=np.zeros(4096, np.uint8))
    with pytest.raises(mprt.TraceError, match="rays: has dtype uint8"):
        simulate(mprt.Trace(dict(t.meta), **arrays), "M")
    with pytest.raises(mprt.TraceError, match="visits: has shape"):
        replay(mprt.Trace(dict(t.meta), **dict(t.arrays(), visits=t.visits.reshape(2, -1))), "M")


def test_meta_is_checked_too():
    t = source()
    with pytest.raises(mprt.TraceError, match="meta.json field 'lights'"):
        simulate(mprt.Trace(dict(t.meta, lights=10 ** 15), **t.arrays()), "M")


def test_checked_once_per_set_of_arrays(monkeypatch):
    """A valid trace is checked once; replacing an array checks it again."""
    t = damaged("visits", "steps", 0, 0)
    calls = []
    real = tracevalid.check_arrays
    monkeypatch.setattr(tracevalid, "check_arrays", lambda *a, **k: (calls.append(1), real(*a, **k))[1])
    a = simulate(t, "M").cycles
    b = replay(t, "M").cycles
    assert a == b and len(calls) == 1
    bad = np.array(t.visits)
    bad["stage"][3] = 7
    t.visits = bad
    with pytest.raises(mprt.TraceError, match="visits field 'stage'"):
        replay(t, "M")
    assert len(calls) == 2


def test_a_loaded_trace_is_not_checked_twice(tmp_path, monkeypatch):
    path = tmp_path / "t.npz"
    source().save(path)
    t = mprt.load_trace(path)
    monkeypatch.setattr(tracevalid, "check_arrays", lambda *a, **k: pytest.fail("checked again"))
    assert simulate(t, "M").cycles == replay(t, "M").cycles
