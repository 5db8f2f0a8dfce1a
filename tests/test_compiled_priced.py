"""The compiled replay's visits priced in C as they load (``mprt_replay_load_priced``,
``cost.fast.Priced``) against the replay of the cost model's arrays: the same SimResult, every
figure, at every level (the ring's flits computed when first asked for), the same deadlock; a
cost model other than the default's arithmetic keeps its arrays."""
import numpy as np
import pytest

import mprt
from mprt.cost import CostModel
from mprt.cost.fast import Priced
from mprt.fidelity import Compiled, at_level
from mprt.fidelity.compiled import costs_for, priced_for
from mprt.fidelity.levels import Evaluator
from mprt.machine import DeadlockError, builtin, load_config
from mprt.machine.config import RingConfig

from test_fidelity import FULL, GOLDEN, NAMES, same

CONFIGS = [("M", 1), ("3mppe", 1), ("3mppe", 2), ("3mppe", 3), ("full", 3), ("full", 2)]


def config(name, level):
    cfg = load_config(FULL) if name == "full" else builtin(name)
    return at_level(cfg, level)


@pytest.mark.parametrize("name", NAMES)
def test_priced_loading_equals_the_arrays_on_every_golden_trace(name):
    trace = mprt.load_trace(GOLDEN[NAMES.index(name)])
    for cname, level in CONFIGS:
        cfg = config(cname, level)
        priced = priced_for(trace, cfg)
        assert isinstance(priced, Priced)
        a = Compiled(trace, costs_for(trace, cfg)).result(cfg)
        b = Compiled(trace, priced).result(cfg)
        assert same(a, b), (cname, level)


@pytest.mark.parametrize("name", ["gears-g4", "mount-g9"])
def test_memory_mapped_records_at_unaligned_offsets(name):
    # the golden files' visits lie 2 and 6 bytes off an 8-byte boundary: mapped, the C loops
    # (checking, costing, loading, memory keys) read them where they are; under `make asan-py`
    # UBSan's alignment check runs here
    path = GOLDEN[NAMES.index(name)]
    mapped, read = mprt.load_trace(path, mmap=True), mprt.load_trace(path, mmap=False)
    assert isinstance(mapped.visits, np.memmap) and mapped.visits.ctypes.data % 8 != 0
    for cname, level in CONFIGS:
        cfg = config(cname, level)
        assert same(Compiled(mapped, priced_for(mapped, cfg)).result(cfg),
                    Compiled(read, priced_for(read, cfg)).result(cfg)), (cname, level)
        assert same(Compiled(mapped, costs_for(mapped, cfg)).result(cfg),
                    Compiled(read, costs_for(read, cfg)).result(cfg)), (cname, level)


def test_priced_flits_equal_the_arrays_flits():
    """Made as the replay loads (a ring configuration) or when first asked for (another)."""
    trace = mprt.load_trace(GOLDEN[0])
    cfg = config("3mppe", 2)
    want = costs_for(trace, cfg).flits
    loaded = priced_for(trace, cfg)
    Compiled(trace, loaded)
    assert loaded._flits is not None and np.array_equal(loaded.flits, want)
    later = priced_for(trace, config("3mppe", 1))
    Compiled(trace, later)
    assert later._flits is None and np.array_equal(later.flits, want)


def test_one_priced_load_runs_ring_and_ideal_configurations():
    trace = mprt.load_trace(GOLDEN[NAMES.index("balls-g4")])
    cfg1, cfg2 = config("3mppe", 1), config("3mppe", 2)
    comp = Compiled(trace, priced_for(trace, cfg1))
    for cfg in (cfg1, cfg2, cfg1):
        assert same(comp.result(cfg), Compiled(trace, costs_for(trace, cfg)).result(cfg))


def test_a_deadlock_is_the_same_priced_or_not():
    trace = mprt.load_trace(GOLDEN[NAMES.index("balls-g9")])
    cfg = builtin("M").replace(ring=RingConfig(1, 1))        # one buffer class: deadlocks (README)
    msgs = []
    for costs in (costs_for(trace, cfg), priced_for(trace, cfg)):
        with pytest.raises(DeadlockError) as e:
            Compiled(trace, costs).result(cfg)
        msgs.append((str(e.value), repr(e.value.state)))
    assert msgs[0] == msgs[1]


