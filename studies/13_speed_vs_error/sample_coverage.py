"""How often the tile-sampled estimate's 95% interval covers the full replay (issue 20).

For each SPD scene (its default size and grid): one whole frame traced at RESxRES in 16x16
tiles, its level-1 replay on model M the truth; for seeds 1..SEEDS the sample SPEC:K:SEED of
its tiles (the same trees a scene-traced sample holds) replayed at level 1 and scaled by
``sampled.estimate``; prints, per scene, the seeds whose interval covered the truth, the
worst error and the mean half-width.  The figures in ``mprt.fidelity.cli.TILE_COVERAGE``
(why ``mprt simulate`` refuses samples of tiles) come from

    .venv/bin/python studies/13_speed_vs_error/sample_coverage.py --res 256 --k 16 --seeds 20
    .venv/bin/python studies/13_speed_vs_error/sample_coverage.py --res 256 --k 64 --seeds 20
    .venv/bin/python studies/13_speed_vs_error/sample_coverage.py --res 256 --k 16 --seeds 20 --method stratified
"""
import argparse
import time
from types import SimpleNamespace

import numpy as np

import mprt
from mprt.cost import CostModel
from mprt.fidelity import Analytical, sample_trace
from mprt.fidelity import sampled as S
from mprt.fidelity.compiled import Compiled
from mprt.machine import builtin
from mprt.scene import SPD_SCENES


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--res", type=int, default=256, help="frame edge in samples (default 256)")
    p.add_argument("--k", type=int, default=16, help="random: tiles drawn; stratified: tiles per block (default 16)")
    p.add_argument("--seeds", type=int, default=20, help="seeds 1..SEEDS (default 20)")
    p.add_argument("--method", choices=("random", "stratified"), default="random", help="default random")
    p.add_argument("--scenes", default=",".join(SPD_SCENES), help="comma-separated (default: all six)")
    p.add_argument("--threads", type=int, default=2, help="tracing threads (default 2)")
    a = p.parse_args(argv)
    cm, cfg = CostModel.default(), builtin("M")
    for name in a.scenes.split(","):
        t0 = time.perf_counter()
        scene = mprt.Scene.spd(name)
        _, frame = scene.grid(scene.default_grid()).trace(a.res, a.res, tile=16, threads=a.threads)
        vc = cm.visit_costs(frame, cfg.processors())
        truth = Compiled(frame, vc).cycles(cfg)
        covered, errs, halves = 0, [], []
        for seed in range(1, a.seeds + 1):
            st = sample_trace(frame, f"{a.method}:{a.k}:{seed}")
            svc = SimpleNamespace(process=vc.process[st.visits], receive=vc.receive[st.visits],
                                  send=vc.send[st.visits], inject_process=vc.inject_process,
                                  inject_send=vc.inject_send)
            cycles = Compiled(st.trace, svc).cycles(cfg)
            sc = S.estimate(st, SimpleNamespace(cycles=cycles), Analytical(st.trace, svc), cfg)
            covered += sc.interval[0] <= truth <= sc.interval[1]
            errs.append(sc.cycles / truth - 1)
            halves.append((sc.interval[1] - sc.interval[0]) / 2 / truth)
        print(f"{name:6s} {a.res}x{a.res} {a.method}:{a.k}: covered {covered}/{a.seeds}, worst error "
              f"{100 * max(map(abs, errs)):.1f}%, mean half-width {100 * np.mean(halves):.1f}% "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
