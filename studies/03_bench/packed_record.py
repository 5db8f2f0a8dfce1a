"""Scratch experiment (issue 21, item 1): how much a packed visit record would save.

Not a format change: each SPD scene's 512x512 trace is made in memory, its visits copied into a
28-byte record holding the same values (ray uint32, voxel_id int32, prim int32, tests 4 x uint16,
steps of an OS visit or vertices of an IC visit in one uint32, stage, outcome, made, suppressed),
checked lossless, and both written through the trace writer's path (tracewriter.Appender: CRC-32 while
copying, direct writes) in 6 MB chunks, best of 3, alternated.

    python studies/03_bench/packed_record.py [balls,gears,mount,rings,tetra,tree]
"""
import os, sys, tempfile, time
import numpy as np
import mprt
from mprt import tracewriter
from mprt.trace import VISIT_DTYPE

PACKED = np.dtype([("ray", "<u4"), ("voxel_id", "<i4"), ("prim", "<i4"), ("tests", "<u2", (4,)),
                   ("count", "<u4"), ("stage", "u1"), ("outcome", "u1"), ("made", "u1"), ("suppressed", "u1")])
assert PACKED.itemsize == 28


def pack(v):
    os_ = v["stage"] == 0
    assert not np.any(v["vertices"][os_]) and not np.any(v["steps"][~os_]), "steps and vertices overlap"
    for k, t in (("ray", np.uint32), ("voxel_id", np.int32), ("prim", np.int32)):
        assert v[k].min() >= np.iinfo(t).min and v[k].max() <= np.iinfo(t).max, k
    assert v["tests"].max() <= 65535 and v["steps"].max() < 2 ** 32 and v["vertices"].max() < 2 ** 32
    p = np.empty(len(v), PACKED)
    for k in ("ray", "voxel_id", "prim", "tests", "stage", "outcome", "made", "suppressed"):
        p[k] = v[k]
    p["count"] = np.where(os_, v["steps"], v["vertices"])
    back = np.zeros(len(v), VISIT_DTYPE)
    for k in ("ray", "voxel_id", "prim", "tests", "stage", "outcome", "made", "suppressed"):
        back[k] = p[k]
    back["steps"] = np.where(os_, p["count"], 0)
    back["vertices"] = np.where(os_, 0, p["count"])
    assert back.tobytes() == v.tobytes(), "not lossless"
    return p


def write(a, path, chunk=6 << 20):
    if os.path.exists(path):
        os.unlink(path)
    fd = os.open(path, os.O_RDWR | os.O_CREAT)
    direct = tracewriter.direct_fd(path)
    b = a.view(np.uint8).reshape(-1)
    c, w = time.process_time(), time.perf_counter()
    ap = tracewriter.Appender(fd, direct, 188, tracewriter.aligned_buffer(4 << 20))
    for i in range(0, len(b), chunk):
        ap.write(b[i:i + chunk])
    ap.close()
    out = time.perf_counter() - w, time.process_time() - c
    os.close(fd)
    if direct is not None:
        os.close(direct)
    os.unlink(path)
    return out


print("scene | visits | 48-byte MB | 28-byte MB | saved | write 48 s (CPU) | write 28 s (CPU)")
scenes = sys.argv[1] if len(sys.argv) > 1 else "balls,gears,mount,rings,tetra,tree"
scratch = os.path.join(tempfile.mkdtemp(prefix="packed-"), "pk.bin")
for scene in scenes.split(","):
    g = mprt.Scene.load(scene).grid(None)
    _, tr = g.trace(512, 512)
    v = np.asarray(tr.visits)
    p = pack(v)
    t48, t28 = [], []
    for _ in range(3):
        t48.append(write(v, scratch))
        t28.append(write(p, scratch))
    w48, w28 = min(t48), min(t28)
    print(f"{scene} | {len(v)} | {v.nbytes / 1e6:.0f} | {p.nbytes / 1e6:.0f} | {1 - p.nbytes / v.nbytes:.0%} | "
          f"{w48[0]:.3f} ({min(x[1] for x in t48):.3f}) | {w28[0]:.3f} ({min(x[1] for x in t28):.3f})", flush=True)
    del tr, v, p
    mprt.tracing.release_buffers()
os.rmdir(os.path.dirname(scratch))
