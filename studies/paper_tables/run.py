"""Paper tables study: our 3MPRT counts in the layout of the paper's results.

For balls, mount, rings, tetra and tree (SPD default sizes) at subdivisions
20, 50 and 100 (n^3 voxels over the scene's box), 512x512, `paper` rules and
the default threshold, every ray is traced (mprt.trace) and tabulated in the
paper's rows (digest section 4), with tests by primitive kind.  Then, to
explain the differences from the paper's balls column:

  * balls beside the paper's figures, ratios ours/paper per subdivision;
  * returns made while IC already holds the ray's final hit (an IC that
    accepted a hit beyond its voxel would not make them);
  * balls at several contribution thresholds;
  * how many suppressed shadow rays carry zero luminance (light behind the
    surface): traces at threshold 0 and 1e-300 have the same ray tree, and
    differ only by those rays;
  * the camera: the view angle moved around 45 degrees;
  * the grid's shape: n^3 voxels over the flat box (ours) or cubic voxels;
    and our voxel lists against lists made from sphere bounding boxes;
  * a NumPy re-implementation of the paper rules for balls on top of
    Grid.intersect, with and without the self-intersection offset (with it,
    it must reproduce the C counts exactly);
  * SPD rules: eye rays, hits, reflect, refract and shadow rays per scene.

Writes CSV tables, tables.md and paper_tables.png to studies/out/paper_tables/
(--quick: 64x64, subdivisions 8 and 16, scenes at size 2, tables only, written
to studies/paper_tables/ref/, the committed reference that the test diffs).

    python studies/paper_tables/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import re
import time

import numpy as np

import mprt
from mprt.trace import BLOCKED, HIT, IC, LATE_HIT, OS, PRIMARY, RETURN, SC, SHADED, SHADOW

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "out", "paper_tables")
REF = os.path.join(HERE, "ref")
SCENES = ("balls", "mount", "rings", "tetra", "tree")
THRESHOLDS = (0.0, 1 / 512, 0.01, 0.05, 0.1)
ANGLES = (45.0, "edges", 40.0, 35.0, 30.0)  # "edges": 45 degrees spanning the image's edges, not pixel centres
EPS = float(np.finfo(np.float64).eps)

# The paper's balls column (digest section 4), subdivision 20 / 50 / 100; counts in thousands,
# voxels and tests in millions.
PAPER_SUBDIVISIONS = (20, 50, 100)
PAPER_BALLS = {
    "os_input": (6797, 7515, 9182),
    "os_input_primary": (262, 262, 262),
    "os_input_returns": (4657, 5346, 7011),
    "os_input_new": (1878, 1906, 1907),
    "os_kills": (50, 45, 45),
    "os_to_ic": (6206, 6921, 8593),
    "os_to_sc_shadow": (540, 548, 543),
    "ic_kills": (861, 877, 882),
    "ic_to_os": (4657, 5346, 7011),
    "hits": (686, 696, 697),
    "sc_input": (1228, 1246, 1242),
    "sc_made_secondary": (476, 481, 481),
    "sc_made_shadow": (1402, 1425, 1426),
    "suppressed": (1420, 1455, 1458),
    "voxels_traversed": (20, 45, 88),
    "tests": (1376, 346, 92),
    "returns_per_ray": (2.2, 2.5, 3.2),
}

# (key, label, unit): unit K = thousands, M = millions, '' = as is
ROWS = [
    ("os_input", "OS input rays", "K"),
    ("os_input_primary", "  of which primary", "K"),
    ("os_input_returns", "  of which returns from IC", "K"),
    ("os_input_new", "  of which new rays from SC", "K"),
    ("os_kills", "OS kills (ray left the space)", "K"),
    ("os_to_ic", "OS -> IC", "K"),
    ("os_to_sc", "OS -> SC", "K"),
    ("os_to_sc_shadow", "  of which unblocked shadow rays", "K"),
    ("os_to_sc_late_hits", "  of which late hits (nearest hit accepted by OS after the walk)", "K"),
    ("ic_kills", "IC kills (blocked shadow rays)", "K"),
    ("ic_to_os", "IC -> OS (returns)", "K"),
    ("ic_to_sc", "IC -> SC (hits)", "K"),
    ("hits", "hits (IC -> SC + late hits)", "K"),
    ("sc_input", "SC input", "K"),
    ("sc_made_secondary", "SC makes: secondary rays", "K"),
    ("sc_made_shadow", "SC makes: shadow rays", "K"),
    ("suppressed", "rays suppressed by the contribution threshold", "K"),
    ("voxels_traversed", "voxels traversed (millions)", "M"),
    ("tests", "intersection tests (millions)", "M"),
    ("tests_sphere", "  sphere tests (millions)", "M"),
    ("tests_polygon", "  polygon tests (millions)", "M"),
    ("tests_cylinder", "  cylinder tests (millions)", "M"),
    ("tests_cone", "  cone tests (millions)", "M"),
    ("returns_per_ray", "returns per ray entering OS from outside", ""),
    ("returns_holding_hit", "returns while IC holds the final hit", "K"),
    ("returns_per_ray_early_accept", "returns per ray if IC accepted hits beyond its voxel", ""),
]
# counts that describe the grid; all others must be the same at every subdivision
GRID_KEYS = {"os_input", "os_input_returns", "os_to_ic", "ic_to_os", "ic_to_sc", "os_to_sc", "os_to_sc_shadow",
             "os_to_sc_late_hits", "voxels_traversed", "tests", "tests_sphere", "tests_polygon", "tests_cylinder",
             "tests_cone", "returns_per_ray", "returns_holding_hit", "returns_per_ray_early_accept", "ic_input",
             "sc_input_from_ic", "sc_input_from_os", "visits", "polygon_vertices", "grid_nonempty", "grid_refs",
             "tests_by_primary", "tests_by_secondary", "tests_by_shadow", "returns_primary", "returns_secondary",
             "returns_shadow_blocked", "returns_shadow_unblocked", "voxels_primary", "voxels_secondary",
             "voxels_shadow_blocked", "voxels_shadow_unblocked"}


def log(msg):
    print(msg, flush=True)


# ---- scenes -------------------------------------------------------------------------------

def load(name, size):
    return mprt.Scene.spd(name, size)


def with_angle(scene, angle):
    """The scene with another view angle (edited through its NFF text)."""
    text, k = re.subn(r"(?m)^angle .*$", f"angle {angle!r}", scene.to_nff())
    assert k == 1
    return mprt.Scene.from_text(text, name=f"{scene.name}@{angle}")


def nonshadow_hits(c):
    """Primary/secondary rays that hit, from render counters: SC visits are those hits plus the
    unblocked shadow rays; 'hits' counts them plus the blocked shadow rays."""
    return (c["sc_visits"] + c["hits"] - c["shadow_rays"]) // 2


# ---- 1. traces in the paper's rows ----------------------------------------------------------

def returns_holding_hit(tr):
    """IC -> OS returns made after IC has tested (and so found) the primitive the ray finally
    hits: IC holds that hit but it lies beyond the voxel.  Found from the voxel lists: the
    first IC visit whose voxel lists the final primitive, and every return from then on."""
    v = tr.visits
    stage, out = v["stage"], v["outcome"]
    final = np.full(len(tr.rays), -1, dtype=np.int64)
    m = ((stage == IC) & (out == HIT)) | ((stage == OS) & (out == LATE_HIT))
    final[v["ray"][m]] = v["prim"][m]
    icv = np.flatnonzero((stage == IC) & (final[v["ray"]] >= 0))
    if icv.size == 0:
        return 0
    start, ids = tr.voxel_start.astype(np.int64), tr.voxel_ids.astype(np.int64)
    nprim = len(tr.prim_kind)
    vox_of_ref = np.repeat(np.arange(len(start) - 1, dtype=np.int64), np.diff(start))
    keys = np.sort(vox_of_ref * nprim + ids)
    q = v["voxel_id"][icv].astype(np.int64) * nprim + final[v["ray"][icv]]
    pos = np.searchsorted(keys, q)
    listed = (pos < len(keys)) & (keys[np.minimum(pos, len(keys) - 1)] == q)
    first = np.full(len(tr.rays), np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first, v["ray"][icv[listed]], icv[listed])
    ret = icv[out[icv] == RETURN]
    return int(np.sum(ret >= first[v["ray"][ret]]))


def trace_row(scene, n, res, threads, progress):
    grid = scene.grid(n)
    _, tr = grid.trace(res, res, rules="paper", threads=threads, progress=progress)
    st = tr.stats()
    row = {k: v for k, v in st.items() if not isinstance(v, (dict, list))}
    for k, v in st["tests_by_kind"].items():
        row["tests_" + k] = v
    row["os_to_sc_shadow"] = st["os_to_sc"] - st["os_to_sc_late_hits"]
    row["hits"] = st["ic_to_sc"] + st["os_to_sc_late_hits"]
    row["returns_holding_hit"] = returns_holding_hit(tr)
    outside = st["os_input_primary"] + st["os_input_new"]
    row["returns_per_ray_early_accept"] = (st["os_input_returns"] - row["returns_holding_hit"]) / outside
    # tests by the kind of ray that made them
    kind = tr.rays["kind"][tr.visits["ray"]]
    tests = tr.visits["tests"].sum(axis=1)
    row["tests_by_primary"] = int(tests[kind == PRIMARY].sum())
    row["tests_by_shadow"] = int(tests[kind == SHADOW].sum())
    row["tests_by_secondary"] = int(tests.sum() - row["tests_by_primary"] - row["tests_by_shadow"])
    v = tr.visits
    blocked = np.zeros(len(tr.rays), dtype=bool)
    blocked[v["ray"][(v["stage"] == IC) & (v["outcome"] == BLOCKED)]] = True
    ret = (v["stage"] == IC) & (v["outcome"] == RETURN)
    rkind = tr.rays["kind"]
    for label, rays_m in (("primary", rkind == PRIMARY), ("secondary", (rkind != PRIMARY) & (rkind != SHADOW)),
                          ("shadow_blocked", (rkind == SHADOW) & blocked),
                          ("shadow_unblocked", (rkind == SHADOW) & ~blocked)):
        row["rays_" + label] = int(rays_m.sum())
        row["returns_" + label] = int(np.sum(ret & rays_m[v["ray"]]))
        row["voxels_" + label] = int(v["steps"][rays_m[v["ray"]]].sum())
    gs = grid.stats()
    row["grid_nonempty"], row["grid_refs"] = gs["nonempty"], gs["refs"]
    del tr
    return row


# ---- 3. spd rules --------------------------------------------------------------------------

def spd_row(scene, res, threads):
    _, c = scene.grid(scene.default_grid()).render(res, res, rules="spd", threads=threads)
    return {"eye_rays": c["eye_rays"], "eye_hits": c["eye_hits"], "reflect_rays": c["reflect_rays"],
            "refract_rays": c["refract_rays"], "shadow_rays": c["shadow_rays"],
            "total_rays": c["eye_rays"] + c["reflect_rays"] + c["refract_rays"] + c["shadow_rays"],
            "depth_limited": c["suppressed_rays"], "shadow_blocked": c["hits"] - nonshadow_hits(c)}


# ---- 4. threshold, zero luminance, camera, grid shape ----------------------------------------

def counts_row(c):
    h = nonshadow_hits(c)
    sec = c["reflect_rays"] + c["refract_rays"]
    blocked = c["hits"] - h
    return {"eye_hits": c["eye_hits"], "hits": h, "os_kills": c["eye_rays"] + sec - h, "sc_made_secondary": sec,
            "sc_made_shadow": c["shadow_rays"], "ic_kills": blocked, "os_to_sc_shadow": c["shadow_rays"] - blocked,
            "suppressed": c["suppressed_rays"],
            "candidates_per_hit": round((sec + c["shadow_rays"] + c["suppressed_rays"]) / h, 4)}


def paper_counts_row(i=1):
    """The paper's balls figures (subdivision 20/50/100 -> i = 0/1/2) in counts_row's keys."""
    p = {k: v[i] * 1000 for k, v in PAPER_BALLS.items()}
    keys = ("hits", "os_kills", "sc_made_secondary", "sc_made_shadow", "ic_kills", "os_to_sc_shadow", "suppressed")
    row = {k: p[k] for k in keys}
    row["candidates_per_hit"] = round((p["sc_made_secondary"] + p["sc_made_shadow"] + p["suppressed"]) / p["hits"], 4)
    return row


def threshold_rows(scene, res, threads):
    grid = scene.grid(scene.default_grid())
    rows = []
    for t in THRESHOLDS:
        _, c = grid.render(res, res, rules="paper", threshold=t, threads=threads)
        rows.append({"threshold": round(t, 6), **counts_row(c)})
    rows.append({"threshold": "paper, 50", "eye_hits": "", **paper_counts_row()})
    return rows


def zero_luminance_row(scene, res, threads, threshold=1 / 512):
    """Suppressed shadow rays at `threshold` that carry zero luminance (light behind the surface,
    N.L <= 0).  Traces at threshold 0 (every light gets a shadow ray) and 1e-300 (only lum = 0 is
    cut) make the same primary/secondary rays; the shaded rays of the `threshold` tree are those
    with contribution >= threshold, and shadow rays carry their parent's contribution."""
    info = scene.info()
    if any(m > 0 for m in _transmittances(scene)):
        return None  # threshold 0 lets a transmissive scene's ray tree grow to depth 64 both ways
    grid = scene.grid(scene.default_grid())
    _, a = grid.trace(res, res, rules="paper", threshold=0.0, threads=threads)
    _, b = grid.trace(res, res, rules="paper", threshold=1e-300, threads=threads)
    _, c = grid.render(res, res, rules="paper", threshold=threshold, threads=threads)

    def shadows(tr):
        r = tr.rays
        return int(np.sum((r["kind"] == SHADOW) & (r["contribution"] >= threshold)))

    shaded = nonshadow_hits(c)
    va = a.visits
    shaded_a = int(np.sum((va["stage"] == SC) & (va["outcome"] == SHADED) &
                          (a.rays["contribution"][va["ray"]] >= threshold)))
    made_a = shadows(a)
    assert shaded_a == shaded, (shaded_a, shaded)
    zero = made_a - shadows(b)
    shadow_supp = info["lights"] * shaded - c["shadow_rays"] - (info["lights"] * shaded_a - made_a)
    return {"lights": info["lights"], "hits": shaded, "shadow_candidates": info["lights"] * shaded,
            "shadow_rays": c["shadow_rays"], "suppressed": c["suppressed_rays"],
            "suppressed_shadow": shadow_supp, "suppressed_zero_luminance": zero,
            "suppressed_dim_shadow": shadow_supp - zero, "suppressed_secondary": c["suppressed_rays"] - shadow_supp}


