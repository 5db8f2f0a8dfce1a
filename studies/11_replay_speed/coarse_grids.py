"""Level 3 per design on the explorer's own traces (balls at 64x64, every subdivision of the
built-in space): milliseconds a design for the 3MPPE and for the explorer's usual answer (two
copies of one whole ray tracer, 4 KiB caches, two PEs), best of --runs after a first run.  At
coarse grids a voxel's data is larger than a 4 KiB cache, so that every look-up misses line by
line; that is where the caches' repeat rule (replay_memory.c) pays.

    python studies/11_replay_speed/coarse_grids.py [--scene balls] [--res 64] [--runs 3]

Run it under two builds (PYTHONPATH=<other checkout>/python) to compare; the cycles must agree."""
import argparse
import time

import mprt
from mprt.explore.evaluate import SceneEvaluator, grid_dims
from mprt.explore.space import Design, Point, default_space, base_design

WHOLE = Design(mapping="OS+IC+SC", replication={"OS": 2, "IC": 1, "SC": 1},
               units={"OS": {"int": 2, "fp": 3}, "IC": {"int": 1, "fp": 1}, "SC": {"general": 1}},
               cache={"IC": 4, "SC": 4}, pes=2)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="balls")
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    sc = mprt.Scene.spd(a.scene)
    se = SceneEvaluator(sc, a.res, a.res, level=3, shape="proportional")
    ns = next(v for v in default_space().variables if v.name == "subdivision.n").values
    print("| n | grid | visits | 3MPPE ms | cycles | whole x2, 2 PEs ms | cycles |")
    print("|---|---|---|---|---|---|---|")
    for n in ns:
        dims = grid_dims(sc, (n,), "proportional")
        row = [str(n), "x".join(map(str, dims)), str(len(se.trace(dims).visits))]
        for d in (base_design(), WHOLE):
            p = Point((n,), d)
            r = se.run(p)
            best = min((lambda t0: (se.run(p), time.perf_counter() - t0)[1])(time.perf_counter())
                       for _ in range(a.runs))
            row += [f"{best * 1e3:.1f}", f"{r.cycles:.0f}"]
        print("| " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()
