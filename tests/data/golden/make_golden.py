"""Regenerate the golden traces: every SPD scene at size 1, 24x24 samples, paper
rules, grids 4 and 9.  Run from the repository root:

    python tests/data/golden/make_golden.py

Only rerun this when a change to the tracer is meant to change traces; the
test test_golden_traces_regenerate_bit_identical guards them otherwise."""
import json
import os

import mprt

HERE = os.path.dirname(os.path.abspath(__file__))

for name in mprt.SPD_SCENES:
    scene = mprt.Scene.spd(name, 1)
    for n in (4, 9):
        _, tr = scene.grid(n).trace(24, 24, rules="paper", tile=8)
        base = os.path.join(HERE, f"{name}-g{n}")
        tr.save(base + ".npz", compress=True)
        with open(base + ".stats.json", "w") as f:
            json.dump(mprt.load_trace(base + ".npz").check(), f, indent=1, sort_keys=True)
        print(base, os.path.getsize(base + ".npz"), "bytes")
