"""Camera: does the view angle explain the paper's balls counts?

balls under `paper` rules with the view angle moved around SPD's 45 degrees:
45; 45 spanning the image's edges rather than the centres of the first and
last pixel (the same pixel pitch, as our centre-to-centre angle); 40; 35; 30.
One render each with the default grid, and the paper's figures at subdivision
50 as the last row.

Writes camera.csv to studies/out/07_camera/ (--quick: 64x64, balls at size 2,
to ref/).

    python studies/07_camera/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import counts_row, paper_counts_row, quick_or_full, study_args, write_table  # noqa: E402

ANGLES = (45.0, "edges", 40.0, 35.0, 30.0)  # "edges": 45 degrees spanning the image's edges


def balls_with_angle(size, angle):
    """balls with another view angle, set before any grid is built."""
    scene = mprt.Scene.spd("balls", size)
    i = scene.info()
    scene.set_view(i["from"], i["at"], i["up"], angle, i["hither"], i["resolution"])
    return scene


def main(argv=None) -> int:
    a, out = study_args(__file__, "balls at several view angles", "64x64, balls at size 2", argv)
    res, size, _ = quick_or_full(a.quick)
    rows = []
    for angle in ANGLES:
        if angle == "edges":  # the pixel pitch of 45 degrees over res pixels, as a centre-to-centre angle
            angle = round(2 * math.degrees(math.atan(math.tan(math.radians(22.5)) * (res - 1) / res)), 4)
        _, c = balls_with_angle(size, angle).grid().render(res, res, rules="paper", threads=a.threads)
        rows.append({"angle": angle, **counts_row(c)})
    rows.append({"angle": "paper, 50", "eye_hits": "", **paper_counts_row()})
    write_table(out, "camera.csv", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
