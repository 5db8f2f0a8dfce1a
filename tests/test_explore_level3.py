"""The explorer at the level its answer is judged by: the search at level 3 (memories free) against
exhaustive enumeration there, the polish's trades, workers, and the prepass for a named machine."""
import argparse
import json
from pathlib import Path

import pytest

import mprt
from mprt.explore import load_space
from mprt.explore.evaluate import TraceEvaluator
from mprt.explore.hwcost import hardware_cost
from mprt.explore.search import Problem, compass, exhaustive, search
from mprt.fidelity import sample_trace

DATA = Path(__file__).parent / "data"
MEMORY = DATA / "explore" / "memory_space.toml"          # caches, FIFOs, copies: 60 designs
SMALL = DATA / "explore" / "small_space.toml"
GOLDEN = DATA / "golden"


class _Memo:
    """Evaluations of one trace, each design once per level (exhaustive enumeration and the
    searches share them; every Problem still counts its own distinct designs)."""

    def __init__(self, trace):
        self.ev, self.got = TraceEvaluator(trace), {}

    def __call__(self, level):
        def f(pts):
            out = []
            for p in pts:
                k = (p.key(), level)
                if k not in self.got:
                    self.got[k] = self.ev.run(p.design, level)
                out.append(self.got[k])
            return out
        return f


@pytest.fixture(scope="module")
def runs():
    """Runs of trees from three golden traces (``runs:K``: about 700 to 1000 visits each, so that
    SimPy's level 3 enumerates the space in seconds)."""
    return {name: _Memo(sample_trace(mprt.load_trace(GOLDEN / f"{name}-g9.npz"), spec).trace)
            for name, spec in (("tetra", "runs:4:1"), ("balls", "runs:32:1"), ("mount", "runs:16:1"))}


@pytest.mark.parametrize("scene", ["tetra", "balls", "mount"])
def test_search_finds_exhaustive_optimum_at_level_3(runs, scene):
    """The explorer's method (DIRECT-L, 20 global evaluations, the lattice polish with its trades,
    costs known before evaluating) at level 3, over a space whose memory sizes, FIFOs and copies
    are all free, finds the design exhaustive enumeration finds at level 3, in fewer evaluations;
    and level 1 (blind to the memories) would have chosen a slower design there at least once."""
    sp = load_space(MEMORY)
    memo = runs[scene]
    cost_of = lambda p: hardware_cost(p.design)  # noqa: E731
    blind = 0
    for budget in (None, 250.0, 350.0):
        ex = Problem(sp, memo(3), "time", budget)
        exhaustive(ex)
        p = Problem(sp, memo(3), "time", budget, cost_of=cost_of)
        r = search(p, "direct-l", "lattice", max_evals=20, seed=1)
        print(f"{scene} budget {budget}: exhaustive {ex.best().cycles:,.0f} ({len(ex.memo)} designs), "
              f"search {r.best.cycles:,.0f} ({r.evaluations}: {r.phases})")
        assert r.best.cycles == ex.best().cycles and r.best.cost == ex.best().cost
        assert r.evaluations < len(ex.memo)
        if budget is not None:
            assert r.best.cost <= budget
        one = Problem(sp, memo(1), "time", budget)
        exhaustive(one)
        blind += memo(3)([one.best().point])[0].cycles > ex.best().cycles
    assert blind > 0


def test_trades_under_a_budget_reach_what_single_steps_cannot():
    """From a design at the budget's edge, the better design one copy more and two caches
    smaller is three indices away: the trades reach it; no design over the budget is evaluated."""
    sp = load_space(MEMORY)
    names = sp.names
    pos = {n: names.index(n) for n in ("mapping", "replication.OS", "replication.IC", "cache.IC", "cache.SC")}
    evaluated = []

    class R:
        def __init__(self, cycles, cost):
            self.cycles, self.cost = cycles, cost

    def f(pts):
        out = []
        for p in pts:
            d = p.design
            evaluated.append(hardware_cost(d))
            # copies speed it up far more than caches
            out.append(R(1e6 / (d.replication["OS"] * d.replication["IC"]) / (1 + 0.01 * (d.cache["IC"] + d.cache["SC"])),
                         hardware_cost(d)))
        return out

    start = [0] * len(names)
    start[pos["replication.OS"]], start[pos["cache.IC"]], start[pos["cache.SC"]] = 1, 1, 1
    start = sp.canonical(start)
    budget = hardware_cost(sp.point(start).design) + 1.0
    p = Problem(sp, f, "time", budget, cost_of=lambda pt: hardware_cost(pt.design))
    p.evaluate_many([start])
    end = compass(p, start, 50, fixed=(pos["mapping"],))
    d = sp.point(end).design
    assert d.replication["IC"] == 2 and d.cache == {"IC": 0, "SC": 0}
    assert max(evaluated) <= budget
    # without the costs beforehand (no trades, only +1/-1 pairs) the polish stays where it began
    q = Problem(sp, f, "time", budget)
    q.evaluate_many([start])
    assert compass(q, start, 50, fixed=(pos["mapping"],)) == start


