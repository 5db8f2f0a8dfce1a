"""The C pricing of visits (mprt.cost.fast, c/src/cost.c) against the numpy
reference (mprt.cost.reference): the same arrays, to the bit, on the golden
traces, random processors and models, scrambled visits, and slices; bad
traces named."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel, KernelCounts, ProcessorConfig, UNIT_KINDS
from mprt.cost import fast, reference
from mprt.cost.kernels import OP_CLASSES
from mprt.errors import TraceError

GOLDEN = sorted((Path(__file__).parent / "data" / "golden").glob("*.npz"))
ARRAYS = ("process", "receive", "send", "flits")
INJECT = ("inject_process", "inject_send", "inject_flits")


def _proc(rng):
    r = rng.integers(4)
    if r == 0:
        return ProcessorConfig.sequential({c: int(rng.integers(1, 9)) for c in OP_CLASSES if rng.random() < 0.3})
    if r == 1:
        return ProcessorConfig.paper(str(rng.choice(["OS", "IC", "SC"])))
    kinds = [k for k in UNIT_KINDS if k != "general"]
    units = {"general": 1} if rng.random() < 0.5 else {"int": 1, "fp": 1}
    for k in rng.choice(kinds, size=int(rng.integers(0, 3)), replace=False):
        units[str(k)] = units.get(str(k), 0) + int(rng.integers(1, 3))
    return ProcessorConfig(units=units, issue_width=int(rng.integers(1, 5)), pipelined=bool(rng.random() < 0.5))


def _model(rng):
    return CostModel({c: int(rng.integers(1, 20)) for c in OP_CLASSES},
                     {s: int(rng.integers(0, 50)) for s in ("OS", "IC", "SC")},
                     {s: int(rng.integers(1, 400)) for s in ("OS", "IC", "SC")})


def _same(a, b, what):
    for k in ARRAYS:
        x, y = getattr(a, k), getattr(b, k)
        assert x.dtype == y.dtype and x.shape == y.shape, (what, k)
        assert np.array_equal(x, y), (what, k, int(np.argmax(x != y)))
    for k in INJECT:
        assert getattr(a, k) == getattr(b, k), (what, k)


@pytest.mark.parametrize("path", GOLDEN, ids=lambda p: p.stem)
def test_c_pricing_equals_the_numpy_reference_on_random_processors(path):
    tr = mprt.load_trace(path)
    rng = np.random.default_rng(len(tr.visits))
    models = [CostModel.default(), CostModel.nominal(), _model(rng)]
    for i in range(6):
        model = models[i % len(models)]
        procs = {s: _proc(rng) for s in ("OS", "IC", "SC")}
        _same(model.visit_costs(tr, procs), model.reference_visit_costs(tr, procs, chunk=int(rng.integers(50, 5000))),
              (path.stem, i, procs))


def _scrambled(tr, rng):
    """The trace with its visits' fields drawn at random (stages, outcomes, counts of any
    size and sign, primitives, made / suppressed): every branch of the pricing, and
    wrapping arithmetic, whatever the pipeline would allow."""
    v = np.array(tr.visits)
    n = len(v)
    v["stage"] = rng.integers(0, 3, n)
    v["outcome"] = rng.integers(0, 9, n)
    big = rng.random(n) < 0.01
    v["steps"] = np.where(big, rng.integers(-2**31, 2**31, n), rng.integers(0, 40, n))
    v["tests"] = np.where(big[:, None], rng.integers(-2**31, 2**31, (n, 4)), rng.integers(0, 9, (n, 4)))
    v["vertices"] = rng.integers(-5, 1000, n)
    v["prim"] = rng.integers(-3, len(tr.prim_kind), n)
    v["made"] = rng.integers(0, 256, n)
    v["suppressed"] = rng.integers(0, 256, n)
    pk = np.array(tr.prim_kind)
    pk[rng.random(len(pk)) < 0.2] = 7              # a kind with no hit kernel
    return dataclasses.replace(tr, visits=v, prim_kind=pk, meta=dict(tr.meta, lights=int(rng.integers(0, 5))))


@pytest.mark.parametrize("path", GOLDEN[::4], ids=lambda p: p.stem)
def test_c_pricing_equals_the_reference_on_scrambled_visits(path):
    rng = np.random.default_rng(7)
    tr = _scrambled(mprt.load_trace(path), rng)
    procs = {s: _proc(rng) for s in ("OS", "IC", "SC")}
    for model in (_model(rng), CostModel({c: 40 for c in OP_CLASSES}, {"OS": 2**40, "IC": 0, "SC": 7})):
        _same(model.visit_costs(tr, procs), model.reference_visit_costs(tr, procs, chunk=333), path.stem)
    assert fast.kernel_counts(tr, chunk=1000) == reference.kernel_counts(tr, chunk=777)


@pytest.mark.parametrize("path", GOLDEN[1::4], ids=lambda p: p.stem)
def test_counts_in_chunks_equal_the_reference(path):
    tr = mprt.load_trace(path)
    assert fast.kernel_counts(tr, chunk=101) == reference.kernel_counts(tr)
    counts = KernelCounts(tr, chunk=555)            # chunks cut through rays
    rng = np.random.default_rng(3)
    for _ in range(3):
        model, procs = _model(rng), {s: _proc(rng) for s in ("OS", "IC", "SC")}
        _same(counts.price(model, procs), model.reference_visit_costs(tr, procs), path.stem)
    # a slice priced alone, with the visit before it as context, is the whole trace's slice
    whole = CostModel.default().visit_costs(tr, procs)
    rec = fast.Records(tr)
    a, b = len(tr.visits) // 3, 2 * len(tr.visits) // 3
    part = np.empty(b - a, np.int64)
    rec.run(CostModel.default().cost_table(procs), a, b, receive=part)
    assert np.array_equal(part, whole.receive[a:b])


def _bad(tr, **fields):
    v = np.array(tr.visits)
    for k, (i, x) in fields.items():
        v[k][i] = x
    return dataclasses.replace(tr, visits=v)


def test_bad_traces_are_named():
    tr = mprt.load_trace(GOLDEN[0])
    cm, procs = CostModel.default(), {s: ProcessorConfig.sequential() for s in ("OS", "IC", "SC")}
    n = len(tr.visits)
    cases = [(_bad(tr, stage=(5, 3)), "visit 5: stage 3 is not OS, IC or SC"),
             (_bad(tr, ray=(n - 1, len(tr.rays))), f"visit {n - 1}: ray {len(tr.rays)} is not a ray of the trace"),
             (_bad(tr, ray=(2, -4)), "visit 2: ray -4 is not a ray of the trace"),
             (_bad(tr, prim=(9, len(tr.prim_kind))), f"visit 9: primitive {len(tr.prim_kind)} is not a primitive")]
    rays = np.array(tr.rays)
    rays["kind"][4] = 9
    cases.append((dataclasses.replace(tr, rays=rays), "ray 4: kind 9 is not a ray kind"))
    rays = np.array(tr.rays)
    rays["parent"][6] = len(rays) + 5
    cases.append((dataclasses.replace(tr, rays=rays), f"ray 6: parent {len(rays) + 5} is not a ray of the trace"))
    for bad, msg in cases:
        with pytest.raises(TraceError, match="cannot cost this trace: " + msg):
            cm.visit_costs(bad, procs)
    # a chunk's message names the trace's visit, not the chunk's
    with pytest.raises(TraceError, match=f"visit {n - 3}: stage 4"):
        fast.kernel_counts(_bad(tr, stage=(n - 3, 4)), chunk=1000)
    with pytest.raises(mprt.cost.CostModelError, match="meta 'lights'"):
        cm.visit_costs(dataclasses.replace(tr, meta=dict(tr.meta, lights=-1)), procs)


def test_records_in_another_layout_take_the_reference_path():
    tr = mprt.load_trace(GOLDEN[2])
    v = np.array(tr.visits)
    other = np.zeros(len(v), dtype=[(k, v.dtype[k]) for k in reversed(v.dtype.names)])   # fields reordered
    for k in v.dtype.names:
        other[k] = v[k]
    odd = dataclasses.replace(tr, visits=other)
    assert not fast.usable(odd) and fast.usable(tr)
    procs = {s: ProcessorConfig.paper(s) for s in ("OS", "IC", "SC")}
    _same(CostModel.default().visit_costs(odd, procs), CostModel.default().visit_costs(tr, procs), "layout")


def test_threads_share_a_large_trace_with_the_same_results(monkeypatch):
    tr = mprt.load_trace(GOLDEN[0])
    reps = (1 << 21) // len(tr.visits) + 1          # over 2^21 visits: two shares of at least 2^20
    v = np.concatenate([tr.visits] * reps)
    v["ray"] += np.repeat(np.arange(reps) * len(tr.rays), len(tr.visits))
    r = np.concatenate([tr.rays] * reps)
    shift = np.repeat(np.arange(reps) * len(tr.rays), len(tr.rays))
    r["id"] += shift
    r["parent"] = np.where(r["parent"] >= 0, r["parent"] + shift, -1)
    big = dataclasses.replace(tr, rays=r, visits=v)
    cm, procs = CostModel.default(), {s: ProcessorConfig.paper(s) for s in ("OS", "IC", "SC")}
    rec, table, n = fast.Records(big), cm.cost_table(procs), len(v)
    outs = {}
    for t in (1, 2, 3, 16):
        o = {k: np.empty(n, np.int64) for k in ("process", "receive", "send")}
        o["flits"] = np.empty(n, np.int32)
        rec.run(table, 0, n, threads=t, **o)
        outs[t] = o
    for t in (2, 3, 16):
        assert all(np.array_equal(outs[1][k], outs[t][k]) for k in outs[1])
    whole = cm.reference_visit_costs(tr, procs)
    assert np.array_equal(outs[16]["process"][-len(tr.visits):], whole.process)
    # the first visit at fault is named, whichever thread meets it
    v["stage"][n - 5] = 7
    v["stage"][n // 2 + 3] = 9
    with pytest.raises(TraceError, match=f"visit {n // 2 + 3}: stage 9"):
        fast.Records(big).run(table, 0, n, threads=4, process=np.empty(n, np.int64))
