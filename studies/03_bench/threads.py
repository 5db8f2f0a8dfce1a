"""Thread scaling of renders: every SPD scene at its default size and grid, RES x RES (default
256), 1 and 2 threads interleaved, best of REPEAT (default 3), the images checked bit-identical.

    .venv/bin/python studies/03_bench/threads.py [RES [REPEAT]]
"""
import time, mprt, sys
res = int(sys.argv[1]) if len(sys.argv) > 1 else 256
repeat = int(sys.argv[2]) if len(sys.argv) > 2 else 3
for name in mprt.SPD_SCENES:
    g = mprt.Scene.spd(name).grid()
    best = {1: 1e9, 2: 1e9}
    ref = None
    for rep in range(repeat):
        for t in (1, 2):
            t0 = time.perf_counter(); img, c = g.render(res, res, threads=t); dt = time.perf_counter() - t0
            best[t] = min(best[t], dt)
            if ref is None: ref = img
            else: assert (img == ref).all()
    print(f"{name:6s} 1 thread {best[1]:.3f} s, 2 threads {best[2]:.3f} s, speed-up {best[1]/best[2]:.2f}", flush=True)
