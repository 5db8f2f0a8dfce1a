"""The paper's statistics of a trace: its table rows, tests by kind and per-ray histograms.

Computed over the rays and visits in chunks (``tracefile.chunks``), so a
memory-mapped trace of any size is summarised in bounded memory.  Pure numpy over the record arrays.
"""
from __future__ import annotations

import numpy as np

from .._lowlevel import KINDS, Outcome, RayKind, Stage
from .tracefile import chunks

OS, IC, SC = Stage.OS, Stage.IC, Stage.SC
O = Outcome


def _add_hist(acc: list, counts) -> None:
    if len(counts) > len(acc):
        acc.extend([0] * (len(counts) - len(acc)))
    for i, c in enumerate(counts):
        acc[i] += int(c)


def _visit_sums(visits, chunk: int) -> dict:
    """Visits by (stage, outcome), tests by kind, summed fields and the three histograms."""
    cnt = np.zeros((len(Stage), 16), dtype=np.int64)
    tests_by_kind = np.zeros(len(KINDS), dtype=np.int64)
    sums = {"suppressed": 0, "steps": 0, "vertices": 0}
    h_vox, h_tests, h_ret = [], [], []
    carry_ray, carry_ret = -1, 0                # a ray's returns may straddle chunks
    for _, v in chunks(visits, chunk):
        stage, out = v["stage"].astype(np.int64), v["outcome"].astype(np.int64)
        cnt += np.bincount(stage * 16 + out, minlength=cnt.size).reshape(cnt.shape)
        tests_by_kind += v["tests"].sum(axis=0, dtype=np.int64)
        for k in sums:
            sums[k] += int(v[k].sum(dtype=np.int64))
        _add_hist(h_vox, np.bincount(v["steps"][stage == OS]))
        _add_hist(h_tests, np.bincount(v["tests"][stage == IC].sum(axis=1)))
        # returns per ray: visits are grouped by ray, so count per run of ray ids
        ray = v["ray"]
        starts = np.flatnonzero(np.concatenate([[True], ray[1:] != ray[:-1]]))
        ret = np.add.reduceat(((stage == IC) & (out == O.RETURN)).astype(np.int64), starts)
        if ray[0] == carry_ray:
            ret[0] += carry_ret
        elif carry_ray >= 0:
            _add_hist(h_ret, np.bincount([carry_ret]))
        carry_ray, carry_ret = int(ray[starts[-1]]), int(ret[-1])
        _add_hist(h_ret, np.bincount(ret[:-1]))
    if carry_ray >= 0:
        _add_hist(h_ret, np.bincount([carry_ret]))
    return {"cnt": cnt, "tests_by_kind": tests_by_kind, "sums": sums, "hist": (h_vox, h_tests, h_ret)}


def trace_stats(trace, chunk: int = 1 << 18) -> dict:
    """The statistics of a trace (anything with ``rays`` and ``visits``): the paper's table
    rows, tests by kind, and histograms of voxels per OS visit, tests per IC visit and returns
    per ray."""
    rays, visits = trace.rays, trace.visits
    kinds = np.zeros(len(RayKind), dtype=np.int64)
    for _, r in chunks(rays, chunk):
        kinds += np.bincount(r["kind"], minlength=len(RayKind))
    n_primary = int(kinds[RayKind.PRIMARY])
    n_new = int(len(rays) - n_primary)
    s = _visit_sums(visits, chunk)
    cnt, tests_by_kind, sums = s["cnt"], s["tests_by_kind"], s["sums"]
    h_vox, h_tests, h_ret = s["hist"]
    returns = int(cnt[IC, O.RETURN])
    return {
        "rays": int(len(rays)),
        "visits": int(len(visits)),
        "os_input": n_primary + returns + n_new,
        "os_input_primary": n_primary,
        "os_input_returns": returns,
        "os_input_new": n_new,
        "os_kills": int(cnt[OS, O.LEFT]),
        "os_to_ic": int(cnt[OS, O.TO_IC]),
        "os_to_sc": int(cnt[OS, O.TO_SC] + cnt[OS, O.LATE_HIT]),
        "os_to_sc_late_hits": int(cnt[OS, O.LATE_HIT]),
        "ic_input": int(cnt[IC].sum()),
        "ic_kills": int(cnt[IC, O.BLOCKED]),
        "ic_to_os": returns,
        "ic_to_sc": int(cnt[IC, O.HIT]),
        "sc_input": int(cnt[SC].sum()),
        "sc_input_from_ic": int(cnt[IC, O.HIT]),
        "sc_input_from_os": int(cnt[OS, O.TO_SC] + cnt[OS, O.LATE_HIT]),
        "sc_made_secondary": int(kinds[RayKind.REFLECT] + kinds[RayKind.REFRACT]),
        "sc_made_reflect": int(kinds[RayKind.REFLECT]),
        "sc_made_refract": int(kinds[RayKind.REFRACT]),
        "sc_made_shadow": int(kinds[RayKind.SHADOW]),
        "suppressed": sums["suppressed"],
        "voxels_traversed": sums["steps"],
        "tests": int(tests_by_kind.sum()),
        "tests_by_kind": {k: int(tests_by_kind[i]) for i, k in enumerate(KINDS)},
        "polygon_vertices": sums["vertices"],
        "returns_per_ray": returns / (n_primary + n_new) if n_primary + n_new else 0.0,
        "hist_voxels_per_os_visit": h_vox,
        "hist_tests_per_ic_visit": h_tests,
        "hist_returns_per_ray": h_ret,
    }