def _transmittances(scene):
    return [float(line.split()[7]) for line in scene.to_nff().splitlines() if line.startswith("f ")]


def camera_rows(scene, res, threads):
    rows = []
    for a in ANGLES:
        if a == "edges":  # the same pixel pitch as 45 degrees over res pixels, as our centre-to-centre angle
            a = round(2 * math.degrees(math.atan(math.tan(math.radians(22.5)) * (res - 1) / res)), 4)
        s = with_angle(scene, a)
        _, c = s.grid(s.default_grid()).render(res, res, rules="paper", threads=threads)
        rows.append({"angle": a, **counts_row(c)})
    rows.append({"angle": "paper, 50", "eye_hits": "", **paper_counts_row()})
    return rows


def grid_shape_rows(scene, subdivisions, res, threads):
    """n^3 voxels over the scene's box (ours) against cubic voxels (n along x and y, z in
    proportion), and our voxel lists against lists made from the spheres' bounding boxes."""
    info = scene.info()
    ext = np.subtract(info["hi"], info["lo"])
    geo = parse_nff(scene.to_nff())
    rows = []
    for n in subdivisions:
        nz = max(1, int(round(n * ext[2] / ext[:2].max())))
        for shape, dims in (("n^3 over the box", (n, n, n)), ("cubic voxels", (n, n, nz))):
            g = scene.grid(dims)
            _, c = g.render(res, res, rules="paper", threads=threads)
            gs = g.stats()
            row = {"subdivision": n, "grid": "x".join(map(str, dims)), "shape": shape,
                   "voxels_traversed": c["voxels_traversed"], "tests": sum(c["tests"].values()),
                   "refs": gs["refs"], "refs_sphere_bboxes": ""}
            if shape.startswith("n^3"):
                row["refs_sphere_bboxes"] = bbox_refs(geo, g, dims)
            rows.append(row)
    return rows