def test_trades_are_every_minimal_repair_of_up_to_two_steps_down():
    """On the built-in space under a budget (costs only, no trace), from designs within it: each
    step up that does not fit comes with every repair of up to two steps down (-1 on one other
    index, -2 on one, -1 on two) that brings it within the budget and has no smaller repair
    inside it, and with no other; a step up that fits comes alone."""
    import numpy as np

    from mprt.explore import default_space
    from mprt.explore.search import _trades

    sp = default_space()
    cost_of = lambda pt: hardware_cost(pt.design)  # noqa: E731
    sizes = [v.size for v in sp.variables]
    num = [i for i in range(len(sizes)) if sizes[i] > 1 and not isinstance(sp.variables[i].values[0], str)]
    rng = np.random.default_rng(3)
    checked = pairs = 0
    while checked < 25:
        cur = sp.canonical([int(rng.integers(s)) for s in sizes])
        budget = cost_of(sp.point(cur)) + float(rng.choice([0.0, 20.0, 60.0]))
        p = Problem(sp, None, "time", budget, cost_of=cost_of)
        fits = lambda nb: not p.over_budget(sp.canonical(nb))  # noqa: E731
        want = set()
        for i in num:
            if cur[i] + 1 >= sizes[i]:
                continue
            up = list(cur)
            up[i] += 1
            if fits(up):
                want.add(sp.canonical(up))
                continue
            moved = lambda steps: [c - steps.get(j, 0) for j, c in enumerate(up)]  # noqa: E731
            repairs = [{j: 1} for j in num if j != i] + [{j: 2} for j in num if j != i] + \
                [{j: 1, k: 1} for a, j in enumerate(num) for k in num[a + 1:] if i not in (j, k)]
            for r in repairs:
                nb = moved(r)
                if min(nb[j] for j in r) < 0 or not fits(nb):
                    continue
                smaller = [{j: 1} for j in r] if sum(r.values()) == 2 else []
                if not any(fits(moved(s)) for s in smaller):
                    want.add(sp.canonical(nb))
                    pairs += len(r) == 2
        got = []
        _trades(p, cur, num, sizes, got.append)
        assert {sp.canonical(k) for k in got} == want
        assert all(not p.over_budget(sp.canonical(k)) for k in got)
        checked += 1
    assert pairs > 0            # some designs needed a repair on two indices


def test_a_cheap_repair_does_not_hide_the_trade_that_keeps_the_pes():
    """Mount at 512x512 under 800 kGE: from two copies of (2 int + 3 fp) with 4 KiB caches on 2 PEs
    (792 kGE), a third copy fits only by dropping a PE (594 kGE, slower) or by one fp unit and
    the SC cache together (756 kGE: 2.31e8 cycles against 3.20e8 at level 3); the polish,
    here on a stand-in for the replay (copies and up to 2 PEs speed it up, caches and fp units a
    little), takes the latter."""
    from mprt.explore import default_space
    from mprt.explore.space import Design, Point

    sp = default_space()
    names = sp.names

    class R:
        def __init__(self, cycles, cost):
            self.cycles, self.cost = cycles, cost

    def f(pts):
        return [R(1e6 / (p.design.replication["OS"] * min(p.design.pes, 2)) * (1 + 0.05 / p.design.units["OS"]["fp"])
                  * (1 + 0.01 * (p.design.cache["SC"] == 0) + 0.5 * (p.design.cache["IC"] == 0)),
                  hardware_cost(p.design)) for p in pts]

    d = Design(mapping="OS+IC+SC", replication={"OS": 2, "IC": 1, "SC": 1}, feed="shared",
               units={"OS": {"int": 2, "fp": 3}, "IC": {"int": 1, "fp": 1}, "SC": {"general": 1}}, fifo=16,
               cache={"IC": 4, "SC": 4}, resident={"IC": 0, "SC": 0}, pes=2)
    start = sp.canonical(sp.index_of(Point((64, 64, 64), d)))
    assert hardware_cost(d) == 792.0
    p = Problem(sp, f, "time", 800.0, cost_of=lambda pt: hardware_cost(pt.design))
    p.evaluate_many([start])
    fixed = tuple(names.index(n) for n in ("mapping", "subdivision.nx", "subdivision.ny", "subdivision.nz"))
    end = sp.point(compass(p, start, 60, fixed=fixed)).design
    assert (end.replication["OS"], end.pes, end.cache["IC"]) == (3, 2, 4)
    assert hardware_cost(end) <= 800.0


