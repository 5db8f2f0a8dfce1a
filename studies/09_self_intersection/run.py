"""Self-intersection: what if secondary and shadow rays started exactly on the surface?

The renderer starts every secondary and shadow ray a little off the surface
it leaves (512 ulps of the hit point's largest coordinate), so a ray never
hits the surface it starts on.  A tracer without that guard, as the paper's
may have been, would.  The library has no switch for the guard, so this
study replays the `paper` rules for balls (spheres and one polygon, nothing
transmissive) one generation of rays at a time on ``Grid.intersect`` (which
starts rays at t = 0), with the geometry, materials, lights and eye rays taken
from the library, and the guard in one of three modes:

  * 'renderer': where the renderer starts the rays; this must reproduce the
    renderer's ray counts exactly (checked, checks.csv);
  * 'none': on the surface;
  * 'polygons only': the guard on polygon hits, none on sphere hits.

It also counts the grid work of the primary and secondary rays and the shadow
rays blocked by their own surface.  Returns per ray from outside are
estimated: the primary and secondary rays' returns are counted; a shadow ray
blocked by its own surface makes none; every other shadow ray is given the
mean returns of our traced blocked or unblocked shadow rays at that
subdivision (an assumption, stated as such).

Writes self_intersection.csv and checks.csv to
studies/out/09_self_intersection/ (--quick: 64x64, subdivisions 8 and 16,
balls at size 2, to ref/).

    python studies/09_self_intersection/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import (GAP_KEYS, PAPER_BALLS, PAPER_SUBDIVISIONS, by_ray_class, candidates_per_hit, log,  # noqa: E402
                     md_rows, paper_counts_row, quick_or_full, study_args, write_checks, write_csv)

EPS = float(np.finfo(np.float64).eps)
OFFSET_MODES = ("renderer", "none", "polygons only")
COUNTS = ("eye_hits", "hits", "os_kills", "sc_made_secondary", "sc_made_shadow", "ic_kills", "os_to_sc_shadow",
          "suppressed", "suppressed_zero_luminance", "self_hits", "shadow_self_blocked", "nonshadow_rays",
          "nonshadow_returns", "nonshadow_voxels", "nonshadow_tests")


def geometry(scene) -> dict:
    """Per primitive id: kind, sphere centre and radius, polygon plane normal, kd and ks; the
    lights' positions and the intensity the renderer weighs a shadow ray's contribution by."""
    prims, mats, lights = scene.primitives(), scene.materials(), scene.lights()
    n = len(prims["kind"])
    if np.any((prims["kind"] != mprt.Kind.SPHERE) & (prims["kind"] != mprt.Kind.POLYGON)):
        raise ValueError("the replay handles spheres and polygons only")
    if np.any(mats["t"] > 0) or scene.info()["patches"]:
        raise ValueError("the replay handles opaque scenes with flat polygons only")
    ctr, rad, pn = np.zeros((n, 3)), np.ones(n), np.zeros((n, 3))
    s = prims["spheres"]
    ctr[s["id"]], rad[s["id"]] = s["center"], s["radius"]
    p = prims["polygons"]
    v0, v1, v2 = (p["vertices"][p["vstart"][:-1] + k] for k in range(3))
    nrm = np.cross(v1 - v0, v2 - v0)
    pn[p["id"]] = nrm / np.sqrt(np.sum(nrm * nrm, axis=1))[:, None]
    rgb = lights["rgb"]
    grey = (rgb[:, 0] == rgb[:, 1]) & (rgb[:, 1] == rgb[:, 2])
    weight = np.where(grey, rgb[:, 0], (rgb[:, 0] + rgb[:, 1] + rgb[:, 2]) / 3)
    mat = prims["material"]
    return {"kind": prims["kind"], "ctr": ctr, "rad": rad, "pn": pn, "kd": mats["kd"][mat], "ks": mats["ks"][mat],
            "lights": lights["position"], "light_weight": weight}


def _dot(a, b):
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def shade_shadow_rays(grid, geo, k, p, nrm, c, kd, pr, off, threshold):
    """One shadow ray per light from each hit point p, counted into k as the renderer decides them."""
    for light, weight in zip(geo["lights"], geo["light_weight"]):
        to = light - p
        dist = np.sqrt(_dot(to, to))
        to /= dist[:, None]
        lum = np.maximum(_dot(nrm, to), 0) * kd * c
        ok = dist > off
        keep = ok & ~(lum * weight < threshold)
        k["suppressed"] += int(np.sum(ok & ~keep))
        k["suppressed_zero_luminance"] += int(np.sum(ok & ~keep & (lum == 0)))
        k["sc_made_shadow"] += int(keep.sum())
        ts, tp = grid.intersect(p[keep] + to[keep] * off[keep, None], to[keep])
        blocked = ts <= dist[keep] - off[keep]
        k["ic_kills"] += int(blocked.sum())
        own = int(np.sum(blocked & (tp == pr[keep]) & (ts < 1e-9)))
        k["self_hits"] += own
        k["shadow_self_blocked"] += own


def paper_rules_numpy(grid, geo, res, offset="renderer", threshold=1 / 512, max_depth=64) -> dict:
    """The paper rules, one ray generation at a time on Grid.intersect, with the surface guard
    in mode ``offset``; returns the counts of COUNTS and candidates per hit."""
    o, d = grid.camera_rays(res, res)
    contrib = np.ones(len(o))
    depth = np.ones(len(o), dtype=np.int64)
    k = dict.fromkeys(COUNTS, 0)
    prev = None  # primitive each ray starts on
    while len(o):
        t, prim, cnt = grid.intersect(o, d, return_counters=True)
        k["nonshadow_rays"] += len(o)
        k["nonshadow_returns"] += cnt["os_visits"] - len(o)
        k["nonshadow_voxels"] += cnt["voxels_traversed"]
        k["nonshadow_tests"] += sum(cnt["tests"].values())
        hit = np.isfinite(t)
        if prev is None:
            k["eye_hits"] = int(hit.sum())
        else:
            k["self_hits"] += int(np.sum(hit & (prim == prev) & (t < 1e-9)))
        k["hits"] += int(hit.sum())
        k["os_kills"] += int((~hit).sum())
        pr, dd, c, dp = prim[hit], d[hit], contrib[hit], depth[hit]
        p = o[hit] + t[hit, None] * dd
        sph = geo["kind"][pr] == mprt.Kind.SPHERE
        nrm = np.where(sph[:, None], (p - geo["ctr"][pr]) / geo["rad"][pr][:, None], geo["pn"][pr])
        nrm /= np.sqrt(_dot(nrm, nrm))[:, None]
        nrm[_dot(nrm, dd) > 0] *= -1
        off = (np.abs(p).max(axis=1) + 1e-30) * EPS * 512
        if offset == "none":
            off[:] = 0
        elif offset == "polygons only":
            off[sph] = 0
        shade_shadow_rays(grid, geo, k, p, nrm, c, geo["kd"][pr], pr, off, threshold)
        k["os_to_sc_shadow"] = k["sc_made_shadow"] - k["ic_kills"]
        ks = geo["ks"][pr]
        r = dd - 2 * _dot(dd, nrm)[:, None] * nrm
        r /= np.sqrt(_dot(r, r))[:, None]
        cand = ks > 0
        keep = cand & ~(c * ks < threshold) & (dp + 1 <= max_depth)
        k["suppressed"] += int(np.sum(cand & ~keep))
        k["sc_made_secondary"] += int(keep.sum())
        o, d = p[keep] + r[keep] * off[keep, None], r[keep]
        contrib, depth, prev = (c * ks)[keep], dp[keep] + 1, pr[keep]
    k["candidates_per_hit"] = candidates_per_hit(k["sc_made_secondary"], k["sc_made_shadow"], k["suppressed"],
                                                 k["hits"])
    return k


def traced_counts(grid, res, threads) -> dict:
    """The renderer's own counts (GAP_KEYS) and per-class returns, from a trace."""
    _, tr = grid.trace(res, res, rules="paper", threads=threads)
    st = tr.stats()
    late = st["os_to_sc_late_hits"]
    row = {"hits": st["ic_to_sc"] + late, "os_kills": st["os_kills"], "sc_made_secondary": st["sc_made_secondary"],
           "sc_made_shadow": st["sc_made_shadow"], "ic_kills": st["ic_kills"], "os_to_sc_shadow": st["os_to_sc"] - late,
           "suppressed": st["suppressed"]}
    return {**row, **by_ray_class(tr)}