def bbox_refs(geo, grid, dims):
    """List entries if every sphere were listed in each voxel its bounding box overlaps (the
    other primitives' entries as ours)."""
    gs = grid.stats()
    lo, hi = np.array(gs["lo"]), np.array(gs["hi"])
    n = np.array(dims)
    vs = (hi - lo) / n
    sph = geo["kind"] == 0
    c, r = geo["ctr"][sph], geo["rad"][sph][:, None]
    a = np.clip(np.floor((c - r - lo) / vs), 0, n - 1)
    b = np.clip(np.floor((c + r - lo) / vs), 0, n - 1)
    ids = grid.lists()[1]
    return int(np.prod(b - a + 1, axis=1).sum()) + int(np.sum(geo["kind"][ids] != 0))


# ---- 4b. the paper rules re-implemented on Grid.intersect (balls: spheres and polygons) ---------

def parse_nff(text):
    """Per-primitive kind, sphere centre/radius, polygon plane normal and material, and the
    lights, from NFF text with spheres and flat polygons only (primitive ids in file order)."""
    lines = text.splitlines()
    i = 0
    mats, kinds, ctr, rad, pn, mat_of, lights = [], [], [], [], [], [], []
    while i < len(lines):
        f = lines[i].split()
        i += 1
        if not f:
            continue
        if f[0] == "f":
            mats.append([float(x) for x in f[1:]])
        elif f[0] == "l":
            lights.append([float(x) for x in f[1:4]])
        elif f[0] == "s":
            kinds.append(0)
            ctr.append([float(x) for x in f[1:4]])
            rad.append(float(f[4]))
            pn.append([0.0, 0.0, 0.0])
            mat_of.append(len(mats) - 1)
        elif f[0] == "p":
            nv = int(f[1])
            v = np.array([[float(x) for x in lines[i + k].split()] for k in range(nv)])
            i += nv
            nrm = np.cross(v[1] - v[0], v[2] - v[0])
            kinds.append(1)
            ctr.append([0.0, 0.0, 0.0])
            rad.append(1.0)
            pn.append(nrm / math.sqrt(float(nrm @ nrm)))
            mat_of.append(len(mats) - 1)
        elif f[0] in ("c", "pp"):
            raise ValueError("the re-implementation handles spheres and flat polygons only")
    m = np.array(mats)
    return {"kind": np.array(kinds), "ctr": np.array(ctr, float), "rad": np.array(rad), "pn": np.array(pn, float),
            "kd": m[mat_of, 3], "ks": m[mat_of, 4], "t": m[mat_of, 6], "lights": np.array(lights)}


