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

The check runs in bounded memory, whatever the trace's size.  The visits are
read in chunks and cut into *blocks*: the shortest runs of whole rays whose
ids are exactly the next ids not yet seen (rays r0..r1-1, in any order).  A
tracer makes one sample's ray tree at a time, so a block is about one sample's
rays; every rule about a ray and its family is checked inside its block with
arrays of the block's size.  Only two things cross blocks: sums (handoffs and
IC visits), and each SC visit's ``made`` against children that may lie in later
blocks.  Those are compared as a count and a 64-bit fingerprint (the sum over
children of a hash of the parent id against the sum over SC visits of made
times the hash of the ray): equal for a correct trace, and unequal for a wrong
one except with probability about 2^-64; when they differ, two more passes
find the first ray at fault, to name it.  Pages of a memory-mapped trace are
released as soon as a chunk is done (``pages.chunks``), so the resident set stays
near the chunk size instead of growing to the file's.

Readers (``load_trace(invariants=True)``, ``Trace.validate``) check the same rules in C first,
with the ranges, in one pass (``mprt.recordcheck``); this module then runs only on a trace C
found at fault, to name the fault in its words (``settle``).
"""
from __future__ import annotations

import numpy as np

from .._lowlevel import Outcome, RayKind, Stage
from ..errors import TraceError
from ..util.pages import chunks, release

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
CHUNK = 1 << 18   # visits read at a time (about 10 MB of records)


def _code(stage, outcome):
    return int(stage) * _CODES + int(outcome)


def _table(pairs) -> np.ndarray:
    t = np.zeros(len(Stage) * _CODES, dtype=bool)
    for s, o in pairs:
        t[_code(s, o)] = True
    return t


_ALLOWED = np.zeros((len(Stage) * _CODES,) * 2, dtype=bool)
for (_s0, _o0), _nxt in NEXT.items():
    for _s1, _o1 in _nxt:
        _ALLOWED[_code(_s0, _o0), _code(_s1, _o1)] = True
_LAST_OK = _table(LAST)
_SHADOW_ONLY = _table([(IC, O.BLOCKED), (SC, O.LIT), (OS, O.TO_SC)])
_NEVER_SHADOW = _table([(IC, O.HIT), (SC, O.SHADED), (OS, O.LEFT)])


def _fail(msg):
    raise TraceError(f"trace invariant broken: {msg}")


def _name(v, i) -> str:
    return f"{Stage(v['stage'][i]).name}/{Outcome(v['outcome'][i]).name.lower()}"


def _fingerprint(ids: np.ndarray) -> np.ndarray:
    """A 64-bit hash of each id (splitmix64's finaliser), wrapping uint64 arithmetic."""
    z = ids.astype(np.uint64) + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def _usum(x: np.ndarray) -> int:
    return int(np.sum(x, dtype=np.uint64))


# -- blocks of whole rays --------------------------------------------------------------------------
def _run_starts(ray: np.ndarray) -> np.ndarray:
    return np.flatnonzero(np.concatenate([[True], ray[1:] != ray[:-1]]))


def _blocks(visits, n: int, chunk: int):
    """(block visits, r0, r1, run starts in the block): the visits cut into blocks holding every
    visit of rays r0..r1-1 and no other; the last block ends at ray n."""
    pending = visits[:0].copy()
    r0 = 0
    for pos, piece in chunks(visits, chunk):
        buf = np.concatenate([pending, piece]) if len(pending) else piece
        at_end = pos + len(piece) >= len(visits)
        starts = _run_starts(buf["ray"])
        run_rays = buf["ray"][starts].astype(np.int64)
        m = len(starts) if at_end else len(starts) - 1     # the last run may go on in the next chunk
        if np.any(run_rays[:m] < r0):
            j = int(np.argmax(run_rays[:m] < r0))
            if run_rays[j] < 0:
                _fail("every ray must have visits, and every visit a ray")
            _fail(f"ray {run_rays[j]}: its visits are not contiguous")
        if at_end:
            k = m - 1
        else:
            closes = np.flatnonzero(np.maximum.accumulate(run_rays[:m]) == r0 + np.arange(m))
            if not closes.size:
                pending = buf          # no block ends here yet: read on
                continue
            k = int(closes[-1])
        end = int(starts[k + 1]) if k + 1 < len(starts) else len(buf)
        r1 = n if at_end else r0 + k + 1
        yield buf[:end], r0, r1, starts[:k + 1]
        pending, r0 = buf[end:], r1
    if r0 < n:                         # rays after the last visit (or no visits at all)
        _fail("every ray must have visits, and every visit a ray")


class _Totals:
    """What crosses blocks: sums, and the parent fingerprints for SC's 'made'."""

    def __init__(self):
        self.to_ic = self.ic = 0
        self.kids = self.made = 0       # counts
        self.kids_fp = self.made_fp = 0  # fingerprints, mod 2^64


def _check_paths(v, starts, run_rays, m):
    """Grouping, first stage, transitions and last outcomes of one block; returns the visit codes."""
    if np.any(run_rays >= m):
        _fail("every ray must have visits, and every visit a ray")
    per_ray = np.bincount(run_rays, minlength=m)
    if np.any(per_ray > 1):
        _fail(f"ray {int(v['ray'][starts][np.argmax(per_ray[run_rays] > 1)])}: its visits are not contiguous")
    if np.any(per_ray == 0):
        _fail("every ray must have visits, and every visit a ray")
    if np.any(v["stage"][starts] != OS):
        _fail(f"ray {int(v['ray'][starts][np.argmax(v['stage'][starts] != OS)])} does not start at OS")
    code = v["stage"].astype(np.int64) * _CODES + v["outcome"]
    same = v["ray"][1:] == v["ray"][:-1]
    bad = same & ~_ALLOWED[code[:-1], code[1:]]
    if bad.any():
        i = int(np.argmax(bad))
        _fail(f"ray {int(v['ray'][i])}: {_name(v, i)} followed by {_name(v, i + 1)}")
    ends = np.concatenate([starts[1:] - 1, [len(v) - 1]])
    if not _LAST_OK[code[ends]].all():
        i = ends[np.argmax(~_LAST_OK[code[ends]])]
        _fail(f"ray {int(v['ray'][i])} ends with {_name(v, i)}")
    return code


def _check_family(rays, rb, r0, v, starts, run_rays, tot):
    """Parents, children, depths, pixels of one block (rays r0.. held in rb); SC's 'made' into
    the totals."""
    n, m = len(rays), len(rb)
    primary = rb["kind"] == RayKind.PRIMARY
    if np.any(primary != (rb["parent"] < 0)):
        _fail("primary rays and only they have no parent")
    kids = np.flatnonzero(~primary)
    parents = rb["parent"][kids].astype(np.int64)
    if np.any(parents >= n):
        i = int(np.argmax(parents >= n))
        _fail(f"ray {r0 + int(kids[i])} has parent {int(parents[i])}, which is not a ray")
    if np.any(parents >= r0 + m):   # the parent's visits come in a later block
        _fail("a child ray starts before its parent's SC visit")
    inside = parents >= r0
    p, c = parents[inside] - r0, kids[inside]
    sc_pos = np.flatnonzero(v["stage"] == SC)
    sc_idx = np.full(m, -1, dtype=np.int64)
    sc_idx[v["ray"][sc_pos] - r0] = sc_pos
    first = np.empty(m, dtype=np.int64)
    first[run_rays] = starts
    if np.any(sc_idx[p] < 0) or np.any(first[c] <= sc_idx[p]):
        _fail("a child ray starts before its parent's SC visit")
    depth, pixel = np.empty(len(kids), dtype=rb["depth"].dtype), np.empty(len(kids), dtype=rb["pixel"].dtype)
    depth[inside], pixel[inside] = rb["depth"][p], rb["pixel"][p]
    if not inside.all():            # parents in earlier blocks: read just those records
        ids = np.unique(parents[~inside])
        outer = np.asarray(rays[ids])
        release(rays[ids[0]:ids[-1] + 1])
        at = np.searchsorted(outer["id"], parents[~inside])
        depth[~inside], pixel[~inside] = outer["depth"][at], outer["pixel"][at]
    if np.any(rb["depth"][kids] < depth):
        _fail("a child is shallower than its parent")
    if np.any(rb["pixel"][kids] != pixel):
        _fail("a child belongs to another pixel than its parent")
    made = v["made"][sc_pos].astype(np.uint64)
    with np.errstate(over="ignore"):
        tot.kids += len(kids)
        tot.kids_fp = (tot.kids_fp + _usum(_fingerprint(parents))) % (1 << 64)
        tot.made += int(made.sum())
        tot.made_fp = (tot.made_fp + _usum(made * _fingerprint(v["ray"][sc_pos]))) % (1 << 64)


def _check_block(rays, v, r0, r1, starts, tot):
    rb = np.array(rays[r0:r1])
    release(rays[r0:r1])
    run_rays = v["ray"][starts].astype(np.int64) - r0
    code = _check_paths(v, starts, run_rays, r1 - r0)
    shadow = rb["kind"][v["ray"] - r0] == RayKind.SHADOW
    if np.any(shadow & _NEVER_SHADOW[code]):
        _fail("a shadow ray was shaded or left the space as a primary/secondary ray")
    if np.any(~shadow & _SHADOW_ONLY[code]):
        _fail("a primary or secondary ray was blocked or lit like a shadow ray")
    _check_family(rays, rb, r0, v, starts, run_rays, tot)
    tot.to_ic += int(np.sum(code == _code(OS, O.TO_IC)))
    tot.ic += int(np.sum(v["stage"] == IC))
    if np.any(v["tests"][v["stage"] != IC] != 0) or np.any(v["steps"][v["stage"] != OS] != 0):
        _fail("tests outside IC or voxels outside OS")


def _first_wrong_parent(rays, visits, chunk: int) -> None:
    """The fingerprints of SC's 'made' and of the children differ: find the first ray whose
    children and 'made' disagree (a pass to find its range of ids, one within it) and name it."""
    n = len(rays)
    nb = max(1, min(n, 1 << 16))

    def bucket(ids):
        return ids.astype(np.int64) * nb // n

    diff = np.zeros(nb, dtype=np.int64)
    fp = np.zeros(nb, dtype=np.uint64)
    for _, r in chunks(rays, chunk):
        p = r["parent"][r["parent"] >= 0].astype(np.int64)
        np.add.at(diff, bucket(p), 1)
        np.add.at(fp, bucket(p), _fingerprint(p))
    for _, v in chunks(visits, chunk):
        s = v[v["stage"] == SC]
        np.subtract.at(diff, bucket(s["ray"]), s["made"].astype(np.int64))
        with np.errstate(over="ignore"):
            np.subtract.at(fp, bucket(s["ray"]), s["made"].astype(np.uint64) * _fingerprint(s["ray"]))
    b = int(np.flatnonzero((diff != 0) | (fp != 0))[0])
    lo, hi = -(-b * n // nb), -(-(b + 1) * n // nb)     # the ids in bucket b
    kids = np.zeros(hi - lo, dtype=np.int64)
    made = np.zeros(hi - lo, dtype=np.int64)
    has_sc = np.zeros(hi - lo, dtype=bool)
    for _, r in chunks(rays, chunk):
        p = r["parent"].astype(np.int64)
        np.add.at(kids, p[(p >= lo) & (p < hi)] - lo, 1)
    for _, v in chunks(visits, chunk):
        s = v[(v["stage"] == SC) & (v["ray"] >= lo) & (v["ray"] < hi)]
        np.add.at(made, s["ray"] - lo, s["made"].astype(np.int64))
        has_sc[s["ray"] - lo] = True
    i = int(np.flatnonzero(kids != made)[0])
    if not has_sc[i]:
        _fail(f"ray {lo + i} has {kids[i]} children but no SC visit")
    _fail(f"an SC visit's 'made' differs from its number of children (ray {lo + i}: made {made[i]}, "
          f"{kids[i]} children)")


def check(trace, chunk: int = CHUNK) -> None:
    """Validate a trace's invariants (see the module's text) in memory bounded by ``chunk``
    visits and the largest block; raise TraceError naming the first broken one."""
    rays, visits = trace.rays, trace.visits
    n = len(rays)
    for i, r in chunks(rays, chunk):
        if not np.array_equal(r["id"], np.arange(i, i + len(r))):
            _fail("ray ids are not 0..n-1 in order")
    if len(visits) == 0:
        if n:
            _fail("rays without visits")
        return
    tot = _Totals()
    for v, r0, r1, starts in _blocks(visits, n, chunk):
        _check_block(rays, v, r0, r1, starts, tot)
    if tot.kids != tot.made or tot.kids_fp != tot.made_fp:
        _first_wrong_parent(rays, visits, chunk)
    if tot.to_ic != tot.ic:
        _fail("OS->IC handoffs and IC visits differ")


def settle(trace, found: str | None) -> None:
    """The invariants, after ``tracevalid.check_arrays(..., invariants=True)`` answered ``found``:
    nothing more when "" (C found them hold), this module's check when None (not checked in C),
    and when C found one broken, this module's check to name it in its words (C's reason if it
    names none)."""
    if found == "":
        return
    check(trace)
    if found is not None:
        _fail(found)
