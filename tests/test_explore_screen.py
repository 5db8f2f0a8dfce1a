"""The full-resolution polish screened by the search's low-resolution replay (``refine.Screen``):
against the polish without it and exhaustive enumeration at level 3, on the small space with
the golden traces (fewer ray trees standing for the low resolution)."""
from pathlib import Path
from types import SimpleNamespace

import pytest

import mprt
from mprt.explore import load_space
from mprt.explore.explorer import _bounds
from mprt.explore.hwcost import hardware_cost
from mprt.explore.refine import SCREEN_MARGIN, Screen
from mprt.explore.search import Problem, compass, exhaustive, search
from mprt.fidelity import sample_trace

from test_explore_level3 import _Memo

DATA = Path(__file__).parent / "data"
SMALL = DATA / "explore" / "small_space.toml"           # 222 designs: mappings, copies, units, PEs
GOLDEN = DATA / "golden"


@pytest.fixture(scope="module")
def traces():
    """Per scene (full, low): the trees of one tile in K of the golden trace, and in 2K
    (half as many rays, as the search's lower resolution has)."""
    out = {}
    for name, k in (("tetra", 2), ("balls", 16), ("mount", 8)):
        tr = mprt.load_trace(GOLDEN / f"{name}-g9.npz")
        out[name] = (_Memo(sample_trace(tr, f"runs:{k}:1").trace), _Memo(sample_trace(tr, f"runs:{2 * k}:1").trace))
    return out


def _polish(sp, full, budget, start, start_result, screen=None):
    cost_of = lambda p: hardware_cost(p.design)  # noqa: E731
    fp = Problem(sp, full(3), "time", budget, cost_of=cost_of, bound_points=lambda pts: _bounds(full(1)(pts)))
    if screen is not None:
        fp.bound_points = screen.bounder(fp, start_result.cycles, start.point, fp.bound_points)
    fp.add(start.point, start_result)
    compass(fp, start.index, 400)
    return fp


def test_screened_polish_keeps_the_exhaustive_optimum_in_fewer_full_replays(traces):
    """The search at level 3 on the low trace, then the polish at level 3 on the full trace from
    the search's best: with the screen it ends where it ends without (exhaustive enumeration's
    optimum on the full trace, where the polish without the screen reaches it), replaying fewer
    designs on the full trace; every design the screen ruled out is no better than the answer,
    and the errors it reports are those of the designs it let through."""
    sp = load_space(SMALL)
    cost_of = lambda p: hardware_cost(p.design)  # noqa: E731
    ran = {"plain": 0, "screened": 0}
    reached = 0
    for scene, budget in ((s, b) for s in traces for b in (None, 300.0, 500.0)):
        full, low = traces[scene]
        ex = Problem(sp, full(3), "time", budget)
        exhaustive(ex)
        lp = Problem(sp, low(3), "time", budget, cost_of=cost_of, bound_points=lambda pts: _bounds(low(1)(pts)))
        search(lp, "direct-l", "lattice", max_evals=20, seed=1)
        start = lp.best()
        start_full = full(3)([start.point])[0]
        plain = _polish(sp, full, budget, start, start_full)
        scr = Screen(lp, SimpleNamespace(run=lambda p, lv: low(lv)([p])[0]), 3, SCREEN_MARGIN)
        screened = _polish(sp, full, budget, start, start_full, scr)
        a, b = plain.best(), screened.best()
        print(f"{scene} budget {budget}: optimum {ex.best().cycles:,.0f}, polish {a.cycles:,.0f} "
              f"({plain.runs} replayed of {len(plain.memo)}), screened {b.cycles:,.0f} ({screened.runs} of "
              f"{len(screened.memo)}; {scr.report()})")
        assert (b.cycles, b.cost) == (a.cycles, a.cost)
        if (a.cycles, a.cost) == (ex.best().cycles, ex.best().cost):
            reached += 1
        for e in screened.memo.values():
            if e.bound:
                assert screened.rank(e)[:2] > screened.rank(b)[:2]
                assert ex.rank(ex.memo[e.index], budget)[:2] >= ex.rank(ex.memo[b.index], budget)[:2]
        ran["plain"] += plain.runs
        ran["screened"] += screened.runs
    assert reached >= 4             # of 9: the polish is a local search (where it reaches the optimum, so does the screen)
    assert ran["screened"] < ran["plain"]