def test_the_evaluator_prices_as_it_loads_and_keeps_arrays_for_the_rest():
    trace = mprt.load_trace(GOLDEN[0])
    ev = Evaluator(trace)
    cfg = builtin("M")
    e = ev.evaluate(cfg, 1, "compiled")
    c = ev._costed[ev._key(at_level(cfg, 1))]
    assert "costs" not in c                              # no per-visit arrays made
    assert same(e.result, Evaluator(trace, costs=costs_for(trace, cfg)).evaluate(cfg, 1, "compiled").result)
    assert ev.evaluate(cfg, 0, "analytical").cycles > 0 and "costs" in c     # made when another form needs them


def test_another_cost_model_keeps_its_arrays():
    """A cost model of another arithmetic (a subclass) is priced by its own arrays; the counted
    model (the same constants and arithmetic) in C, to the same run, and without its counts."""
    class Other(CostModel):
        pass
    trace = mprt.load_trace(GOLDEN[0])
    cfg = builtin("M")
    base = CostModel.default()
    assert priced_for(trace, cfg, Other(base.latency, base.visit_overhead, base.scale, base.info)) is None
    assert priced_for(trace, cfg, base) is not None
    counted = base.counted(trace)
    priced = priced_for(trace, cfg, counted)
    assert priced is not None and counted._counts is None          # nothing counted to price it in C
    got = Evaluator(trace, counted).evaluate(cfg, 1, "compiled").result
    assert counted._counts is None
    assert same(got, Evaluator(trace, costs=costs_for(trace, cfg)).evaluate(cfg, 1, "compiled").result)
    assert np.array_equal(counted.visit_costs(trace, cfg.processors()).process,
                          base.visit_costs(trace, cfg.processors()).process)      # counted when asked


def test_a_visit_c_cannot_price_is_a_trace_error():
    trace = mprt.load_trace(GOLDEN[0])
    cfg = builtin("M")
    priced = priced_for(trace, cfg)
    priced.records.prim_kind = priced.records.prim_kind[:0]       # every primitive unknown to the pricing
    hit = int(np.flatnonzero(trace.visits["prim"] >= 0)[0])
    with pytest.raises(mprt.TraceError, match=f"cannot cost this trace: visit {hit}: primitive"):
        Compiled(trace, priced)


@pytest.mark.parametrize("name", NAMES)
def test_memory_keys_and_references_in_c_equal_numpy(name):
    """Level 3's keys and reference counts, counted in C in one pass (mprt_visit_keys), equal
    memdata.visit_keys and DataLayout's own counts; so do the memory estimate's reads."""
    from mprt.fidelity.memdata import MemoryData, visit_keys
    from mprt.machine.memory import DataLayout

    trace = mprt.load_trace(GOLDEN[NAMES.index(name)])
    md = MemoryData(trace)
    assert np.array_equal(md.keys, visit_keys(trace))
    own = DataLayout(trace)
    assert np.array_equal(md.layout.voxel_refs, own.voxel_refs)
    assert np.array_equal(md.layout.material_refs, own.material_refs)
    keys = md.replay_keys
    for tag, sel in (("ic", keys[keys >= 0]), ("sc", -2 - keys[keys <= -2].astype(np.int64))):
        per = np.diff(md.get(tag, 1024, 32)[0]["line_start"])
        assert md.reads(tag, per) == int(per[sel].sum())


@pytest.mark.parametrize("at", [0, 1, 0.5, -1])
def test_one_long_visit_late_widens_the_packed_records(at):
    """Records are packed as they load until a visit of 2^24 cycles or more: those before it are
    widened then; the machine is the SimPy model's wherever it comes (first, second, middle, last)."""
    from types import SimpleNamespace

    from mprt.fidelity import replay
    from mprt.machine import simulate
    from test_fidelity import head

    t = head(mprt.load_trace(GOLDEN[NAMES.index("balls-g9")]), 20)
    vc = costs_for(t, builtin("M"))
    process = vc.process.copy()
    k = int(at * (len(process) - 1)) if at != -1 else len(process) - 1
    process[k] = (1 << 24) + 5
    long = SimpleNamespace(process=process, receive=vc.receive, send=vc.send, flits=vc.flits,
                           inject_process=vc.inject_process, inject_send=vc.inject_send)
    assert same(simulate(t, "M", costs=long), replay(t, "M", costs=long))
