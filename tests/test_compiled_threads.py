"""The compiled replay's priced loading on two threads (``mprt_replay_load_priced_threads``: the
visits priced on a thread of their own, blocks ahead of the loading) against one thread: the
same replay at every level, the same flits, and the same error where a trace cannot be priced
or loaded, wherever in the visits the fault lies (the second half, a later block, a fault of
the loading before a fault of the pricing in the same block)."""
import numpy as np
import pytest

import mprt
from mprt._lowlevel import binding
from mprt.errors import InvalidArgument
from mprt.fidelity import Compiled, at_level
from mprt.fidelity import compiled as compiled_mod
from mprt.fidelity.compiled import priced_for
from mprt.machine import builtin
from mprt.trace import SC

from test_fidelity import same

LIB = binding("double")
BLOCK = 16 * 4096           # replay_load.c's PIPE_BLOCK: traces of two blocks or more are piped


@pytest.fixture(scope="module")
def trace():
    scene = mprt.Scene.spd("balls", size=1)
    grid = scene.grid(16)       # (the scene kept while its grid lives)
    _, t = grid.trace(64, 64)
    del grid, scene
    assert len(t.visits) >= 3 * BLOCK        # piped, over several blocks
    return t


def load(trace, threads, visits=None, prim_kind=None, dtype=np.int32):
    """(flits, the load's error message or None) of a priced load with this many threads."""
    cfg = at_level(builtin("3mppe"), 2)
    p = priced_for(trace, cfg)
    rec = p.records
    v = np.asarray(trace.visits) if visits is None else visits
    flits = np.zeros(len(v), dtype)
    h = LIB.replay_create({})
    try:
        LIB.replay_load_priced(h, np.asarray(trace.rays), v, p.table, rec.children,
                               rec.prim_kind if prim_kind is None else prim_kind, flits, threads=threads)
    except InvalidArgument as e:
        return flits, str(e)
    return flits, None


@pytest.mark.parametrize("model, level", [("M", 1), ("3mppe", 1), ("3mppe", 2), ("3mppe", 3)])
def test_two_threads_replay_as_one(trace, monkeypatch, model, level):
    cfg = at_level(builtin(model), level)
    got = {}
    for threads in ("1", "2"):
        monkeypatch.setenv(compiled_mod.THREADS_ENV, threads)
        assert compiled_mod.load_threads() == int(threads)
        c = Compiled(trace, priced_for(trace, cfg))
        got[threads] = (c.result(cfg), np.array(c.admissions()))
    assert same(got["1"][0], got["2"][0]) and np.array_equal(got["1"][1], got["2"][1])


def test_two_threads_give_the_same_flits(trace):
    """The same flits, as int64 (what the ring's replay takes: the loading widens them) or int32,
    as the cost pass's own."""
    from mprt.fidelity.compiled import costs_for

    want = costs_for(trace, at_level(builtin("3mppe"), 2)).flits
    for dtype in (np.int64, np.int32):
        one, e1 = load(trace, 1, dtype=dtype)
        two, e2 = load(trace, 2, dtype=dtype)
        assert e1 is None and e2 is None and np.array_equal(one, two) and np.array_equal(one, want)
    cfg = at_level(builtin("3mppe"), 2)
    p = priced_for(trace, cfg)
    Compiled(trace, p)
    assert p.flits.dtype == np.int64 and np.array_equal(p.flits, want)


def _hit_visits(v):
    return np.flatnonzero(v["prim"] >= 0)


@pytest.mark.parametrize("where", [0.55, 0.9, 1.0])
def test_a_visit_the_pricing_refuses_late_is_the_same_error(trace, where):
    """A primitive the pricing does not know, in the second half (and the last hit): the same
    message, naming the same visit, with one thread or two."""
    v = np.array(trace.visits)
    hits = _hit_visits(v)
    at = int(hits[min(int(where * len(hits)), len(hits) - 1)])
    v["prim"][at] = 1 << 30
    _, e1 = load(trace, 1, v)
    _, e2 = load(trace, 2, v)
    assert e1 == e2 == f"cannot cost this trace: visit {at}: primitive {1 << 30} is not a primitive of the trace"


def test_a_fault_of_the_loading_before_one_of_the_pricing_in_the_same_block(trace):
    """The loading's fault comes first, as with one thread, though the pricing's thread met its
    own fault later in the same block before the loading got there."""
    v = np.array(trace.visits)
    sc = np.flatnonzero((v["stage"] == SC) & (v["made"] > 0))
    first = int(sc[np.searchsorted(sc, 2 * BLOCK + 10)])        # in the third block
    v["made"][first] += 1                                       # made differs from its children
    hits = _hit_visits(v)
    later = int(hits[np.searchsorted(hits, first + 5000)])      # a later sub-chunk, same block
    assert later // BLOCK == first // BLOCK
    v["prim"][later] = 1 << 30
    _, e1 = load(trace, 1, v)
    _, e2 = load(trace, 2, v)
    assert e1 == e2 and f"visit {first} made" in e1
    v["made"][first] -= 1           # the loading's fault gone: the pricing's, in both
    _, e1 = load(trace, 1, v)
    _, e2 = load(trace, 2, v)
    assert e1 == e2 and f"visit {later}: primitive" in e1


def test_an_unknown_primitive_kind_table_fails_alike(trace):
    """Every primitive unknown to the pricing: the first hit is named either way."""
    empty = np.zeros(0, np.int32)
    _, e1 = load(trace, 1, prim_kind=empty)
    _, e2 = load(trace, 2, prim_kind=empty)
    hit = int(_hit_visits(np.asarray(trace.visits))[0])
    assert e1 == e2 and f"visit {hit}: primitive" in e1