def pivot(rows, n) -> list:
    """Rows of the table at subdivision n: one per count, one column per offset mode, and the paper's."""
    i = PAPER_SUBDIVISIONS.index(n) if n in PAPER_SUBDIVISIONS else None
    paper = paper_counts_row(i) if i is not None else {}
    if i is not None:
        paper["returns_per_ray_estimate"] = PAPER_BALLS["returns_per_ray"][i]
    by_mode = {r["offset"]: r for r in rows if r["subdivision"] == n}
    keys = COUNTS[:-3] + ("candidates_per_hit", "nonshadow_returns", "nonshadow_returns_traced", "nonshadow_voxels",
                          "nonshadow_tests", "returns_per_ray_estimate")
    return [{"row": key, **{f"offset: {m}": by_mode[m].get(key, "") for m in OFFSET_MODES},
             f"paper {n}": paper.get(key, "")} for key in keys]


def main(argv=None) -> int:
    a, out = study_args(__file__, "balls with and without the self-intersection guard",
                        "64x64, subdivisions 8 and 16, balls at size 2", argv)
    res, size, subdivisions = quick_or_full(a.quick)
    scene = mprt.Scene.spd("balls", size)
    geo = geometry(scene)
    rows, same = [], True
    for n in subdivisions:
        grid = scene.grid(n)
        tr = traced_counts(grid, res, a.threads)
        rb = tr["returns_shadow_blocked"] / max(tr["rays_shadow_blocked"], 1)
        ru = tr["returns_shadow_unblocked"] / max(tr["rays_shadow_unblocked"], 1)
        for mode in OFFSET_MODES:
            k = paper_rules_numpy(grid, geo, res, offset=mode)
            if mode == "renderer":
                same &= all(k[key] == tr[key] for key in GAP_KEYS)
                k["nonshadow_returns_traced"] = tr["returns_primary"] + tr["returns_secondary"]
            est = k["nonshadow_returns"] + (k["ic_kills"] - k["shadow_self_blocked"]) * rb + k["os_to_sc_shadow"] * ru
            k["returns_per_ray_estimate"] = round(est / (k["nonshadow_rays"] + k["sc_made_shadow"]), 4)
            rows.append({"subdivision": n, "offset": mode, **k})
            log(f"  {n:3d}^3, offset {mode}: {k['hits']:,} hits, {k['self_hits']:,} self-hits")
    write_csv(os.path.join(out, "self_intersection.csv"), rows)
    write_checks(os.path.join(out, "checks.csv"), {"renderer_offset_reproduces_the_renderer": same})
    log(md_rows(pivot(rows, subdivisions[len(subdivisions) // 2])))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