def test_screen_errors_and_what_it_ruled_out_are_reported():
    """``Screen.report``: the margin, the designs ruled out by the estimate alone (here a wide
    margin, so level 1 rules out most), and the worst errors (full over estimate, less one) of
    the designs replayed."""
    sp = load_space(SMALL)
    tr = mprt.load_trace(GOLDEN / "tetra-g9.npz")
    full, low = _Memo(sample_trace(tr, "runs:2:1").trace), _Memo(sample_trace(tr, "runs:4:1").trace)
    lp = Problem(sp, low(3), "time", None)
    search(lp, "direct-l", "lattice", max_evals=20, seed=1)
    start = lp.best()
    scr = Screen(lp, SimpleNamespace(run=lambda p, lv: low(lv)([p])[0]), 3, 0.5)
    fp = _polish(sp, full, None, start, full(3)([start.point])[0], scr)
    scr.note(fp)
    r = scr.report()
    # the errors are known where the search replayed the design (a design it only bounded, or
    # never saw, has no exact low-resolution figure: the screen replays nothing of its own)
    ran = [e for e in fp.memo.values() if not e.bound and e.index != start.index
           and e.index in lp.memo and not lp.memo[e.index].bound]
    assert len(ran) < sum(not e.bound for e in fp.memo.values()) - 1      # some it never saw
    ratio = full(3)([start.point])[0].cycles / low(3)([start.point])[0].cycles
    errs = [e.cycles / (low(3)([e.point])[0].cycles * ratio) - 1 for e in ran]
    assert r["margin"] == 0.5 and r["checked"] == len(ran) >= 1
    assert r["ruled_out"] <= sum(e.bound for e in fp.memo.values())
    assert (r["worst_below"], r["worst_above"]) == (min(errs), max(errs))


def test_explore_with_the_screen_is_the_same_for_any_workers_and_keeps_the_answer():
    """``explore`` searching at 32x32 and polishing at 64x64 (level 3): with the screen, one and
    two workers give the same report (every history row), the answer is the one without the
    screen, and the report says what the screen did."""
    from mprt.explore.explorer import explore
    scene = mprt.Scene.spd("tetra", 1)
    sp = load_space(SMALL)
    kw = dict(space=sp, budget=400, level=3, max_evals=16, fraction=2, refine_evals=40)
    got = [explore(scene, 64, 64, workers=w, **kw) for w in (1, 2)]
    plain = explore(scene, 64, 64, workers=1, screen=None, **kw)
    for key in ("best", "references", "history", "evaluations", "runs", "screen"):
        assert got[0][key] == got[1][key], key
    s = got[0]["screen"]
    assert s["margin"] == SCREEN_MARGIN and s["ruled_out"] > 0 and s["checked"] >= 0
    assert plain["screen"] is None
    assert (got[0]["best"]["cycles"], got[0]["best"]["cost"]) == (plain["best"]["cycles"], plain["best"]["cost"])
    assert got[0]["runs"]["full"] <= plain["runs"]["full"]


def test_explore_leaves_no_cycle_holding_its_traces():
    """The screen's bounds refer to their polish weakly: with the garbage collector off, nothing
    the exploration made (its evaluators, which hold the traces) outlives it."""
    import gc

    from mprt.explore.evaluate import SceneEvaluator
    from mprt.explore.explorer import explore
    sp = load_space(SMALL)
    gc.collect()
    gc.disable()
    try:
        r = explore(mprt.Scene.spd("tetra", 1), 64, 64, space=sp, budget=400, level=3, max_evals=16, fraction=2,
                    refine_evals=40, workers=1)
        assert r["screen"] is not None
        assert not [o for o in gc.get_objects() if isinstance(o, SceneEvaluator)]
    finally:
        gc.enable()