def _dot(a, b):
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


OFFSET_MODES = ("renderer", "none", "polygons only")


def paper_rules_numpy(scene, grid, res, offset="renderer", threshold=1 / 512, max_depth=64):
    """The paper rules for a scene of spheres and polygons without transmission, one ray
    generation at a time on Grid.intersect (which starts rays at t = 0).  offset 'renderer':
    secondary and shadow rays start where the C renderer starts them (512 eps max|p| along the
    ray); 'none': on the surface, as in a tracer with no self-intersection guard; 'polygons
    only': the guard on polygon hits, none on sphere hits.  Also counts the grid work of the
    primary and secondary rays (the same walk as the renderer's) and the shadow rays blocked
    by the surface they start on (blocked in their first IC visit, with no return)."""
    geo = parse_nff(scene.to_nff())
    assert not np.any(geo["t"] > 0)
    light_i = 1 / math.sqrt(len(geo["lights"]))
    o, d = grid.camera_rays(res, res)
    contrib = np.ones(len(o))
    depth = np.ones(len(o), dtype=np.int64)
    k = dict.fromkeys(("eye_hits", "hits", "os_kills", "sc_made_secondary", "sc_made_shadow", "ic_kills",
                       "os_to_sc_shadow", "suppressed", "suppressed_zero_luminance", "self_hits",
                       "shadow_self_blocked", "nonshadow_rays", "nonshadow_returns", "nonshadow_voxels",
                       "nonshadow_tests"), 0)
    prev = None  # primitive each ray starts on
    first = True
    while len(o):
        t, prim, cnt = grid.intersect(o, d, return_counters=True)
        k["nonshadow_rays"] += len(o)
        k["nonshadow_returns"] += cnt["os_visits"] - len(o)
        k["nonshadow_voxels"] += cnt["voxels_traversed"]
        k["nonshadow_tests"] += sum(cnt["tests"].values())
        hit = np.isfinite(t)
        if first:
            k["eye_hits"] = int(hit.sum())
            first = False
        if prev is not None:
            k["self_hits"] += int(np.sum(hit & (prim == prev) & (t < 1e-9)))
        k["hits"] += int(hit.sum())
        k["os_kills"] += int((~hit).sum())
        pr, dd, c, dp = prim[hit], d[hit], contrib[hit], depth[hit]
        p = o[hit] + t[hit, None] * dd
        sph = geo["kind"][pr] == 0
        nrm = np.where(sph[:, None], (p - geo["ctr"][pr]) / geo["rad"][pr][:, None], geo["pn"][pr])
        nrm /= np.sqrt(_dot(nrm, nrm))[:, None]
        nrm[_dot(nrm, dd) > 0] *= -1
        off = (np.abs(p).max(axis=1) + 1e-30) * EPS * 512
        if offset == "none":
            off[:] = 0
        elif offset == "polygons only":
            off[sph] = 0
        kd, ks = geo["kd"][pr], geo["ks"][pr]
        for light in geo["lights"]:
            to = light - p
            dist = np.sqrt(_dot(to, to))
            to /= dist[:, None]
            ndl = _dot(nrm, to)
            lum = np.maximum(ndl, 0) * kd * c
            ok = dist > off
            keep = ok & ~(lum * light_i < threshold)
            k["suppressed"] += int(np.sum(ok & ~keep))
            k["suppressed_zero_luminance"] += int(np.sum(ok & ~keep & (lum == 0)))
            k["sc_made_shadow"] += int(keep.sum())
            ts, tp = grid.intersect(p[keep] + to[keep] * off[keep, None], to[keep])
            blocked = ts <= dist[keep] - off[keep]
            k["ic_kills"] += int(blocked.sum())
            own = int(np.sum(blocked & (tp == pr[keep]) & (ts < 1e-9)))
            k["self_hits"] += own
            k["shadow_self_blocked"] += own
        k["os_to_sc_shadow"] = k["sc_made_shadow"] - k["ic_kills"]
        r = dd - 2 * _dot(dd, nrm)[:, None] * nrm
        r /= np.sqrt(_dot(r, r))[:, None]
        cand = ks > 0
        keep = cand & ~(c * ks < threshold) & (dp + 1 <= max_depth)
        k["suppressed"] += int(np.sum(cand & ~keep))
        k["sc_made_secondary"] += int(keep.sum())
        o, d = p[keep] + r[keep] * off[keep, None], r[keep]
        contrib, depth, prev = (c * ks)[keep], dp[keep] + 1, pr[keep]
    k["candidates_per_hit"] = round((k["sc_made_secondary"] + k["sc_made_shadow"] + k["suppressed"]) / k["hits"], 4)
    return k


