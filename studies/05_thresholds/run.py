"""Thresholds: does the paper's contribution threshold explain its balls counts?

balls under `paper` rules at contribution thresholds 0, 1/512 (our default),
0.01, 0.05 and 0.1, with the default grid, one render each: hits, OS kills,
secondary and shadow rays, blocked and unblocked shadow rays, suppressed rays
and candidates per hit ((secondary + shadow + suppressed) / hits), with the
paper's figures at subdivision 50 as the last row.

Writes thresholds.csv to studies/out/05_thresholds/ (--quick: 64x64, balls at
size 2, to ref/).

    python studies/05_thresholds/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import counts_row, paper_counts_row, quick_or_full, study_args, write_table  # noqa: E402

THRESHOLDS = (0.0, 1 / 512, 0.01, 0.05, 0.1)


def main(argv=None) -> int:
    a, out = study_args(__file__, "balls at several contribution thresholds", "64x64, balls at size 2", argv)
    res, size, _ = quick_or_full(a.quick)
    grid = mprt.Scene.spd("balls", size).grid()
    rows = []
    for t in THRESHOLDS:
        _, c = grid.render(res, res, rules="paper", threshold=t, threads=a.threads)
        rows.append({"threshold": round(t, 6), **counts_row(c)})
    rows.append({"threshold": "paper, 50", "eye_hits": "", **paper_counts_row()})
    write_table(out, "thresholds.csv", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
