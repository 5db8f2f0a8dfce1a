"""What the one validation of a trace (mprt.tracevalid, issue 19 item 1) costs, side by side in
one process with what a reader does anyway: the checksums of a verified load, the statistics and
the invariant check.  Best of N of each, alternated; the ratios are what to compare (the machine
may be shared).

    mprt trace balls --grid 50 --res 512x512 -o /tmp/v512.npz
    python studies/03_bench/validate_cost.py /tmp/v512.npz --repeat 3
"""
from __future__ import annotations

import argparse
import resource
import time

from mprt import load_trace, tracecheck, tracevalid


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trace")
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args()
    tr = load_trace(a.trace, mmap=True, verify=False)
    arrays = tr.arrays()
    steps = {
        "validation: meta schema": lambda: tracevalid.check_meta(tr.meta, 1 << 40),
        "validation: dtypes, shapes, ranges": lambda: tracevalid.check_arrays(tr.meta, arrays),
        "checksums (load_trace verify, incl. validation)": lambda: load_trace(a.trace, mmap=True),
        "invariants (tracecheck)": lambda: tracecheck.check(tr),
        "statistics": lambda: tr.stats(),
    }
    best = {k: float("inf") for k in steps}
    for _ in range(a.repeat):
        for k, f in steps.items():
            t0 = time.perf_counter()
            f()
            best[k] = min(best[k], time.perf_counter() - t0)
    ranges = best["validation: dtypes, shapes, ranges"]
    print(f"{a.trace}: {len(tr.rays)} rays, {len(tr.visits)} visits; best of {a.repeat}")
    for k, t in best.items():
        print(f"  {k:50s} {t:8.3f} s   validation/this {ranges / t if t else float('nan'):6.3f}")
    print(f"  max RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