def self_intersection_rows(scene, subdivisions, res, threads, traced):
    """The NumPy paper rules at each subdivision and offset mode.  Returns per ray from outside
    are estimated: the primary/secondary rays' returns are counted (starting a ray a little
    further on instead of at tmin moves a few, see nonshadow_returns_traced); a shadow ray blocked by its
    own surface makes none; every other shadow ray is given the mean returns of our traced
    blocked or unblocked shadow rays at that subdivision (an assumption, stated as such)."""
    rows, same = [], True
    for n in subdivisions:
        grid = scene.grid(n)
        tr = traced[n]
        rb = tr["returns_shadow_blocked"] / max(tr["rays_shadow_blocked"], 1)
        ru = tr["returns_shadow_unblocked"] / max(tr["rays_shadow_unblocked"], 1)
        for mode in OFFSET_MODES:
            k = paper_rules_numpy(scene, grid, res, offset=mode)
            if mode == "renderer":
                same &= all(k[key] == tr[key] for key in ("hits", "os_kills", "sc_made_secondary", "sc_made_shadow",
                                                          "ic_kills", "os_to_sc_shadow", "suppressed"))
                k["nonshadow_returns_traced"] = tr["returns_primary"] + tr["returns_secondary"]
            est = k["nonshadow_returns"] + (k["ic_kills"] - k["shadow_self_blocked"]) * rb + k["os_to_sc_shadow"] * ru
            k["returns_per_ray_estimate"] = round(est / (k["nonshadow_rays"] + k["sc_made_shadow"]), 4)
            rows.append({"subdivision": n, "offset": mode, **k})
            log(f"  {n:3d}^3, offset {mode}: {k['hits']:,} hits, {k['self_hits']:,} self-hits")
    return rows, same