def _refined(behind: float):
    """refine() on a made-up landscape: two subdivisions, the second's designs ``behind`` times
    the first's cycles; the subdivisions its full-resolution polish walked (both subdivisions
    among the twelve designs checked at full resolution)."""
    from mprt.explore.evaluate import Result
    from mprt.explore.refine import refine
    from mprt.explore.space import parse_space

    sp = parse_space('mapping = "OS+IC+SC"\npes = { min = 1, max = 4 }\nfifo = 16\n'
                     '[subdivision]\nn = { choices = [8, 16] }\nshape = "cube"\n'
                     '[replication]\nOS = { min = 1, max = 3 }\n[units.OS]\nint = 1\nfp = 1\n'
                     '[cache]\nIC = 0\nSC = 0\n[resident]\nIC = 0\nSC = 0\n')

    def cycles(p):
        base = 1000.0 * (behind if p.subdivision[0] == 16 else 1.0)
        return base / (p.design.pes * p.design.replication["OS"]) ** 0.5

    def run(pts, level=3):
        return [Result(cycles=cycles(p), level=level, cost=hardware_cost(p.design)) for p in pts]

    low = Problem(sp, run, "time", None)
    exhaustive(low)
    full = SimpleNamespace(level=3, width=8, height=8)
    pool = SimpleNamespace(workers=1, run=lambda ev, pts, lv: run(pts, lv))
    best, rows, n, ran = refine(low, sp, full, "time", None, 2, 10, 12, pool, lambda p: hardware_cost(p.design))
    return {r["subdivision"][0] for r in rows if r["phase"] == "full"} | {best.point.subdivision[0]}


def test_refine_polishes_a_second_subdivision_only_within_the_screen_margin():
    """The full-resolution polish starts from the second-best subdivision only if its best is
    within the screen's margin of the best: far behind, its walk cannot win and is not made."""
    assert _refined(1.0 / (1 - SCREEN_MARGIN) * 1.5) == {8}
    assert _refined(1.0 / (1 - SCREEN_MARGIN) * 0.9) == {8, 16}


def test_each_mapping_best_is_checked_unless_far_behind_the_best():
    """``refine.first_checks``: the search's ``verify`` best, then each stage mapping's best, but
    not one whose objective is more than CHECK_BEHIND times the best's (gears' 4x4x1 hedge)."""
    from mprt.explore.evaluate import Result
    from mprt.explore.refine import CHECK_BEHIND, first_checks
    from mprt.explore.space import parse_space

    sp = parse_space('mapping = { choices = ["OS|IC|SC", "OS+SC|IC", "OS|IC+SC", "OS+IC+SC"] }\n'
                     'pes = { min = 1, max = 2 }\nfifo = 16\n[subdivision]\nn = 8\nshape = "cube"\n'
                     '[replication]\nOS = 1\nIC = 1\nSC = 1\n[units.OS]\nint = 1\nfp = 1\n[units.IC]\nint = 1\n'
                     'fp = 1\n[units.SC]\ngeneral = 1\n[cache]\nIC = 0\nSC = 0\n[resident]\nIC = 0\nSC = 0\n')
    behind = {"OS+IC+SC": 1.0, "OS|IC+SC": 1.5, "OS+SC|IC": CHECK_BEHIND * 0.99, "OS|IC|SC": CHECK_BEHIND * 1.01}

    def run(pts):
        return [Result(cycles=1000.0 * behind[p.design.mapping] / p.design.pes, level=3, cost=100.0) for p in pts]
    low = Problem(sp, run, "time", None)
    exhaustive(low)
    got = [(e.point.design.mapping, e.point.design.pes) for e in first_checks(low, 2)]
    assert got == [("OS+IC+SC", 2), ("OS|IC+SC", 2), ("OS+SC|IC", 2)]     # the two best; a mapping within
