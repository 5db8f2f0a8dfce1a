"""SPD rules: the ray counts of SPD's standard test procedure per scene.

Under `spd` rules (eye rays through the pixel corners, each pixel the mean of
its four corners, depth 5, no contribution cutoff, no shadow ray toward a
light behind the surface) each scene is rendered once with its default grid;
the counters give eye rays and hits, reflection, refraction and shadow rays,
the rays cut by the depth limit and the blocked shadow rays.  None of these
depends on the grid.

Writes spd_rules.csv to studies/out/04_spd_rules/ (--quick: 64x64, scenes at
size 2, to ref/).

    python studies/04_spd_rules/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _common import nonshadow_hits, per_scene_study  # noqa: E402


def spd_row(scene, res, threads) -> dict:
    _, c = scene.grid().render(res, res, rules="spd", threads=threads)
    return {"eye_rays": c["eye_rays"], "eye_hits": c["eye_hits"], "reflect_rays": c["reflect_rays"],
            "refract_rays": c["refract_rays"], "shadow_rays": c["shadow_rays"],
            "total_rays": c["eye_rays"] + c["reflect_rays"] + c["refract_rays"] + c["shadow_rays"],
            "depth_limited": c["suppressed_rays"], "shadow_blocked": c["hits"] - nonshadow_hits(c)}


def main(argv=None) -> int:
    return per_scene_study(__file__, "ray counts under SPD's test procedure", "spd_rules.csv", spd_row, argv)


if __name__ == "__main__":
    raise SystemExit(main())
