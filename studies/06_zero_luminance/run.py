"""Zero luminance: how many suppressed shadow rays point at a light behind the surface?

Under `paper` rules a shadow ray whose contribution falls under the threshold
is suppressed and counted, and a light behind the surface (N.L <= 0) gives
contribution 0.  Traces at threshold 0 (every light gets a shadow ray) and
1e-300 (only luminance 0 is cut) make the same primary and secondary rays and
differ only by those zero-luminance rays; keeping the rays whose contribution
reaches the default threshold 1/512 splits the default render's suppressed
rays into zero-luminance shadow rays, dim shadow rays and secondary rays.
This is exact, but a transmissive scene (mount) cannot be run at threshold 0:
its ray tree grows to depth 64 in both directions.

Writes zero_luminance.csv to studies/out/06_zero_luminance/ (--quick: 64x64,
scenes at size 2, to ref/).

    python studies/06_zero_luminance/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _common import nonshadow_hits, per_scene_study  # noqa: E402
from mprt import Outcome, RayKind, Stage  # noqa: E402

THRESHOLD = 1 / 512


def shadows_kept(tr) -> int:
    """Shadow rays of a trace whose contribution reaches THRESHOLD."""
    r = tr.rays
    return int(np.sum((r["kind"] == RayKind.SHADOW) & (r["contribution"] >= THRESHOLD)))


def zero_luminance_row(scene, res, threads) -> dict:
    """The split of the suppressed rays at THRESHOLD, or a note for a transmissive scene."""
    info = scene.info()
    if np.any(scene.materials()["t"] > 0):
        return {"note": "not measured: transmissive (threshold 0 tree explodes)"}
    grid = scene.grid()
    _, a = grid.trace(res, res, rules="paper", threshold=0.0, threads=threads)
    _, b = grid.trace(res, res, rules="paper", threshold=1e-300, threads=threads)
    _, c = grid.render(res, res, rules="paper", threshold=THRESHOLD, threads=threads)
    shaded = nonshadow_hits(c)
    va = a.visits
    shaded_a = int(np.sum((va["stage"] == Stage.SC) & (va["outcome"] == Outcome.SHADED)
                          & (a.rays["contribution"][va["ray"]] >= THRESHOLD)))
    if shaded_a != shaded:
        raise AssertionError(f"{scene.name}: the threshold-0 tree shades {shaded_a} hits, the default {shaded}")
    made_a = shadows_kept(a)
    zero = made_a - shadows_kept(b)
    candidates = info["lights"] * shaded
    shadow_supp = candidates - c["shadow_rays"] - (info["lights"] * shaded_a - made_a)
    return {"lights": info["lights"], "hits": shaded, "shadow_candidates": candidates,
            "shadow_rays": c["shadow_rays"], "suppressed": c["suppressed_rays"],
            "suppressed_shadow": shadow_supp, "suppressed_zero_luminance": zero,
            "suppressed_dim_shadow": shadow_supp - zero, "suppressed_secondary": c["suppressed_rays"] - shadow_supp}


def main(argv=None) -> int:
    return per_scene_study(__file__, "suppressed shadow rays that carry zero luminance", "zero_luminance.csv", zero_luminance_row, argv)


if __name__ == "__main__":
    raise SystemExit(main())
