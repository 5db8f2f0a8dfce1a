"""The design-space explorer: space files, hardware cost, evaluation through the fidelity ladder, NLopt search."""
from pathlib import Path

import numpy as np
import pytest

import mprt
from mprt.explore import (Design, SpaceError, UnitCosts, default_space, hardware_cost, load_space, model_m,
                          model_s, base_design)
from mprt.explore.evaluate import TraceEvaluator, machine_config, machine_fields
from mprt.explore.search import Problem, exhaustive, search

DATA = Path(__file__).parent / "data"
SMALL = DATA / "explore" / "small_space.toml"


class _At:
    """A trace's evaluator at one level, as the search calls it."""

    def __init__(self, trace, level):
        self.ev, self.level, self.trace = TraceEvaluator(trace), level, trace

    def run(self, design):
        return self.ev.run(design, self.level)


@pytest.fixture(scope="module")
def level0s():
    """Level 1 (the compiled exact replay) on three golden traces: what the search runs at."""
    return {n: _At(mprt.load_trace(DATA / "golden" / f"{n}-g9.npz"), 1) for n in ("balls", "mount", "tetra")}


# --- the space file ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, field", [
    ("pes = { min = 0, max = 2 }", "pes.min"),
    ("mapping = { choices = ['OS|IC|SC', 'OS|SC|IC'] }", "mapping.choices[1]"),
    ("fifo = { min = 8, max = 4 }", "fifo: max 4 is below min 8"),
    ("[replication]\nIC = 2.5", "replication.IC"),
    ("[units.IC]\nint = 1\nfp = 0", "units.IC: no unit runs floating-point"),
    ("[units.OS]\nint = 1\nfp = 1\nvector = 2", "units.OS.vector"),
    ("[cache]\nOS = 4", "cache.OS"),
    ("colour = 3", "colour"),
    ("[cost]\nfp_unit = -1", "cost.fp_unit"),
    ("[subdivision]\nn = 4\nnx = 3", "subdivision: give n, or nx, ny and nz, not both"),
    ("[subdivision]\nn = 4\nshape = 'round'", "subdivision.shape"),
    ("fifo = { choices = [4, 4] }", "fifo.choices: repeated"),
    # bounded before anything is made (issue 19: max = 1e18 built a list until MemoryError)
    ("pes = { min = 1, max = 1000000000000000000 }", "pes.max: 1000000000000000000 is above the maximum"),
    ("pes = { min = 1, max = 100000, step = 1 }", "pes: 100000 values; at most 4096"),
    ("[subdivision]\nn = 1000000000000000000", "subdivision.n: 1000000000000000000 is above the maximum"),
])
def test_space_errors_name_file_and_field(tmp_path, text, field):
    p = tmp_path / "bad.toml"
    p.write_text(text + "\n")
    with pytest.raises(SpaceError) as e:
        load_space(p)
    assert str(e.value).startswith(f"{p}: ") and field in str(e.value)


def test_toml_nested_too_deeply_is_one_line(tmp_path):
    p = tmp_path / "deep.toml"
    p.write_text("x = " + "[" * 100000 + "]" * 100000 + "\n")
    with pytest.raises(SpaceError, match="nested too deeply"):
        load_space(p)
    from mprt.explore.sweep import load_spec
    with pytest.raises(SpaceError, match="nested too deeply"):
        load_spec(p)
    q = tmp_path / "spec.toml"
    q.write_text('scenes = ["tetra:1"]\nsubdivisions = [1099511627776]\n[designs]\nS = "S"\n')
    with pytest.raises(SpaceError, match=r"subdivisions\[0\]: .* integers in 1\.\.1024"):
        load_spec(q)


def test_space_unreadable_and_malformed(tmp_path):
    with pytest.raises(SpaceError, match="cannot read"):
        load_space(tmp_path / "missing.toml")
    p = tmp_path / "bad.toml"
    p.write_text("fifo = [\n")
    with pytest.raises(SpaceError, match=str(p)):
        load_space(p)