def self_intersection_pivot(rows, n):
    """Rows of the table at subdivision n: one per count, one column per offset mode, and the paper's."""
    i = PAPER_SUBDIVISIONS.index(n) if n in PAPER_SUBDIVISIONS else None
    paper = paper_counts_row(i) if i is not None else {}
    if i is not None:
        paper["returns_per_ray_estimate"] = PAPER_BALLS["returns_per_ray"][i]
    by_mode = {r["offset"]: r for r in rows if r["subdivision"] == n}
    out = []
    for key in ("eye_hits", "hits", "os_kills", "sc_made_secondary", "sc_made_shadow", "ic_kills", "os_to_sc_shadow",
                "suppressed", "suppressed_zero_luminance", "self_hits", "shadow_self_blocked", "candidates_per_hit",
                "nonshadow_returns", "nonshadow_returns_traced", "nonshadow_voxels", "nonshadow_tests",
                "returns_per_ray_estimate"):
        row = {"row": key}
        row.update({f"offset: {m}": by_mode[m].get(key, "") for m in OFFSET_MODES})
        row[f"paper {n}"] = paper.get(key, "")
        out.append(row)
    return out


# ---- output ---------------------------------------------------------------------------------

def fmt_unit(v, unit):
    if v == "" or v is None:
        return ""
    if unit == "K":
        return f"{v / 1e3:,.0f}"
    if unit == "M":
        return f"{v / 1e6:,.1f}" if v < 1e8 else f"{v / 1e6:,.0f}"
    if isinstance(v, float):
        return f"{v:.2f}"
    return f"{v:,}"


def write_csv(path, rows):
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in r.items()})


def cell(v):
    if isinstance(v, bool) or v is None:
        return "" if v is None else str(v)
    if isinstance(v, (int, np.integer)):
        return f"{v:,}"
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def md_rows(rows, first=None):
    """A Markdown table of dict rows (union of their keys)."""
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    return md_table(keys, [[cell(r.get(k, "")) for k in keys] for r in rows])


def md_table(header, rows):
    s = "| " + " | ".join(header) + " |\n|" + "|".join("---" for _ in header) + "|\n"
    for r in rows:
        s += "| " + " | ".join(str(x) for x in r) + " |\n"
    return s


def balls_comparison(balls_rows, subdivisions):
    """Rows: (key, label, unit, [(ours, paper, ratio) per subdivision]); the paper's values only
    where our subdivision is one of the paper's."""
    out, csv_rows = [], []
    for key, label, unit in ROWS:
        if key not in PAPER_BALLS and key not in ("os_to_sc", "os_to_sc_late_hits", "ic_to_sc", "tests_sphere",
                                                  "tests_polygon", "returns_holding_hit",
                                                  "returns_per_ray_early_accept"):
            continue
        cells = []
        for n in subdivisions:
            ours = balls_rows[n][key]
            paper = None
            if key in PAPER_BALLS and n in PAPER_SUBDIVISIONS:
                pv = PAPER_BALLS[key][PAPER_SUBDIVISIONS.index(n)]
                paper = pv * (1e3 if unit == "K" else 1e6 if unit == "M" else 1)
            ratio = ours / paper if paper else None
            cells.append((ours, paper, ratio))
            csv_rows.append({"row": key, "subdivision": n, "ours": ours,
                             "paper": "" if paper is None else (round(paper, 4) if unit == "" else int(paper)),
                             "ratio": "" if ratio is None else round(ratio, 3)})
        out.append((key, label, unit, cells))
    return out, csv_rows


