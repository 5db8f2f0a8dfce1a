"""Precision: single-precision geometry against double, per SPD scene.

For each SPD scene at its default size:
  * error: hit distances of the float build against a double-precision
    reference on the scene's primary rays and on random rays (the double
    grid's hits, which the tests show are bit-identical to the double
    brute-force search; --brute re-checks that here on a sample): maximum
    and mean relative distance error over rays both builds hit, rays whose
    hit primitive differs, and leaks (the double build hits, the float build
    finds nothing);
  * pixels whose 8-bit value differs between float and double renders;
  * speed: intersect throughput and render time of both builds, measured
    side by side in this run (best of --repeat).
Writes precision.csv, precision.md and precision.png to
studies/out/02_precision/ (--quick: scenes at size 2, 48x48, 4000 random
rays, the error columns only, to ref/).

    python studies/02_precision/run.py [--scenes tetra,mount] [--res 512] [--quick]
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import best_time, log, md_rows, random_rays, study_args, write_csv  # noqa: E402

SPEED = ("isect_speedup_float", "render_speedup_float", "isect_double_Mrays", "isect_float_Mrays")


def study(name, size, res, nrand, repeat, brute) -> dict:
    sd = mprt.Scene.spd(name, size)
    sf = mprt.Scene.spd(name, size, precision="single")
    n = sd.default_grid(density=4, limit=512)
    gd, gf = sd.grid(n), sf.grid(n)
    po, pd = gd.camera_rays(res, res)
    ro, rd = random_rays(sd, nrand, seed=7)
    o, d = np.vstack([po, ro]), np.vstack([pd, rd])
    td_time, (td, pdd) = best_time(lambda: gd.intersect(o, d), repeat)
    tf_time, (tf, pf) = best_time(lambda: gf.intersect(o, d), repeat)
    if brute:
        k = slice(0, len(o), max(1, len(o) // 4000))
        tb, pb = sd.grid(1).intersect(o[k], d[k])
        assert np.array_equal(tb, td[k]) and np.array_equal(pb, pdd[k]), "double grid differs from brute force"
    both = np.isfinite(td) & np.isfinite(tf)
    rel = np.abs(tf[both] - td[both]) / td[both]
    rdd_time, (imd, _) = best_time(lambda: gd.render(res, res), repeat)
    rdf_time, (imf, _) = best_time(lambda: gf.render(res, res), repeat)
    q = lambda im: np.clip(np.round(np.clip(im, 0, 1) * 255), 0, 255).astype(np.uint8)  # noqa: E731
    return {
        "scene": name, "grid": "x".join(map(str, n)), "rays": len(o),
        "max_rel_err": f"{rel.max() if rel.size else 0.0:.3e}", "mean_rel_err": f"{rel.mean() if rel.size else 0.0:.3e}",
        "other_prim": int(np.sum(both & (pdd != pf))), "leaks": int(np.sum(np.isfinite(td) & ~np.isfinite(tf))),
        "extra_hits": int(np.sum(~np.isfinite(td) & np.isfinite(tf))),
        "pixels_differ": int(np.sum(np.any(q(imd) != q(imf), axis=2))), "pixels": res * res,
        "isect_speedup_float": td_time / tf_time, "render_speedup_float": rdd_time / rdf_time,
        "isect_double_Mrays": len(o) / td_time / 1e6, "isect_float_Mrays": len(o) / tf_time / 1e6,
    }


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["scene"] for r in rows]
    x = np.arange(len(rows))
    err = {k: [max(float(r[k]), 1e-18) for r in rows] for k in ("max_rel_err", "mean_rel_err")}
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    a1.bar(x - 0.2, [r["isect_speedup_float"] for r in rows], 0.4, label="intersect")
    a1.bar(x + 0.2, [r["render_speedup_float"] for r in rows], 0.4, label="render")
    a1.axhline(1, color="k", lw=0.8)
    a1.set_xticks(x, names)
    a1.set_ylabel("float speed / double speed")
    a1.set_title("Speed of single precision")
    a1.legend()
    a2.bar(x - 0.2, err["max_rel_err"], 0.4, label="max rel. distance error")
    a2.bar(x + 0.2, err["mean_rel_err"], 0.4, label="mean rel. distance error")
    a2.set_yscale("log")
    a2.set_xticks(x, names)
    a2.set_title("Error of single precision vs double")
    for i, r in enumerate(rows):
        a2.annotate(f"{r['pixels_differ']} px\n{r['leaks']} leaks", (i, err["max_rel_err"][i]), ha="center",
                    va="bottom", fontsize=7)
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def options(ap):
    ap.add_argument("--scenes", default=",".join(mprt.SPD_SCENES))
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--random", type=int, default=100000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--brute", action="store_true", help="re-check the double reference against brute force")


def main(argv=None) -> int:
    a, out = study_args(__file__, "float vs double: speed and error per SPD scene",
                        "scenes at size 2, 48x48, 4000 random rays, error columns only", argv, options)
    size = None
    if a.quick:
        size, a.res, a.random, a.repeat = 2, 48, 4000, 1
    rows = []
    for name in a.scenes.split(","):
        r = study(name, size, a.res, a.random, a.repeat, a.brute)
        rows.append(r)
        log(f"{name:6s} max rel err {r['max_rel_err']}  mean {r['mean_rel_err']}  other prim {r['other_prim']:6d}  "
            f"leaks {r['leaks']:5d}  pixels differ {r['pixels_differ']:6d}/{r['pixels']}  "
            f"float speed x{r['isect_speedup_float']:.2f} (intersect), x{r['render_speedup_float']:.2f} (render)")
    if a.quick:  # timings are not reproducible: the reference keeps the error columns
        rows = [{k: v for k, v in r.items() if k not in SPEED} for r in rows]
    write_csv(os.path.join(out, "precision.csv"), rows)
    if not a.quick:
        with open(os.path.join(out, "precision.md"), "w") as f:
            f.write(md_rows([{k: f"{v:.3g}" if isinstance(v, float) else v for k, v in r.items()} for r in rows]))
        plot(rows, os.path.join(out, "precision.png"))
        log(f"wrote {os.path.join(out, 'precision.png')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
