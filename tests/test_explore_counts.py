"""mprt.cost.KernelCounts: a trace's kernel runs counted once, priced for any
processors by a product; it must equal the cost model's per-visit pricing."""
from pathlib import Path

import numpy as np
import pytest

import mprt
from mprt.cost import CostModel, KernelCounts, ProcessorConfig

GOLDEN = sorted((Path(__file__).parent / "data" / "golden").glob("*.npz"))
FIELDS = ("process", "receive", "send", "flits", "inject_process", "inject_send", "inject_flits")


def _procs(rng):
    """Random processors: sequential, the paper's, or random unit mixes and issue widths."""
    out = {}
    for s in ("OS", "IC", "SC"):
        r = rng.integers(3)
        if r == 0:
            out[s] = ProcessorConfig.sequential()
        elif r == 1:
            out[s] = ProcessorConfig.paper(s)
        else:
            out[s] = ProcessorConfig(units={"int": int(rng.integers(1, 4)), "fp": int(rng.integers(1, 5))},
                                     issue_width=int(rng.integers(1, 5)))
    return out


@pytest.mark.parametrize("path", GOLDEN[::3], ids=lambda p: p.stem)
def test_price_equals_visit_costs(path):
    tr = mprt.load_trace(path)
    rng = np.random.default_rng(len(tr.visits))
    counts = KernelCounts(tr, chunk=777)          # chunks cut through rays: the counts must not care
    for model in (CostModel.default(), CostModel.nominal()):
        for _ in range(4):
            procs = _procs(rng)
            want, got = model.visit_costs(tr, procs), counts.price(model, procs)
            for k in FIELDS:
                assert np.array_equal(getattr(want, k), getattr(got, k)), (path.stem, k, procs)


def test_counted_model_prices_its_trace_and_falls_back_on_others():
    a = mprt.load_trace(GOLDEN[0])
    b = mprt.load_trace(GOLDEN[1])
    cm = CostModel.default()
    fast = cm.counted(a)
    procs = {s: ProcessorConfig.paper(s) for s in ("OS", "IC", "SC")}
    for tr in (a, b):
        want, got = cm.visit_costs(tr, procs), fast.visit_costs(tr, procs)
        assert all(np.array_equal(getattr(want, k), getattr(got, k)) for k in FIELDS)
    assert fast.latency == cm.latency and fast.scale == cm.scale
    with pytest.raises(mprt.cost.CostModelError, match="no processor for stage 'SC'"):
        fast.visit_costs(a, {"OS": procs["OS"], "IC": procs["IC"]})


def test_pricing_through_classes_equals_visit_costs_and_is_taken_from_the_second_pricing():
    tr = mprt.load_trace(GOLDEN[0])
    counts = KernelCounts(tr)
    model = CostModel.default()
    rng = np.random.default_rng(7)
    procs = [_procs(rng) for _ in range(3)]
    first = counts.price(model, procs[0])
    assert counts._classes is None                 # one pricing: the product a visit, no classes yet
    for p in procs + procs[:1]:
        want, got = model.visit_costs(tr, p), counts.price(model, p)
        assert all(np.array_equal(getattr(want, k), getattr(got, k)) for k in FIELDS), p
    cls, table, m = counts._classes
    assert len(cls) == len(tr.visits) and 1 < m <= len(tr.visits) + 1
    assert sum(len(r) for _, r, _ in table.values()) == m - 1     # one row a class (class 0: no stage)
    again = counts.price(model, procs[0])
    assert all(np.array_equal(getattr(first, k), getattr(again, k)) for k in FIELDS)


def test_pricing_falls_back_to_the_product_where_the_classes_key_would_not_fit():
    tr = mprt.load_trace(GOLDEN[1])
    counts = KernelCounts(tr)
    name = next(s for s in counts.rows if len(counts.rows[s]))
    counts.runs[name] = counts.runs[name].copy()
    counts.runs[name][0, :] = np.iinfo(np.int32).max // 1024      # columns too wide for one int64 key
    model = CostModel.default()
    procs = {s: ProcessorConfig.paper(s) for s in ("OS", "IC", "SC")}
    a, b = counts.price(model, procs), counts.price(model, procs)
    assert counts._classes == ()
    assert all(np.array_equal(getattr(a, k), getattr(b, k)) for k in FIELDS)
