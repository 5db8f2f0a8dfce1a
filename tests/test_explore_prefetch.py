"""The search's evaluator traces the space's grids ahead on a thread while the global phase
replays on one core (``SceneEvaluator.prefetch``): the traces are those made on demand, each
grid is made once, a grid that cannot be made fails where it is asked for, the thread ends before
the workers fork, and the explorer's answer does not depend on it."""
import numpy as np
import pytest

import mprt
from mprt.errors import InvalidArgument
from mprt.explore import load_space
from mprt.explore.evaluate import SceneEvaluator
from mprt.explore.explorer import _prefetch_order, explore
from mprt.explore.parallel import Pool
from mprt.explore.space import default_space

from test_explore_level3 import SMALL


def test_prefetched_traces_are_those_made_on_demand():
    scene = mprt.Scene.spd("balls", 1)
    dims = [(6, 6, 6), (2, 2, 2), (9, 9, 9), (4, 4, 4)]
    a = SceneEvaluator(scene, 24, 24, level=1)
    a.prefetch(dims)
    got = [a.evaluator(d)[0].trace for d in reversed(dims)]     # waited for, or made here first
    a.stop_prefetch()
    assert a.traces_made == len(dims)                           # each once, whichever thread made it
    b = SceneEvaluator(scene, 24, 24, level=1)
    for d, t in zip(reversed(dims), got):
        u = b.evaluator(d)[0].trace
        assert np.array_equal(t.visits, u.visits) and np.array_equal(t.rays, u.rays)
    assert a._prefetch is None and not a._pending


def test_a_grid_the_prefetch_cannot_make_fails_where_it_is_asked_for():
    a = SceneEvaluator(mprt.Scene.spd("balls", 1), 16, 16)
    a.prefetch([(0, 4, 4), (3, 3, 3)])
    a.stop_prefetch()
    with pytest.raises(InvalidArgument, match="subdivision 0x4x4"):
        a.evaluator((0, 4, 4))
    assert not a._pending and (0, 4, 4) not in a._held
    assert a.evaluator((3, 3, 3))[0].visits > 0


def test_the_pool_ends_threads_before_it_forks():
    pool = Pool(mprt.Scene.spd("tetra", 1), 2)
    calls = []
    pool.before_fork = lambda: calls.append(1)
    try:
        pool._executor()
        assert calls == [1]
    finally:
        pool.close()


def test_the_order_begins_in_the_middle_of_the_space():
    scene = mprt.Scene.spd("balls", 1)
    order = _prefetch_order(scene, default_space())
    ns = [4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256]
    assert len(order) == len(ns) and order[0] == _prefetch_order(scene, default_space().with_subdivision((32,)))[0]
    assert order[-1] == _prefetch_order(scene, default_space().with_subdivision((256,)))[0]


def test_the_explorer_finds_with_a_prefetch_what_one_process_finds(monkeypatch):
    made = []
    orig = SceneEvaluator.prefetch

    def prefetch(self, dims, runs=(), level=None):
        made.append(list(dims))
        orig(self, dims, runs, level)
    monkeypatch.setattr(SceneEvaluator, "prefetch", prefetch)
    scene = mprt.Scene.spd("tetra", 1)
    sp = load_space(SMALL)
    got = [explore(scene, 16, 16, space=sp, budget=400, level=3, max_evals=16, workers=w) for w in (1, 2)]
    assert len(made) == 1 and len(made[0]) == 1            # the two-worker run's search, its one grid
    for key in ("best", "references", "history", "evaluations"):
        assert got[0][key] == got[1][key], key


def test_a_prefetch_called_again_adds_to_its_list():
    scene = mprt.Scene.spd("balls", 1)
    a = SceneEvaluator(scene, 24, 24, level=1)
    a.prefetch([(6, 6, 6)])
    a.prefetch([(2, 2, 2), (6, 6, 6), (4, 4, 4)])       # joins the list, or starts a thread anew
    a._prefetch[0].join()                                # the thread ends with its list
    assert sorted(a._held) == [(2, 2, 2), (4, 4, 4), (6, 6, 6)] and a.traces_made == 3
    a.stop_prefetch()
    assert a._prefetch is None and not a._pending


def test_the_prefetch_makes_the_evaluator_let_go_of_no_trace():
    scene = mprt.Scene.spd("balls", 1)
    visits = SceneEvaluator(scene, 24, 24, level=1).evaluator((4, 4, 4))[0].visits
    a = SceneEvaluator(scene, 24, 24, level=1, max_visits=2 * visits)     # room for two such traces
    a.prefetch([(4, 4, 4), (5, 5, 5), (6, 6, 6)])
    a._prefetch[0].join()
    assert list(a._held) == [(4, 4, 4)] and a.traces_made == 1            # half the room taken: it stops
    a.stop_prefetch()


def _twice(ev, x):
    return ev * x


def test_the_pool_says_when_a_worker_has_nothing_left_to_take():
    """``Pool.map_forked``'s ``idle``: told the results so far once a worker is left without a task
    (at the start where tasks are fewer than workers), the results in order whatever it does."""
    pool = Pool(mprt.Scene.spd("tetra", 1), 2)
    seen = []
    assert pool.map_forked(_twice, 2, [(1,), (2,), (3,)], idle=lambda got: seen.append(got)) == [2, 4, 6]
    assert [len(g) for g in seen] == [2, 3] and seen[-1] == {0: 2, 1: 4, 2: 6}
    assert set(seen[0].items()) <= set(seen[-1].items())
    pool = Pool(mprt.Scene.spd("tetra", 1), 3)
    seen = []
    assert pool.map_forked(_twice, 3, [(1,), (2,)], idle=lambda got: seen.append(got)) == [3, 6]
    assert [len(g) for g in seen] == [0, 1, 2]