def test_space_leaves_and_defaults(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("pes = { min = 2, max = 8, step = 3 }\n[subdivision]\nnx = 4\nny = { choices = [1, 2] }\nnz = 5\n")
    sp = load_space(p)
    var = {v.name: v.values for v in sp.variables}
    assert var["pes"] == (2, 5, 8)
    assert var["subdivision.ny"] == (1, 2) and sp.shape == "cube"
    # fields the file leaves out are the built-in default's
    assert var["replication.IC"] == {v.name: v.values for v in default_space().variables}["replication.IC"]
    pt = sp.point([0] * len(sp.variables))
    assert pt.subdivision == (4, 1, 5) and pt.design.pes == 2


def test_canonical_merges_designs_that_cannot_differ():
    sp = load_space(SMALL)
    pos = {n: i for i, n in enumerate(sp.names)}
    a = [0] * len(sp.variables)
    a[pos["mapping"]] = sp.variables[pos["mapping"]].values.index("OS+IC+SC")
    b = list(a)
    b[pos["units.IC.fp"]] = 3          # IC runs on the OS processor: its own units are dead
    b[pos["replication.IC"]] = 2
    assert sp.canonical(a) == sp.canonical(b)
    c = list(a)
    c[pos["units.OS.fp"]] = 2          # the one processor's units are live
    assert sp.canonical(a) != sp.canonical(c)
    assert sp.index_of(sp.point(c)) == tuple(c)


def test_design_round_trip_and_errors():
    d = base_design()
    assert Design.from_dict(d.to_dict()) == d
    with pytest.raises(SpaceError, match="design: replication.IC: 0 is below the minimum 1"):
        Design.from_dict({"replication": {"OS": 1, "IC": 0, "SC": 1}})
    with pytest.raises(SpaceError, match="unknown field"):
        Design.from_dict({"speed": 3})


# --- hardware cost ----------------------------------------------------------------------------------------------

def test_cost_of_paper_machine_by_hand():
    c = UnitCosts()
    # three processors: OS 2 int + 2 FP, IC 1 int + 3 FP, SC 1 general; two FIFOs and a ring node each;
    # 16 KiB IC cache and 4 KiB SC cache
    by_hand = (3 * c.processor + (2 * c.int_unit + 2 * c.fp_unit) + (c.int_unit + 3 * c.fp_unit) + c.general_unit
               + 3 * 2 * 256 * c.fifo_word + 3 * c.ring_node + 20 * c.cache_kib)
    assert hardware_cost(base_design()) == pytest.approx(by_hand)
    two = Design.from_dict({**base_design().to_dict(), "pes": 2})
    assert hardware_cost(two) == pytest.approx(2 * by_hand)
    # model S has no packets, so no FIFOs or ring
    s = model_s()
    assert hardware_cost(s) == pytest.approx(c.processor + c.general_unit + 20 * c.cache_kib)


# --- evaluation through the fidelity ladder ---------------------------------------------------------------

def test_model_s_is_the_sum_of_processing(level0s):
    """Model S: one processor that never waits: its time at levels 0 and 1 is every
    visit's cycles (processing, receiving, sending: the machine model charges a packet
    also when it stays on its processor) plus SC's making of each primary ray."""
    from mprt.cost import CostModel, ProcessorConfig
    tr = level0s["balls"].trace
    seq = ProcessorConfig.sequential()
    vc = CostModel.default().visit_costs(tr, {"OS": seq, "IC": seq, "SC": seq})
    primaries = int(np.sum(tr.rays["kind"] == 0))
    ev = TraceEvaluator(tr)
    for level in (0, 1):
        want = int(np.sum(vc.process) + np.sum(vc.receive) + np.sum(vc.send)) \
            + primaries * (vc.inject_process + vc.inject_send)
        assert ev.run(model_s(), level).cycles == want


def test_levels_are_the_fidelity_ladders(level0s):
    """Every level's cycles are mprt.fidelity's for the design's machine (the explorer adds nothing)."""
    from mprt.fidelity import evaluate
    tr = level0s["tetra"].trace
    ev = TraceEvaluator(tr)
    d = Design.from_dict({**base_design().to_dict(), "mapping": "OS+SC|IC", "pes": 2, "fifo": 256})
    for level in (0, 1, 2, 3):
        r = ev.run(d, level)
        want = evaluate(tr, machine_config(d), level)
        assert r.cycles == want.cycles and r.engine == want.engine and r.level == level


def test_pipeline_figures(level0s):
    for ev in level0s.values():
        m = ev.run(model_m())
        assert m.cycles >= max(m.loads.values())
        assert m.cycles < ev.run(model_s()).cycles       # three processors beat one here
        assert 0 < max(m.utilisation.values()) <= 1.0
        # a second copy of the bottleneck processor halves its load per copy and speeds the machine up
        d = model_m().to_dict()
        d["replication"][m.bottleneck] = 2
        m2 = ev.run(Design.from_dict(d))
        assert m2.loads[m.bottleneck] == pytest.approx(m.loads[m.bottleneck] / 2, rel=0.02)
        assert m2.cycles < m.cycles
        # more FP units on IC never make IC busier
        d = base_design().to_dict()
        d["units"]["IC"]["fp"] = 4
        assert ev.run(Design.from_dict(d)).loads["IC"] <= ev.run(base_design()).loads["IC"]


def test_window_keeps_the_fifos_from_deadlocking():
    """The window admits no more trees than the FIFOs can hold on the trace's largest tree
    (the machine model's bound; at least one), so small-FIFO designs replay; a configuration
    past the bound that deadlocks is reported as such, with a cycle count no search prefers."""
    from mprt.explore.evaluate import DEADLOCK_CYCLES, max_leaves, window
    d = Design.from_dict({**base_design().to_dict(), "fifo": 16, "replication": {"OS": 3, "IC": 4, "SC": 2}})
    for path in sorted((DATA / "golden").glob("*-g9.npz")):
        tr = mprt.load_trace(path)
        leaves = max_leaves(tr)
        cfg = machine_config(d, leaves)
        assert cfg.window == window(d, leaves)
        assert cfg.window * leaves < cfg.cycle_capacity or cfg.window == 1       # 1: the least a PE can admit
        assert TraceEvaluator(tr).run(d, 1).bottleneck != "deadlock"
    tr = mprt.load_trace(DATA / "golden" / "gears-g9.npz")
    from mprt.machine.config import config_from_dict
    wide = config_from_dict({**machine_fields(d), "window": 64})
    r = TraceEvaluator(tr).run_config(wide, 1)
    assert r.bottleneck == "deadlock" and r.cycles == DEADLOCK_CYCLES



def test_a_design_deadlocking_on_the_ring_runs_with_a_smaller_window():
    """The window's bound is the ideal network's: on the ring (level 3) tetra's pipeline with
    16-word FIFOs deadlocks at it; under the rule ``window = "auto"`` (the design's machine file)
    the window is then halved until the machine runs, and that run's cycles are reported (the
    same as asking for that window); a fixed window that deadlocks stays a deadlock."""
    from mprt.machine.config import auto_window, config_from_dict
    d = Design.from_dict({"mapping": "OS|IC|SC", "fifo": 16, "pes": 1, "replication": {"OS": 1, "IC": 1, "SC": 1}})
    ev = TraceEvaluator(mprt.load_trace(DATA / "golden" / "tetra-g9.npz"))
    fields = machine_fields(d)
    assert fields["window"] == "auto"
    w0 = auto_window(config_from_dict(fields), ev.leaves)
    assert w0 > 1
    fixed = {**fields, "window": w0}
    assert ev.run_config(config_from_dict(fixed), 3).bottleneck == "deadlock"
    assert ev.run_config(config_from_dict(fixed), 1).bottleneck != "deadlock"     # live on the ideal network
    got = ev.run(d, 3)
    assert got.bottleneck != "deadlock"
    assert ev.run_config(config_from_dict(fields), 3).cycles == got.cycles        # the rule, as the file says
    w = w0 // 2
    while ev.run_config(config_from_dict({**fields, "window": w}), 3).bottleneck == "deadlock":
        w //= 2
    assert got.cycles == ev.run_config(config_from_dict({**fields, "window": w}), 3).cycles


# --- search -----------------------------------------------------------------------------------------------------

CASES = [("time", 300.0), ("time", 500.0), ("time*cost", None), ("time", None)]


@pytest.mark.parametrize("scene", ["balls", "mount", "tetra"])
def test_nlopt_finds_exhaustive_optimum(level0s, scene):
    """DIRECT-L (80 distinct designs) and the lattice polish find the design
    exhaustive enumeration finds, in fewer evaluations (counts printed)."""
    sp = load_space(SMALL)
    ev = level0s[scene]
    f = lambda pts: [ev.run(p.design) for p in pts]  # noqa: E731
    for obj, budget in CASES:
        ex = exhaustive(Problem(sp, f, obj, budget))
        p = Problem(sp, f, obj, budget)
        r = search(p, "direct-l", "lattice", max_evals=80, seed=1)
        print(f"{scene} {obj} budget {budget}: exhaustive {ex.evaluations} evaluations, "
              f"search {r.evaluations} ({r.phases})")
        assert p.f(r.best) == pytest.approx(p.f(ex.best), abs=1e-12)
        assert r.best.cycles == ex.best.cycles and r.best.cost == ex.best.cost
        assert r.evaluations < ex.evaluations
        if budget is not None:
            assert r.best.cost <= budget


def test_search_repeats_exactly_with_a_seed(level0s):
    sp = load_space(SMALL)
    ev = level0s["tetra"]
    f = lambda pts: [ev.run(p.design) for p in pts]  # noqa: E731
    runs = []
    for _ in range(2):
        p = Problem(sp, f, "time", 400.0)
        search(p, "crs2", "lattice", max_evals=30, seed=7)
        runs.append(p.history())
    assert runs[0] == runs[1]
    p = Problem(sp, f, "time", 400.0)
    search(p, "crs2", "lattice", max_evals=30, seed=8)
    assert p.history() != runs[0]          # the seed reaches NLopt's random numbers


def test_memo_counts_distinct_designs(level0s):
    sp = load_space(SMALL)
    ev = level0s["balls"]
    calls = []

    def f(pts):
        calls.extend(pts)
        return [ev.run(p.design) for p in pts]

    p = Problem(sp, f, "time")
    r = search(p, "direct-l", "sbplx", max_evals=25, seed=1)
    assert len(calls) == r.evaluations == len({pt.key() for pt in calls})
    assert r.calls > r.evaluations       # NLopt revisited cells, answered from the memo


def test_nlopt_stops_once_idle_with_the_same_designs(level0s, monkeypatch):
    """NLopt stops after IDLE_CALLS calls in a row that found no new design: where the space
    runs out before the designs asked for, the same designs in the same order as letting it
    run to its call budget, in fewer calls; a smaller IDLE_CALLS stops sooner, with fewer."""
    import mprt.explore.search as S

    sp = load_space(SMALL)
    ev = level0s["tetra"]
    f = lambda pts: [ev.run(p.design) for p in pts]  # noqa: E731
    runs = {}
    for idle in (S.IDLE_CALLS, 10 ** 9, 400):
        monkeypatch.setattr(S, "IDLE_CALLS", idle)
        runs[idle] = p = Problem(sp, f, "time", 400.0)
        search(p, "direct-l", "none", max_evals=200, seed=1)
    p, q, r = runs.values()
    assert q.calls == 200 * 200 and len(q.memo) < 200        # unstopped: the whole call budget
    assert p.order == q.order and p.calls < q.calls
    assert r.order == q.order[:len(r.order)] and len(r.order) < len(q.order) and r.calls < p.calls


def test_pareto_front_is_nondominated(level0s):
    from mprt.explore.search import pareto
    sp = load_space(SMALL)
    ev = level0s["mount"]
    f = lambda pts: [ev.run(p.design) for p in pts]  # noqa: E731
    ex = Problem(sp, f, "time")
    exhaustive(ex)
    true_front = [(e.cost, e.cycles) for e in ex.front()]
    p = Problem(sp, f, "pareto")
    r = pareto(p, np.geomspace(150, 900, 6), max_evals=40)
    found = [(e.cost, e.cycles) for e in r.front]
    assert found == sorted(found) and all(b[1] < a[1] for a, b in zip(found, found[1:]))
    # every point found lies on the true front or is dominated by none of the found ones; most are on it
    assert sum(pt in true_front for pt in found) >= 0.8 * len(found)


def test_machine_config_of_a_design():
    """The machine-model configuration a design becomes (the fidelity levels take parts away)."""
    from mprt.cost import packet_flits
    from mprt.fidelity import at_level
    d = Design.from_dict({"mapping": "OS+SC|IC", "replication": {"OS": 2, "IC": 3, "SC": 1}, "fifo": 256,
                          "units": {"OS": {"int": 3, "fp": 1}, "IC": {"int": 1, "fp": 4}, "SC": {"general": 1}},
                          "cache": {"IC": 16, "SC": 0}, "resident": {"IC": 0, "SC": 4}, "pes": 2})
    c = machine_fields(d)
    assert [s["subtasks"] for s in c["stage"]] == [["OS", "SC"], ["IC"]]
    assert [s["replicas"] for s in c["stage"]] == [2, 3]
    assert c["stage"][0]["processor"] == {"units": {"int": 3, "fp": 1}}       # OS+SC takes OS's units
    biggest = max(packet_flits(0, 1, k) for k in range(4))
    assert "ring" in c and 1 <= c["stage"][1]["receive_fifo"] <= 256 // biggest and c["pes"] == 2
    assert c["ic_memory"] == {"resident": 0, "cache": {"size": 16384, "line": 32, "ways": 4}}
    assert c["sc_memory"] == {"resident": 4096} and "icgm" in c and "scgm" in c
    cfg = machine_config(d)
    one = at_level(cfg, 1)
    assert one.ring is None and one.ic_memory is None and one.stages[1].receive_fifo == cfg.stages[1].receive_fifo
    assert at_level(cfg, 2).ring is not None and at_level(cfg, 2).ic_memory is None
    s = machine_fields(model_s())
    assert len(s["stage"]) == 1 and "ring" not in s and "send_fifo" not in s["stage"][0]

def test_feeds_reach_the_machine_and_its_deadlock_bound(tmp_path):
    """A space's feed choices become the machine's stage feed for replicated processors only;
    the window respects the feed's deadlock capacity; an unknown feed is refused by name."""
    from mprt.explore.evaluate import window
    from mprt.machine.config import stage_capacity
    p = tmp_path / "s.toml"
    p.write_text('[replication]\nIC = 3\nfeed = { choices = ["shared", "round-robin", "shortest-queue"] }\n')
    sp = load_space(str(p))
    feeds = list(sp.variables[sp._pos["replication.feed"]].values)
    assert feeds == ["shared", "round-robin", "shortest-queue"]
    d = model_m()
    for feed in feeds:
        rep = {**d.replication, "IC": 3}
        dd = Design(**{**d.__dict__, "replication": rep, "feed": feed, "fifo": 64})
        cfg = machine_config(dd, leaves=5)
        st = {s.name: s for s in cfg.stages}
        assert st["IC"].feed == feed and st["OS"].feed == "shared" and st["SC"].feed == "shared"
        # window x leaves stays below the machine's own bound, whatever the feed
        assert cfg.window == window(dd, 5) and cfg.window * 5 < cfg.cycle_capacity
        assert cfg.cycle_capacity == sorted(stage_capacity(s) for s in cfg.stages)[0] + \
            sorted(stage_capacity(s) for s in cfg.stages)[1]
    # without copies the feed means nothing: one design whatever its feed
    p.write_text('[replication]\nIC = { min = 1, max = 2 }\nfeed = { choices = ["shared", "round-robin"] }\n')
    sp = load_space(str(p))
    ic, fd = sp._pos["replication.IC"], sp._pos["replication.feed"]
    idx = [0] * len(sp.variables)
    for n_ic, feed, kept in ((0, 1, 0), (1, 1, 1)):
        idx[ic], idx[fd] = n_ic, feed
        assert sp.canonical(idx)[fd] == kept
    p.write_text('[replication]\nfeed = { choices = ["shared", "random"] }\n')
    with pytest.raises(SpaceError, match=r"replication\.feed: feed 'random' is not one of shared, round-robin"):
        load_space(str(p))
