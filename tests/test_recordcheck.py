"""The records' one-pass check in C (mprt.recordcheck, c/src/tracecheck.c) against the Python
checkers it stands in for (tracevalid's ranges, tracecheck's invariants): on crafted bad
traces, each rule broken alone, and on random edits, C finds a fault exactly when Python does,
and a reader reports the Python checkers' message, word for word."""
import dataclasses
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mprt import Outcome, RayKind, Stage, TraceError, load_trace, recordcheck, tracecheck, tracefile, tracevalid

GOLDEN = Path(__file__).parent / "data" / "golden"


def golden(name="balls-g4"):
    tr = load_trace(GOLDEN / f"{name}.npz", mmap=False)
    return tr.meta, {k: np.array(v) for k, v in tr.arrays().items()}


def python_message(meta, arrays):
    """What the Python checkers alone say: ranges, then invariants (None: sound)."""
    try:
        tracevalid._record_ranges(meta, arrays, tracevalid.CHUNK)
        tracecheck.check(SimpleNamespace(rays=arrays["rays"], visits=arrays["visits"]))
    except TraceError as e:
        return str(e)
    return None


def fused_message(meta, arrays):
    """What a reader says now: the C pass, the Python checkers naming what it found."""
    try:
        found = tracevalid.check_arrays(meta, arrays, invariants=True)
        tracecheck.settle(SimpleNamespace(rays=arrays["rays"], visits=arrays["visits"]), found)
    except TraceError as e:
        return str(e)
    return None


def c_fault(meta, arrays, invariants=True, chunk=recordcheck.CHUNK):
    return recordcheck.check(recordcheck.limits(meta, arrays, invariants), arrays["rays"], arrays["visits"],
                             chunk)[0]


# -- the crafted faults: each edits a golden trace so that one rule breaks -------------------------
def _first(v, stage, outcome=None):
    m = v["stage"] == stage
    if outcome is not None:
        m &= v["outcome"] == outcome
    return int(np.flatnonzero(m)[0])


def _child(r, depth_at_least=0):
    return int(np.flatnonzero((r["parent"] >= 0) & (r["depth"] >= depth_at_least))[0])


def swap_os_ic(meta, a):
    v = a["visits"]
    i = _first(v, Stage.IC)
    v[[i - 1, i]] = v[[i, i - 1]]


def drop_shaded(meta, a):
    a["visits"] = np.delete(a["visits"], _first(a["visits"], Stage.SC, Outcome.SHADED))


def made_plus(meta, a):
    a["visits"]["made"][_first(a["visits"], Stage.SC, Outcome.SHADED)] += 1


def made_minus(meta, a):
    v = a["visits"]
    i = int(np.flatnonzero((v["stage"] == Stage.SC) & (v["made"] > 0))[0])
    v["made"][i] -= 1


def split_run(meta, a):
    v = a["visits"]
    ends = np.flatnonzero(v["ray"][1:-1] != v["ray"][2:]) + 1       # last visit of a ray, not the first
    i = int(ends[(v["ray"][ends - 1] == v["ray"][ends])][0])
    v[[i, i + 1]] = v[[i + 1, i]]


def os_left_midway(meta, a):
    v = a["visits"]
    i = int(np.flatnonzero((v["stage"] == Stage.OS) & (v["outcome"] == Outcome.TO_IC))[0])
    v["outcome"][i] = Outcome.LEFT


def ends_to_ic(meta, a):
    v = a["visits"]
    last = np.flatnonzero(np.append(v["ray"][1:] != v["ray"][:-1], True))
    i = int(last[(v["stage"][last] == Stage.OS) & (v["outcome"][last] == Outcome.LEFT)][0])
    v["outcome"][i] = Outcome.TO_IC


def shadow_to_reflect(meta, a):
    r = a["rays"]
    r["kind"][int(np.flatnonzero(r["kind"] == RayKind.SHADOW)[0])] = RayKind.REFLECT


def reflect_to_shadow(meta, a):
    r = a["rays"]
    r["kind"][int(np.flatnonzero(r["kind"] == RayKind.REFLECT)[0])] = RayKind.SHADOW