def comparison_markdown(table, subdivisions):
    header = ["balls"]
    for n in subdivisions:
        header += [f"ours {n}", f"paper {n}", "ratio"]
    rows = []
    for _, label, unit, cells in table:
        r = [label.strip() if not label.startswith("  ") else "&nbsp;&nbsp;" + label.strip()]
        for ours, paper, ratio in cells:
            r += [fmt_unit(ours, unit), "" if paper is None else fmt_unit(paper, unit),
                  "" if ratio is None else f"{ratio:.2f}"]
        rows.append(r)
    return md_table(header, rows)


def comparison_text(table, subdivisions):
    w = max(len(lab) for _, lab, _, _ in table)
    head = f"{'balls (K; voxels, tests M)':<{w}}" + "".join(f" | {'ours ' + str(n):>9} {'paper':>7} {'ratio':>5}"
                                                            for n in subdivisions)
    lines = [head, "-" * len(head)]
    for _, label, unit, cells in table:
        s = f"{label:<{w}}"
        for ours, paper, ratio in cells:
            s += f" | {fmt_unit(ours, unit):>9} {'' if paper is None else fmt_unit(paper, unit):>7} " \
                 f"{'' if ratio is None else f'{ratio:.2f}':>5}"
        lines.append(s)
    return "\n".join(lines)


