"""Precision study: single-precision geometry against double, per SPD scene.

For each SPD scene at its default size:
  * error: hit distances of the float build against a double-precision
    reference on the scene's 512x512 primary rays and on random rays (the
    double grid's hits, which the tests show are bit-identical to the
    double brute-force search; --brute re-checks that here on a sample):
    maximum and mean relative distance error over rays both builds hit,
    rays whose hit primitive differs, and leaks (the double build hits, the
    float build finds nothing);
  * pixels whose 8-bit value differs between float and double renders;
  * speed: intersect throughput and render time of both builds, measured
    side by side in this run (best of --repeat).
Writes studies/out/precision.csv, .md and .png (speed and error side by side).

    python studies/precision/run.py [--scenes tetra,mount] [--res 512] [--quick]
"""
from __future__ import annotations

import argparse
import csv
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
import mprt  # noqa: E402
from bench import best_time, random_rays  # noqa: E402

OUT = os.path.join(HERE, "..", "out")


def study(name, res, nrand, repeat, brute):
    sd = mprt.Scene.spd(name)
    sf = mprt.Scene.spd(name, precision="single")
    n = sd.default_grid(density=4, limit=512)
    gd, gf = sd.grid(n), sf.grid(n)
    po, pd = sd.camera_rays(res, res)
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
    leaks = int(np.sum(np.isfinite(td) & ~np.isfinite(tf)))
    extra = int(np.sum(~np.isfinite(td) & np.isfinite(tf)))
    other = int(np.sum(both & (pdd != pf)))
    rdd_time, (imd, _) = best_time(lambda: gd.render(res, res), repeat)
    rdf_time, (imf, _) = best_time(lambda: gf.render(res, res), repeat)
    q = lambda im: np.clip(np.round(np.clip(im, 0, 1) * 255), 0, 255).astype(np.uint8)  # noqa: E731
    pix = int(np.sum(np.any(q(imd) != q(imf), axis=2)))
    return {
        "scene": name, "grid": "x".join(map(str, n)), "rays": len(o),
        "max_rel_err": float(rel.max()) if rel.size else 0.0, "mean_rel_err": float(rel.mean()) if rel.size else 0.0,
        "other_prim": other, "leaks": leaks, "extra_hits": extra, "pixels_differ": pix, "pixels": res * res,
        "isect_speedup_float": td_time / tf_time, "render_speedup_float": rdd_time / rdf_time,
        "isect_double_Mrays": len(o) / td_time / 1e6, "isect_float_Mrays": len(o) / tf_time / 1e6,
    }


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["scene"] for r in rows]
    x = np.arange(len(rows))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    a1.bar(x - 0.2, [r["isect_speedup_float"] for r in rows], 0.4, label="intersect")
    a1.bar(x + 0.2, [r["render_speedup_float"] for r in rows], 0.4, label="render")
    a1.axhline(1, color="k", lw=0.8)
    a1.set_xticks(x, names)
    a1.set_ylabel("float speed / double speed")
    a1.set_title("Speed of single precision")
    a1.legend()
    a2.bar(x - 0.2, [max(r["max_rel_err"], 1e-18) for r in rows], 0.4, label="max rel. distance error")
    a2.bar(x + 0.2, [max(r["mean_rel_err"], 1e-18) for r in rows], 0.4, label="mean rel. distance error")
    a2.set_yscale("log")
    a2.set_xticks(x, names)
    a2.set_title("Error of single precision vs double")
    for i, r in enumerate(rows):
        a2.annotate(f"{r['pixels_differ']} px\n{r['leaks']} leaks", (i, max(r["max_rel_err"], 1e-18)), ha="center",
                    va="bottom", fontsize=7)
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="float vs double: speed and error per SPD scene")
    ap.add_argument("--scenes", default=",".join(mprt.SPD_SCENES))
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--random", type=int, default=100000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--brute", action="store_true", help="re-check the double reference against brute force")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=OUT)
    a = ap.parse_args(argv)
    if a.quick:
        a.res, a.random, a.repeat = 128, 10000, 1
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for name in a.scenes.split(","):
        r = study(name, a.res, a.random, a.repeat, a.brute)
        rows.append(r)
        print(f"{name:6s} max rel err {r['max_rel_err']:.2e}  mean {r['mean_rel_err']:.2e}  other prim {r['other_prim']:6d}  "
              f"leaks {r['leaks']:5d}  pixels differ {r['pixels_differ']:6d}/{r['pixels']}  "
              f"float speed x{r['isect_speedup_float']:.2f} (intersect), x{r['render_speedup_float']:.2f} (render)",
              flush=True)
    with open(os.path.join(a.out, "precision.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    with open(os.path.join(a.out, "precision.md"), "w") as f:
        keys = list(rows[0])
        f.write("| " + " | ".join(keys) + " |\n|" + "---|" * len(keys) + "\n")
        for r in rows:
            f.write("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in r.values()) + " |\n")
    try:
        plot(rows, os.path.join(a.out, "precision.png"))
        print(f"wrote {os.path.join(a.out, 'precision.png')}")
    except ImportError:
        print("matplotlib not installed: no plot (pip install matplotlib)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