def primary_with_parent(meta, a):
    a["rays"]["parent"][int(np.flatnonzero(a["rays"]["kind"] == RayKind.PRIMARY)[1])] = 0


def orphan_child(meta, a):
    a["rays"]["parent"][_child(a["rays"])] = -1


def parent_later(meta, a):
    r = a["rays"]
    c = _child(r)
    r["parent"][c] = len(r) - 1


def shallower(meta, a):
    r = a["rays"]
    c = _child(r, 1)
    r["depth"][c] = r["depth"][r["parent"][c]] - 1


def other_pixel(meta, a):
    r = a["rays"]
    c = _child(r)
    r["pixel"][c] = (r["pixel"][c] + 1) % (meta["samples_w"] * meta["samples_h"])


def os_with_tests(meta, a):
    a["visits"]["tests"][_first(a["visits"], Stage.OS), 0] = 1


def steps_in_ic(meta, a):
    a["visits"]["steps"][_first(a["visits"], Stage.IC)] = 1


def no_visits_last_ray(meta, a):
    v = a["visits"]
    a["visits"] = v[v["ray"] != len(a["rays"]) - 1]


def no_visits_at_all(meta, a):
    a["visits"] = a["visits"][:0]


INVARIANTS = [swap_os_ic, drop_shaded, made_plus, made_minus, split_run, os_left_midway, ends_to_ic,
              shadow_to_reflect, reflect_to_shadow, primary_with_parent, orphan_child, parent_later, shallower,
              other_pixel, os_with_tests, steps_in_ic, no_visits_last_ray, no_visits_at_all]


def _set(member, field, index, value):
    def edit(meta, a):
        a[member][field][index] = value(meta, a) if callable(value) else value
    edit.__name__ = f"{member}.{field}[{index}]"
    return edit


RANGES = [_set("rays", "id", 3, 7), _set("rays", "parent", 5, lambda m, a: len(a["rays"])),
          _set("rays", "pixel", 2, -1), _set("rays", "light", 4, lambda m, a: m["lights"]),
          _set("rays", "kind", 6, 4), _set("rays", "depth", 1, 255), _set("rays", "contribution", 9, np.nan),
          _set("visits", "ray", 11, lambda m, a: len(a["rays"])), _set("visits", "voxel_id", 3, -2),
          _set("visits", "prim", 8, lambda m, a: len(a["prim_kind"])), _set("visits", "steps", 2, -1),
          _set("visits", "tests", (5, 2), -1), _set("visits", "vertices", 4, -1), _set("visits", "stage", 7, 3),
          _set("visits", "outcome", 12, 9), _set("visits", "made", 13, 200), _set("visits", "suppressed", 1, 200)]


@pytest.mark.parametrize("name", ["balls-g4", "tetra-g9", "gears-g4", "rings-g9"])
def test_sound_traces_pass_in_c(name):
    meta, a = golden(name)
    assert c_fault(meta, a, True) == c_fault(meta, a, False) == recordcheck.SOUND
    assert c_fault(meta, a, True, chunk=7) == recordcheck.SOUND       # chunk edges inside rays' runs


@pytest.mark.parametrize("edit", INVARIANTS, ids=lambda f: f.__name__)
def test_each_broken_invariant_gives_the_python_message(edit):
    meta, a = golden()
    edit(meta, a)
    want = python_message(meta, a)
    assert want is not None and want.startswith("trace invariant broken:")
    assert c_fault(meta, a) == recordcheck.INVARIANT
    assert c_fault(meta, a, chunk=5) == recordcheck.INVARIANT
    assert c_fault(meta, a, invariants=False) == recordcheck.SOUND      # in range: ranges alone pass
    assert fused_message(meta, a) == want
    assert tracevalid.check_arrays(meta, a) is None                      # ranges only: no error, not checked


@pytest.mark.parametrize("edit", RANGES, ids=lambda f: f.__name__)
def test_each_range_fault_gives_the_python_message(edit):
    meta, a = golden()
    edit(meta, a)
    want = python_message(meta, a)
    assert want is not None and want.startswith(("rays field", "visits field"))
    assert c_fault(meta, a) == c_fault(meta, a, invariants=False) == recordcheck.RANGE
    assert fused_message(meta, a) == want
    with pytest.raises(TraceError) as e:
        tracevalid.check_arrays(meta, a)
    assert str(e.value) == want