def test_one_and_two_workers_give_the_same_answer():
    """The ladder's designs, the subdivisions' descents, the search's machines on two scenes, the
    full-resolution checks and the references on two worker processes: every evaluation, and so
    the answer, the same as in this process."""
    from mprt.explore.explorer import FidelitySettings, Resources, SearchSettings, explore
    from mprt.explore.workload import workload_of
    sp = load_space(SMALL)
    got = [explore(workload_of(["tetra:1", "balls:1"]), sp, SearchSettings(budget=400, max_evals=16),
                   FidelitySettings(level="auto"), Resources(workers=w)).to_json() for w in (1, 2)]
    assert got[0]["workers"] == 1 and got[1]["workers"] == 2
    for key in ("best", "per_scene", "references", "history", "level", "front"):
        a, b = got[0][key], got[1][key]
        if key == "level":
            a, b = ({k: v for k, v in x.items() if k != "ladder_seconds"} for x in (a, b))
            for x in (a, b):
                for row in x.get("ladder", []) + [r for s in x.get("per_scene", []) for r in s["ladder"]]:
                    row.pop("seconds_per_design", None)
        assert a == b, key


def _run(*argv):
    from mprt.explore.cli import add_parsers
    p = argparse.ArgumentParser(prog="mprt")
    add_parsers(p.add_subparsers(dest="cmd", required=True))
    a = p.parse_args([str(x) for x in argv])
    return a.func(a)


def test_prepass_for_the_machine_named_at_the_level_trusted(tmp_path):
    """--model/--config name the machine; --level auto takes the lowest level of its ladder within
    the tolerance; --level N replays there; the predictions are that machine's cycles at that level."""
    from mprt.explore.evaluate import grid_dims
    from mprt.machine.config import builtin, load_config
    scene = mprt.Scene.spd("tetra", 1)
    out = tmp_path / "p.json"
    assert _run("prepass", "tetra:1", "--res", "64x64", "--fraction", "2", "--candidates", "3,6", "--model",
                "3mppe", "--json", out) == 0
    r = json.loads(out.read_text())
    ok = [row["level"] for row in r["ladder"] if row["error_top_worst"] <= 0.01]
    assert r["machine"] == "3mppe" and r["level"] == (min(ok) if ok else 3)
    cfg = tmp_path / "m.toml"
    cfg.write_text('base = "3mppe"\nname = "mine"\npes = 1\n')
    assert _run("prepass", "tetra:1", "--res", "64x64", "--fraction", "2", "--candidates", "3,6", "--config", cfg,
                "--level", "3", "--json", out) == 0
    r = json.loads(out.read_text())
    assert r["machine"] == "mine" and r["level"] == 3 and r["ladder"] is None
    mine = load_config(str(cfg))
    for c in r["candidates"]:
        tr = scene.grid(tuple(c["subdivision"])).trace(32, 32)[1]
        assert c["predicted_cycles"] == TraceEvaluator(tr, counted=False).run_config(mine, 3).cycles * 4
    assert [tuple(c["subdivision"]) for c in r["candidates"]] == sorted(grid_dims(scene, (n,), "proportional")
                                                                         for n in (3, 6))
    assert mine.pes != builtin("3mppe").pes           # the file's machine, not the default one
    with pytest.raises(mprt.MprtError, match="--model or --config, not both"):
        _run("prepass", "tetra:1", "--model", "M", "--config", cfg)


@pytest.mark.parametrize("scene", ["tetra", "balls", "mount"])
def test_level_1_bounds_keep_the_answer_in_fewer_level_3_runs(runs, scene):
    """With each design first bounded at level 1 (``explorer._bounds``: less the slack), the search
    finds what it finds replaying every design at level 3, exhaustive enumeration's optimum, while
    replaying fewer designs there; a design kept with its bound was never better than the answer."""
    from mprt.explore.explorer import slack_bounds as _bounds
    sp = load_space(MEMORY)
    memo = runs[scene]
    cost_of = lambda p: hardware_cost(p.design)  # noqa: E731
    ran = {"plain": 0, "bounded": 0}
    for budget in (None, 250.0, 350.0):
        ex = Problem(sp, memo(3), "time", budget)
        exhaustive(ex)
        plain = Problem(sp, memo(3), "time", budget, cost_of=cost_of)
        a = search(plain, "direct-l", "lattice", max_evals=20, seed=1)
        bounded = Problem(sp, memo(3), "time", budget, cost_of=cost_of, bound_points=lambda pts: _bounds(memo(1)(pts)))
        b = search(bounded, "direct-l", "lattice", max_evals=20, seed=1)
        print(f"{scene} budget {budget}: {plain.runs} designs replayed at level 3 without bounds, "
              f"{bounded.runs} of {len(bounded.memo)} with them")
        assert (b.best.cycles, b.best.cost) == (a.best.cycles, a.best.cost) == (ex.best().cycles, ex.best().cost)
        assert not b.best.bound
        for e in bounded.memo.values():
            if e.bound:
                exact = memo(3)([e.point])[0]
                assert e.cycles <= exact.cycles
                assert bounded.rank(e)[:2] > bounded.rank(b.best)[:2]
        ran["plain"] += plain.runs
        ran["bounded"] += bounded.runs
    assert ran["bounded"] < ran["plain"]