def test_the_checks_ahead_are_the_search_best_then_each_walk_best_then_the_best_known():
    from mprt.explore.evaluate import Result, grid_dims
    from mprt.explore.explorer import _checks_ahead
    from mprt.explore.search import Problem

    scene = mprt.Scene.spd("balls", 1)
    sp = default_space()
    i_sub = sp.names.index("subdivision.n")

    def point(k, fifo=0):
        idx = [0] * len(sp.variables)
        idx[i_sub], idx[sp.names.index("fifo")] = k, fifo
        return sp.point(tuple(idx))
    prob = Problem(sp, lambda pts: [], "time", 800.0)
    prob.add(point(8), Result(700.0, 3, 500.0))
    prob.add(point(9), Result(50.0, 3, 500.0), True)                 # a bound: no guess
    prob.add(point(10), Result(950.0, 3, 400.0))
    tasks = [(sp, "time", 800.0, [], sp.index_of(point(5)), 10, ()) for _ in range(3)]
    rows = {2: [(point(1), Result(900.0, 3, 500.0), False), (point(3), Result(300.0, 3, 500.0), False),
                (point(4), Result(10.0, 3, 500.0), True),          # known by its bound
                (point(6), Result(10.0, 3, 900.0), False)],        # over the budget
            1: [(point(5), Result(100.0, 3, 500.0), False), (point(3, 1), Result(600.0, 3, 500.0), False)],
            0: [(point(7), Result(450.0, 3, 500.0), False)]}     # over CHECK_BEHIND x the best: not checked
    dims, points = _checks_ahead(scene, sp, prob, tasks, 2, rows)
    want = [point(5), point(3)]             # the start; walk 2's best (walk 1's is the start); the best 2
    assert [p.key() for p in points] == [p.key() for p in want]
    assert dims == list(dict.fromkeys(grid_dims(scene, p.subdivision, sp.shape) for p in want))
    dims, points = _checks_ahead(scene, sp, prob, tasks, 3, rows)
    assert [p.key() for p in points] == [p.key() for p in (point(5), point(3), point(7))]
    dims, points = _checks_ahead(scene, sp, prob, tasks, 1, {})
    assert [p.key() for p in points] == [point(5).key(), point(8).key()]


def test_a_prefetched_run_is_the_run_made_on_demand():
    from mprt.explore.space import Point
    scene = mprt.Scene.spd("balls", 1)
    sp = default_space()
    pts = [Point((6,), sp.point(tuple([0] * len(sp.variables))).design),
           Point((4,), sp.point(tuple(min(1, v.size - 1) for v in sp.variables)).design)]
    a = SceneEvaluator(scene, 24, 24, level=3)
    a.prefetch([], runs=pts)
    a._prefetch[0].join()
    assert len(a._ran) == 2 and a.traces_made == 2
    got = [a.run(p) for p in pts]
    assert not a._ran                                           # each kept result handed out once
    b = SceneEvaluator(scene, 24, 24, level=3)
    assert got == [b.run(p) for p in pts] and got[0] is not a.run(pts[0])
    a.stop_prefetch()


def test_the_walks_trace_the_full_resolution_ahead_and_change_no_answer(monkeypatch):
    """Searching at 32x32 and polishing at 64x64 on two workers, the full-resolution evaluator is
    told what to trace ahead while the walks leave a core idle; the answer is one worker's."""
    asked = []
    orig = SceneEvaluator.prefetch

    def prefetch(self, dims, runs=(), level=None):
        asked.append((self.width, list(dims), list(runs)))
        orig(self, dims, runs, level)
    monkeypatch.setattr(SceneEvaluator, "prefetch", prefetch)
    scene = mprt.Scene.spd("tetra", 1)
    sp = load_space(SMALL)
    kw = dict(space=sp, budget=400, level=3, max_evals=16, fraction=2, refine_evals=20)
    got = [explore(scene, 64, 64, workers=w, **kw) for w in (1, 2)]
    full = [(dims, runs) for w, dims, runs in asked if w == 64]
    assert full and all(dims and runs for dims, runs in full)
    assert all(d in _prefetch_order(scene, sp) for dims, _ in full for d in dims)
    checks = {(tuple(r["subdivision"]), str(r["design"])) for r in got[1]["history"] if r["phase"] == "full-check"}
    assert any((p.subdivision, str(p.design.to_dict())) in checks for _, runs in full for p in runs)
    for key in ("best", "references", "history", "evaluations", "runs"):
        assert got[0][key] == got[1][key], key


def test_a_run_the_simpy_model_would_make_is_not_made_ahead(monkeypatch):
    import mprt.fidelity.levels as levels
    from mprt.explore.space import Point
    scene = mprt.Scene.spd("balls", 1)
    sp = default_space()
    p = Point((4,), sp.point(tuple([0] * len(sp.variables))).design)
    monkeypatch.setattr(levels, "unsupported", lambda cfg: "made up")     # every design to SimPy
    a = SceneEvaluator(scene, 24, 24, level=3)
    a.prefetch([(4, 4, 4)], runs=[p])
    a._prefetch[0].join()
    assert (4, 4, 4) in a._held and not a._ran                 # the grid traced, the run left
    a.stop_prefetch()