def test_random_edits_c_and_python_agree():
    """Random single-field edits (ranges kept mostly valid, so invariants are what break): C finds
    a fault exactly when the Python checkers do, and the message is theirs."""
    meta, base = golden("tetra-g4")
    rng = np.random.default_rng(18)
    n, nv = len(base["rays"]), len(base["visits"])
    fields = [("visits", "ray", lambda: rng.integers(0, n)), ("visits", "stage", lambda: rng.integers(0, 3)),
              ("visits", "outcome", lambda: rng.integers(0, 9)), ("visits", "made", lambda: rng.integers(0, 4)),
              ("visits", "steps", lambda: rng.integers(0, 3)), ("rays", "parent", lambda: rng.integers(-1, n)),
              ("rays", "kind", lambda: rng.integers(0, 4)), ("rays", "depth", lambda: rng.integers(0, 6))]
    faults = 0
    for _ in range(150):
        a = {k: v.copy() for k, v in base.items()}
        member, field, value = fields[rng.integers(len(fields))]
        a[member][field][rng.integers(0, nv if member == "visits" else n)] = value()
        want = python_message(meta, a)
        assert (c_fault(meta, a) != recordcheck.SOUND) == (want is not None), (member, field, want)
        assert fused_message(meta, a) == want
        faults += want is not None
    assert faults > 50


def test_trace_validate_and_check_name_the_same_fault():
    meta, a = golden()
    tr = load_trace(GOLDEN / "balls-g4.npz")
    v = tr.visits.copy()
    v["made"][_first(v, Stage.SC, Outcome.SHADED)] += 1
    bad = dataclasses.replace(tr, visits=v)
    with pytest.raises(TraceError) as e:
        bad.check()
    with pytest.raises(TraceError) as py:
        tracecheck.check(bad)
    assert str(e.value) == str(py.value)


def _stored_copy(tmp_path, edit=None):
    tr = load_trace(GOLDEN / "balls-g4.npz", mmap=False)
    if edit is not None:
        arrays = {k: np.array(v) for k, v in tr.arrays().items()}
        edit(tr.meta, arrays)
        tr = dataclasses.replace(tr, **arrays)
    p = tmp_path / "t.npz"
    tr.save(p, compress=False)
    return p


@pytest.mark.parametrize("background", [False, True])
def test_load_names_a_broken_invariant_without_the_path(tmp_path, monkeypatch, background):
    """load_trace(invariants=True): the invariants in the same pass, named as tracecheck names them
    (no file prefix, as before), with the checksums computed on a thread or not."""
    if background:
        monkeypatch.setattr(tracefile, "BACKGROUND_CRC", 0)
    p = _stored_copy(tmp_path, made_plus)
    meta, a = golden()
    made_plus(meta, a)
    with pytest.raises(TraceError) as e:
        load_trace(p, mmap=True, invariants=True)
    assert str(e.value) == python_message(meta, a)
    load_trace(p, mmap=True)            # without the invariants: it loads


@pytest.mark.parametrize("background", [False, True])
def test_a_checksum_fault_comes_before_a_range_fault(tmp_path, monkeypatch, background):
    """A record edited out of range after the file was written: the checksum names it first,
    whether computed in order or on a thread while the records are checked."""
    if background:
        monkeypatch.setattr(tracefile, "BACKGROUND_CRC", 0)
    p = _stored_copy(tmp_path)
    tr = load_trace(p, mmap=True)
    off = tr.visits.offset + 7 * tr.visits.dtype.itemsize + tr.visits.dtype.fields["stage"][1]
    del tr
    with open(p, "r+b") as f:
        f.seek(off)
        f.write(b"\x09")
    with pytest.raises(TraceError, match="array 'visits' does not match its checksum"):
        load_trace(p, mmap=True, invariants=True)
    with pytest.raises(TraceError, match="visits field 'stage': record 7 holds 9"):
        load_trace(p, mmap=True, verify=False)
