"""``python -m mprt.cli.calibrate``: the cost model's calibration from the command line (the fit
and its cells: ``mprt.cost.calibrate``).

    python -m mprt.cli.calibrate                      # fit on the shipped counts, print residuals
    python -m mprt.cli.calibrate --trace --res 256    # re-trace the 15 cells first
    python -m mprt.cli.calibrate --write              # re-trace, fit, write the shipped model + counts
    python -m mprt.cli.calibrate --scenes balls       # fit on balls only, residuals for all
"""
from __future__ import annotations

import argparse
import json
import sys

from ..cost import calibrate


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m mprt.cli.calibrate", description=calibrate.__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default=None, help="comma-separated scenes to fit on (default: all five)")
    ap.add_argument("--trace", action="store_true", help="trace the cells anew instead of the shipped counts")
    ap.add_argument("--res", type=int, default=256, help="trace resolution (square; default 256)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--counts", default=None, help="counts CSV to fit (default: the shipped one)")
    ap.add_argument("--fixed-scale", action="store_true",
                    help="keep the stage scales at 100%% (fit latencies and per-visit overheads only)")
    ap.add_argument("--write", action="store_true",
                    help="trace, fit on all five scenes and write the shipped model and counts")
    ap.add_argument("--check", default=None, metavar="SCENE:N:RES,RES,...",
                    help="print the per-unit averages of one cell traced at several resolutions "
                         "with the shipped model, e.g. balls:50:128,256,512, and exit")
    ap.add_argument("--kernels", action="store_true",
                    help="print every kernel's operation counts and cycles with the shipped model, and exit")
    args = ap.parse_args(argv)
    if args.kernels:
        print(calibrate.kernel_report())
        return 0
    if args.check:
        return calibrate.resolution_check(args.check, args.threads)
    scenes = tuple(s for s in args.scenes.split(",") if s) if args.scenes else None
    if args.trace or args.write:
        rows = calibrate.collect(calibrate.SCENES, calibrate.SUBDIVISIONS, args.res, args.threads,
                                 progress=lambda m: print(m, file=sys.stderr))
    else:
        rows = calibrate.read_counts(args.counts or calibrate.COUNTS_FILE)
    cal = calibrate.fit(rows, None if args.write else scenes, free_scale=not args.fixed_scale)
    cal.model.info["command"] = "python -m mprt.cli.calibrate --write" if args.write else \
        "python -m mprt.cli.calibrate " + " ".join(argv if argv is not None else sys.argv[1:])
    print(json.dumps({"latency": cal.model.latency, "visit_overhead": cal.model.visit_overhead,
                      "scale": cal.model.scale}))
    print(calibrate.residual_table(cal.residuals, scenes))
    if args.write:
        calibrate.write_counts(rows)
        cal.model.info["residuals"] = [[r.scene, r.grid, r.stage, r.paper, round(r.ours, 4)] for r in cal.residuals]
        cal.model.save(calibrate.DEFAULT_FILE)
        print(f"wrote {calibrate.DEFAULT_FILE} and {calibrate.COUNTS_FILE}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
