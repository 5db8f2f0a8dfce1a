"""The invariants of a trace: every ray's visits form a legal 3MPRT path.

``check(trace)`` raises ``TraceError`` naming the first broken rule:

- ray ids are 0..n-1 in order, and each ray's visits are one contiguous run;
- a ray starts at OS, and each visit is followed only by a visit the pipeline
  allows (OS->IC->OS ... ->SC), ending in a final outcome;
- shadow rays end blocked (IC) or lit (SC), other rays never do;
- primary rays and only they have no parent; a child starts after its
  parent's SC visit, is not shallower, belongs to the same pixel, and each SC
  visit's ``made`` equals its number of children;
- the counts add up: every OS->IC handoff is an IC visit, tests only in IC
  visits, voxel steps only in OS visits.
"""
from __future__ import annotations

import numpy as np

from ._lowlevel import Outcome, RayKind, Stage
from .errors import TraceError

OS, IC, SC = Stage.OS, Stage.IC, Stage.SC
O = Outcome

# allowed (stage, outcome) of a visit followed by the next visit of the same ray
NEXT = {
    (OS, O.TO_IC): {(IC, O.HIT), (IC, O.BLOCKED), (IC, O.RETURN)},
    (IC, O.RETURN): {(OS, O.TO_IC), (OS, O.LEFT), (OS, O.TO_SC), (OS, O.LATE_HIT)},
    (IC, O.HIT): {(SC, O.SHADED)},
    (OS, O.TO_SC): {(SC, O.LIT)},
    (OS, O.LATE_HIT): {(SC, O.SHADED)},
}
# (stage, outcome) a ray may end with
LAST = {(OS, O.LEFT), (IC, O.BLOCKED), (SC, O.SHADED), (SC, O.LIT)}

_CODES = 16  # stage * _CODES + outcome indexes the tables below
if len(Outcome) > _CODES:
    raise ImportError("more outcomes than the invariant tables hold")


def _code(stage, outcome):
    return int(stage) * _CODES + int(outcome)


def _fail(msg):
    raise TraceError(f"trace invariant broken: {msg}")


def _name(v, i) -> str:
    return f"{Stage(v['stage'][i]).name}/{Outcome(v['outcome'][i]).name.lower()}"


def _check_paths(v, n):
    """Grouping, first stage, transitions and last outcomes; returns (run starts, their rays)."""
    same = v["ray"][1:] == v["ray"][:-1]
    starts = np.flatnonzero(np.concatenate([[True], ~same]))
    run_rays = v["ray"][starts]
    if len(np.unique(run_rays)) != len(run_rays):
        _fail("a ray's visits are not contiguous")
    if len(run_rays) != n or not np.array_equal(np.sort(run_rays), np.arange(n)):
        _fail("every ray must have visits, and every visit a ray")
    if np.any(v["stage"][starts] != OS):
        _fail(f"ray {int(run_rays[np.argmax(v['stage'][starts] != OS)])} does not start at OS")
    code = v["stage"].astype(np.int64) * _CODES + v["outcome"]
    size = len(Stage) * _CODES
    allowed = np.zeros((size, size), dtype=bool)
    for (s0, o0), nxt in NEXT.items():
        for s1, o1 in nxt:
            allowed[_code(s0, o0), _code(s1, o1)] = True
    bad = same & ~allowed[code[:-1], code[1:]]
    if bad.any():
        i = int(np.argmax(bad))
        _fail(f"ray {int(v['ray'][i])}: {_name(v, i)} followed by {_name(v, i + 1)}")
    ends = np.concatenate([starts[1:] - 1, [len(v) - 1]])
    last_ok = np.zeros(size, dtype=bool)
    for s, o in LAST:
        last_ok[_code(s, o)] = True
    if not last_ok[code[ends]].all():
        i = ends[np.argmax(~last_ok[code[ends]])]
        _fail(f"ray {int(v['ray'][i])} ends with {_name(v, i)}")
    return code, starts, run_rays


def _check_family(rays, v, starts, run_rays):
    """Parents, children, depths, pixels and SC's 'made'."""
    n = len(rays)
    primary = rays["kind"] == RayKind.PRIMARY
    if np.any(primary != (rays["parent"] < 0)):
        _fail("primary rays and only they have no parent")
    sc_idx = np.full(n, -1, dtype=np.int64)
    sc_pos = np.flatnonzero(v["stage"] == SC)
    sc_idx[v["ray"][sc_pos]] = sc_pos
    first = np.empty(n, dtype=np.int64)
    first[run_rays] = starts
    kids = np.flatnonzero(~primary)
    parents = rays["parent"][kids]
    if np.any(sc_idx[parents] < 0) or np.any(first[kids] <= sc_idx[parents]):
        _fail("a child ray starts before its parent's SC visit")
    if np.any(rays["depth"][kids] < rays["depth"][parents]):
        _fail("a child is shallower than its parent")
    made = np.bincount(parents, minlength=n)
    sc_made = np.zeros(n, dtype=np.int64)
    sc_made[v["ray"][sc_pos]] = v["made"][sc_pos]
    if not np.array_equal(made, sc_made):
        _fail("an SC visit's 'made' differs from its number of children")
    if np.any(rays["pixel"][kids] != rays["pixel"][parents]):
        _fail("a child belongs to another pixel than its parent")


def check(trace) -> None:
    """Validate a trace's invariants (see the module's text); raise TraceError naming the
    first broken one."""
    rays, v = trace.rays, trace.visits
    n = len(rays)
    if not np.array_equal(rays["id"], np.arange(n)):
        _fail("ray ids are not 0..n-1 in order")
    if len(v) == 0:
        if n:
            _fail("rays without visits")
        return
    code, starts, run_rays = _check_paths(v, n)
    shadow = rays["kind"][v["ray"]] == RayKind.SHADOW
    if np.any(shadow & np.isin(code, [_code(IC, O.HIT), _code(SC, O.SHADED), _code(OS, O.LEFT)])):
        _fail("a shadow ray was shaded or left the space as a primary/secondary ray")
    if np.any(~shadow & np.isin(code, [_code(IC, O.BLOCKED), _code(SC, O.LIT), _code(OS, O.TO_SC)])):
        _fail("a primary or secondary ray was blocked or lit like a shadow ray")
    _check_family(rays, v, starts, run_rays)
    if np.sum(code == _code(OS, O.TO_IC)) != np.sum(v["stage"] == IC):
        _fail("OS->IC handoffs and IC visits differ")
    if np.any(v["tests"][v["stage"] != IC] != 0) or np.any(v["steps"][v["stage"] != OS] != 0):
        _fail("tests outside IC or voxels outside OS")