def test_work_bounds_in_the_polish_keep_its_steps_with_no_level_1_replay(runs):
    """From the lattice polish on, the explorer's bounds are work bounds (``search(polish_bounds=)``,
    ``TraceEvaluator.work_bound``: nothing run).  Bounds decide which designs are replayed, not the
    polish's steps: the search evaluates the same designs in the same order, and reaches the same
    answer, as with level-1 bounds throughout, and replays no design at level 1 after the global
    phase; a design known by its work bound is below its level-3 cycles and behind the answer."""
    from mprt.explore.explorer import slack_bounds as _bounds
    sp = load_space(MEMORY)
    cost_of = lambda p: hardware_cost(p.design)  # noqa: E731
    by_work = 0
    for scene in ("tetra", "balls", "mount"):
        memo = runs[scene]
        level1 = lambda pts: _bounds(memo(1)(pts))  # noqa: E731
        for budget in (None, 250.0, 350.0):
            a = Problem(sp, memo(3), "time", budget, cost_of=cost_of, bound_points=level1)
            ra = search(a, "direct-l", "lattice", max_evals=20, seed=1)
            calls = {"level1": 0, "at_polish": None}

            def counted(pts):
                calls["level1"] += len(pts)
                return level1(pts)

            def work(pts):
                if calls["at_polish"] is None:
                    calls["at_polish"] = calls["level1"]
                return [memo.ev.work_bound(p.design, 3) for p in pts]
            b = Problem(sp, memo(3), "time", budget, cost_of=cost_of, bound_points=counted)
            rb = search(b, "direct-l", "lattice", max_evals=20, seed=1, polish_bounds=work)
            assert (rb.best.cycles, rb.best.cost, rb.best.index) == (ra.best.cycles, ra.best.cost, ra.best.index)
            assert b.order == a.order
            assert calls["at_polish"] is not None and calls["level1"] == calls["at_polish"] > 0
            for k in b.order:
                x, y = b.memo[k], a.memo[k]
                assert x.bound or y.bound or x.cycles == y.cycles
                if x.bound:
                    assert x.cycles <= memo(3)([x.point])[0].cycles
                    assert b.rank(x)[:2] > b.rank(rb.best)[:2]
                    by_work += x.result.engine == "work bound"
    assert by_work > 0      # (tetra 15, balls 8, mount 0 when written)


@pytest.mark.parametrize("scene", ["tetra", "balls", "mount"])
def test_walks_on_the_search_state_take_the_steps_of_walks_one_after_another(runs, scene):
    """The polish's walks from each mapping's start, each on a problem of its own that knows only
    the search before the walks (``search.walk``: what the explorer's workers run), evaluate the
    designs and reach the answer of the walks made one after another on the shared problem: the
    mappings' walks share no design, and bounds decide which designs are replayed, not the steps.
    A design merged as known by its bound is never better than the answer."""
    from mprt.explore.explorer import slack_bounds as _bounds
    from mprt.explore.search import walk
    sp = load_space(SMALL)
    memo = runs[scene]
    cost_of = lambda p: hardware_cost(p.design)  # noqa: E731
    bound = lambda pts: _bounds(memo(1)(pts))  # noqa: E731
    walked = 0
    for budget in (None, 300.0):
        seq = Problem(sp, memo(3), "time", budget, cost_of=cost_of, bound_points=bound)
        a = search(seq, "direct-l", "lattice", max_evals=24, seed=1)
        par = Problem(sp, memo(3), "time", budget, cost_of=cost_of, bound_points=bound)
        tasks = []

        def run_walks(ts):
            tasks.extend(ts)
            return [walk(memo(3), *t, bound_points=bound, cost_of=cost_of) for t in ts]
        b = search(par, "direct-l", "lattice", max_evals=24, seed=1, run_walks=run_walks)
        walked += len(tasks)
        assert (b.best.cycles, b.best.cost, b.best.index) == (a.best.cycles, a.best.cost, a.best.index)
        assert par.order == seq.order
        for k in par.order:
            x, y = par.memo[k], seq.memo[k]
            assert x.serial == y.serial
            assert x.bound or y.bound or x.cycles == y.cycles
            if x.bound:
                assert par.rank(x)[:2] > par.rank(b.best)[:2]
    assert walked >= 4
