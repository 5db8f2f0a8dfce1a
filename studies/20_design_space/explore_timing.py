"""The time of one `mprt explore` per SPD scene at 512x512 (default settings:
built-in space, search at 64x64, the two best subdivisions polished at
512x512, level 0), budget 800 kGE.

    .venv/bin/python studies/20_design_space/explore_timing.py [RES] [BUDGET]
"""
import sys
import time

import mprt
from mprt.explore.explorer import explore


def main(res=512, budget=800.0):
    print(f"| scene | seconds | evaluations | search res. | level | subdivision | best design | cycles "
          f"| x 3MPPE | x S |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in mprt.SPD_SCENES:
        t0 = time.perf_counter()
        r = explore(mprt.Scene.spd(name), res, res, budget=float(budget), threads=2)
        s = time.perf_counter() - t0
        b, refs = r["best"], r["references"]
        print(f"| {name} | {s:.0f} | {r['evaluations']} | {'x'.join(map(str, r['search_resolution']))} "
              f"| {r['level']} | {'x'.join(map(str, b['subdivision']))} | {b['described']} | {b['cycles']:.3g} "
              f"| {refs['3mppe']['cycles'] / b['cycles']:.2f} | {refs['S']['cycles'] / b['cycles']:.2f} |",
              flush=True)


if __name__ == "__main__":
    main(*(float(a) if i else int(a) for i, a in enumerate(sys.argv[1:])))