def plot(trace_rows, subdivisions, path, si_rows=()):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for name in SCENES:
        rs = [r for r in trace_rows if r["scene"] == name]
        if not rs:
            continue
        ns = [r["subdivision"] for r in rs]
        line, = axes[0].plot(ns, [r["voxels_traversed"] / 1e6 for r in rs], "o-", label=name)
        axes[1].plot(ns, [r["tests"] / 1e6 for r in rs], "o-", color=line.get_color(), label=name)
        axes[2].plot(ns, [r["returns_per_ray"] for r in rs], "o-", color=line.get_color(), label=name)
    for ax, key, scale in ((axes[0], "voxels_traversed", 1), (axes[1], "tests", 1), (axes[2], "returns_per_ray", 1)):
        ax.plot(PAPER_SUBDIVISIONS, [v * scale for v in PAPER_BALLS[key]], "k*--", ms=11, label="balls, paper")
        ax.set_xlabel("subdivision per axis")
        ax.set_xticks(subdivisions)
    est = [(r["subdivision"], r["returns_per_ray_estimate"]) for r in si_rows if r["offset"] == "none"]
    if est:
        axes[2].plot(*zip(*est), "s:", color="C0", label="balls, no self-intersection offset (estimate)")
        axes[2].legend(fontsize=8)
    axes[0].set_ylabel("voxels traversed (millions)")
    axes[1].set_ylabel("intersection tests (millions)")
    axes[1].set_yscale("log")
    axes[2].set_ylabel("IC -> OS returns per ray from outside")
    axes[0].set_title("OS work")
    axes[1].set_title("IC work")
    axes[2].set_title("Returns per ray")
    axes[0].legend(fontsize=8)
    fig.suptitle("3MPRT counts, 512x512, paper rules, threshold 1/512 (ours: lines; paper's balls: stars)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="our 3MPRT counts in the layout of the paper's tables")
    ap.add_argument("--quick", action="store_true",
                    help="64x64, subdivisions 8 and 16, scenes at size 2; tables to ref/ (the committed reference)")
    ap.add_argument("--out", default=None, help=f"output folder (default {OUT}, or {REF} with --quick)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--no-plot", action="store_true")
    a = ap.parse_args(argv)
    t_start = time.perf_counter()
    if a.quick:
        res, subdivisions, size, progress = 64, (8, 16), 2, False
    else:
        res, subdivisions, size, progress = 512, PAPER_SUBDIVISIONS, None, True
    out = a.out or (REF if a.quick else OUT)
    os.makedirs(out, exist_ok=True)
    scenes = {name: load(name, size) for name in SCENES}

    # 1. every scene and subdivision, traced
    trace_rows = []
    for name in SCENES:
        for n in subdivisions:
            t0 = time.perf_counter()
            row = trace_row(scenes[name], n, res, a.threads, progress)
            trace_rows.append({"scene": name, "subdivision": n, **row})
            log(f"traced {name:5s} at {n:3d}^3: {row['rays']:,} rays, {row['visits']:,} visits, "
                f"{row['tests']:,} tests ({time.perf_counter() - t0:.1f} s)")
    # counts that do not describe the grid are the same at every subdivision
    grid_independent = True
    for name in SCENES:
        rs = [r for r in trace_rows if r["scene"] == name]
        for key in rs[0]:
            if key not in GRID_KEYS and key not in ("subdivision",) and any(r[key] != rs[0][key] for r in rs):
                grid_independent = False
                log(f"WARNING: {name} {key} differs between subdivisions")
    write_csv(os.path.join(out, "paper_rows.csv"), trace_rows)

    # 2. balls beside the paper
    balls = {r["subdivision"]: r for r in trace_rows if r["scene"] == "balls"}
    table, cmp_csv = balls_comparison(balls, subdivisions)
    write_csv(os.path.join(out, "balls_vs_paper.csv"), cmp_csv)

    # 3. spd rules
    log("spd rules ...")
    spd_rows = [{"scene": name, **spd_row(scenes[name], res, a.threads)} for name in SCENES]
    write_csv(os.path.join(out, "spd_rules.csv"), spd_rows)

    # 4. explanations (balls)
    log("balls: thresholds ...")
    thr_rows = threshold_rows(scenes["balls"], res, a.threads)
    write_csv(os.path.join(out, "thresholds.csv"), thr_rows)
    log("zero-luminance shadow rays ...")
    zl_rows = []
    for name in SCENES:
        z = zero_luminance_row(scenes[name], res, a.threads)
        zl_rows.append({"scene": name, **(z or {"note": "not measured: transmissive (threshold 0 tree explodes)"})})
    write_csv(os.path.join(out, "zero_luminance.csv"), zl_rows)
    log("balls: camera angle ...")
    cam_rows = camera_rows(scenes["balls"], res, a.threads)
    write_csv(os.path.join(out, "camera.csv"), cam_rows)
    log("balls: grid shape ...")
    shape_rows = grid_shape_rows(scenes["balls"], subdivisions, res, a.threads)
    write_csv(os.path.join(out, "grid_shape.csv"), shape_rows)
    log("balls: paper rules in NumPy, with and without the self-intersection offset ...")
    si_rows, si_same = self_intersection_rows(scenes["balls"], subdivisions, res, a.threads, balls)
    write_csv(os.path.join(out, "self_intersection.csv"), si_rows)

    # Markdown
    md = [f"# Paper tables ({'quick: ' if a.quick else ''}{res}x{res}, paper rules, threshold 1/512"
          f"{', SPD size 2' if a.quick else ', SPD default sizes'})\n",
          f"Counts that do not describe the grid are identical at every subdivision: "
          f"{'yes' if grid_independent else 'NO'}.\n",
          "## balls: ours and the paper's (thousands; voxels and tests in millions)\n",
          comparison_markdown(table, subdivisions)]
    for name in SCENES:
        rs = {r["subdivision"]: r for r in trace_rows if r["scene"] == name}
        md.append(f"\n## {name}\n")
        md.append(md_table([name] + [str(n) for n in subdivisions],
                           [[lab.strip() if not lab.startswith("  ") else "&nbsp;&nbsp;" + lab.strip()]
                            + [fmt_unit(rs[n][key], unit) for n in subdivisions] for key, lab, unit in ROWS]))
    md.append("\n## spd rules (pixel corners, depth 5, no cutoff, no shadow ray toward a light behind)\n")
    md.append(md_rows(spd_rows))
    md.append("\n## balls at several thresholds (paper rules)\n")
    md.append(md_rows(thr_rows))
    md.append("\n## Suppressed shadow rays that carry zero luminance (paper rules, threshold 1/512)\n")
    md.append(md_rows(zl_rows))
    md.append("\n## balls: view angle (paper rules)\n")
    md.append(md_rows(cam_rows))
    md.append("\n## balls: grid shape and list construction (paper rules)\n")
    md.append(md_rows(shape_rows))
    mid = subdivisions[len(subdivisions) // 2]
    md.append(f"\n## balls: paper rules re-implemented in NumPy, at {mid}^3 (reproduces the renderer with the "
              f"renderer's offset: {'yes' if si_same else 'NO'})\n")
    md.append(md_rows(self_intersection_pivot(si_rows, mid)))
    md.append("\n### returns per ray from outside (estimate, see run.py) by subdivision\n")
    md.append(md_rows([{"subdivision": n, **{m: r["returns_per_ray_estimate"] for r in si_rows
                                              if r["subdivision"] == n for m in [r["offset"]]},
                        "ours, traced": balls[n]["returns_per_ray"],
                        "paper": PAPER_BALLS["returns_per_ray"][PAPER_SUBDIVISIONS.index(n)]
                        if n in PAPER_SUBDIVISIONS else ""} for n in subdivisions]))
    with open(os.path.join(out, "tables.md"), "w") as f:
        f.write("\n".join(md))

    log("")
    log(comparison_text(table, subdivisions))
    if not a.quick and not a.no_plot:
        try:
            plot(trace_rows, subdivisions, os.path.join(out, "paper_tables.png"), si_rows)
        except ImportError:
            log("matplotlib not installed: no plot (pip install matplotlib)")
    log(f"\nwrote {os.path.relpath(out)}/ in {time.perf_counter() - t_start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
