"""Per-ray cost traces: agreement with the renderer, invariants, determinism, files."""
import io
import json
import os
import zipfile

import numpy as np
import pytest

import mprt
from mprt.trace import BLOCKED, IC, OS, SC, SHADED, TraceError

GOLDEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "golden")
SCENE_SIZES = {"balls": 1, "gears": 1, "mount": 2, "rings": 1, "tetra": 2, "tree": 4}


def traced(name, n=8, w=24, h=24, **kw):
    grid = mprt.Scene.spd(name, SCENE_SIZES[name]).grid(n)
    return grid, grid.trace(w, h, **kw)


@pytest.mark.parametrize("name", mprt.SPD_SCENES)
@pytest.mark.parametrize("rules", ["paper", "spd"])
def test_trace_agrees_with_render_and_keeps_its_invariants(name, rules):
    """A trace's image and counts equal the untraced render's, and its invariants hold."""
    grid, (img, tr) = traced(name, rules=rules)
    ref, c = grid.render(24, 24, rules=rules)
    assert np.array_equal(img, ref)
    st = tr.check()
    assert st["os_input_primary"] == c["eye_rays"]
    assert st["sc_made_shadow"] == c["shadow_rays"]
    assert st["sc_made_reflect"] == c["reflect_rays"] and st["sc_made_refract"] == c["refract_rays"]
    assert st["suppressed"] == c["suppressed_rays"]
    assert st["voxels_traversed"] == c["voxels_traversed"]
    assert st["tests_by_kind"] == c["tests"]
    assert st["ic_input"] == c["ic_visits"] and st["sc_input"] == c["sc_visits"]
    assert st["ic_to_sc"] + st["os_to_sc_late_hits"] + st["ic_kills"] == c["hits"]


def test_traces_are_the_same_bits_with_any_thread_count():
    """1 and 3 threads give identical ray and visit arrays."""
    grid = mprt.Scene.spd("mount", 2).grid(10)
    _, a = grid.trace(40, 40, threads=1, tile=8)
    _, b = grid.trace(40, 40, threads=3, tile=8)
    assert np.array_equal(a.rays, b.rays) and np.array_equal(a.visits, b.visits)


def test_save_load_round_trip_and_streaming_to_disk(tmp_path):
    """A saved trace loads back equal; a trace streamed to disk equals one built in memory."""
    grid = mprt.Scene.spd("balls", 1).grid(6)
    _, mem = grid.trace(20, 20, tile=4)
    p = tmp_path / "t.npz"
    mem.save(p)
    back = mprt.load_trace(p)
    for k in ("rays", "visits", "voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material"):
        assert np.array_equal(getattr(back, k), getattr(mem, k)), k
    assert back.meta["grid"] == [6, 6, 6] and back.meta["version"] == mprt.trace.FORMAT_VERSION
    _, disk = grid.trace(20, 20, tile=4, path=tmp_path / "s.npz")
    assert isinstance(disk.visits, np.memmap)
    assert np.array_equal(disk.rays, mem.rays) and np.array_equal(disk.visits, mem.visits)
    mapped = mprt.load_trace(tmp_path / "s.npz", mmap=True)
    assert mapped.stats() == mem.stats()
    assert mem.stats() == mprt.trace.trace_stats(mem, chunk=7)  # chunk edges split rays' visit runs


def test_bad_trace_files_are_clear_errors(tmp_path):
    """Unknown version, truncation and tampering each raise TraceError saying so."""
    _, (_, tr) = traced("tetra", w=12, h=12)
    good = tmp_path / "good.npz"
    tr.save(good)
    data = good.read_bytes()
    (tmp_path / "trunc.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(TraceError, match="trunc.npz"):
        mprt.load_trace(tmp_path / "trunc.npz")
    # tamper: change one byte inside the visits array
    with zipfile.ZipFile(good) as z:
        members = {n: z.read(n) for n in z.namelist()}
    v = bytearray(members["visits.npy"])
    v[-5] ^= 0xFF
    members["visits.npy"] = bytes(v)
    with zipfile.ZipFile(tmp_path / "tamper.npz", "w") as z:
        for n, b in members.items():
            z.writestr(n, b)
    with pytest.raises(TraceError, match="checksum"):
        mprt.load_trace(tmp_path / "tamper.npz")
    meta = json.loads(members["meta.json"])
    meta["version"] = 99
    members["meta.json"] = json.dumps(meta).encode()
    members["visits.npy"] = zipfile.ZipFile(good).read("visits.npy")
    with zipfile.ZipFile(tmp_path / "v99.npz", "w") as z:
        for n, b in members.items():
            z.writestr(n, b)
    with pytest.raises(TraceError, match="version 99"):
        mprt.load_trace(tmp_path / "v99.npz")


def test_check_catches_broken_traces():
    """check() rejects a trace with a missing SC visit, a reordered visit, or a wrong child count."""
    _, (_, tr) = traced("balls", w=12, h=12)
    tr.check()
    v = tr.visits
    sc = np.flatnonzero((v["stage"] == SC) & (v["outcome"] == SHADED))[0]
    broken = mprt.Trace(tr.meta, dict(tr._arrays, visits=np.delete(v, sc)))
    with pytest.raises(TraceError):
        broken.check()
    swapped = v.copy()
    i = np.flatnonzero(swapped["stage"] == IC)[0]
    swapped[[i - 1, i]] = swapped[[i, i - 1]]
    with pytest.raises(TraceError):
        mprt.Trace(tr.meta, dict(tr._arrays, visits=swapped)).check()
    made = v.copy()
    made["made"][sc] += 1
    with pytest.raises(TraceError, match="made"):
        mprt.Trace(tr.meta, dict(tr._arrays, visits=made)).check()


def test_subsets_trace_only_their_tiles_with_the_same_records():
    """A tile subset's records equal the same tiles' records in the full trace."""
    grid = mprt.Scene.spd("rings", 1).grid(8)
    _, full = grid.trace(32, 32, tile=8)
    _, part = grid.trace(32, 32, tile=8, sample="regular:3")
    assert part.meta["tiles"] == [0, 3, 6, 9, 12, 15]
    tile_of = lambda pix: (pix // 32 // 8) * 4 + (pix % 32) // 8  # noqa: E731
    keep = np.isin(tile_of(full.rays["pixel"]), part.meta["tiles"])
    assert np.array_equal(full.rays["pixel"][keep], part.rays["pixel"])
    fv = full.visits[np.isin(full.visits["ray"], np.flatnonzero(keep))]
    for f in ("stage", "outcome", "steps", "tests", "prim", "made", "suppressed"):
        assert np.array_equal(fv[f], part.visits[f]), f
    part.check()
    _, rnd = grid.trace(32, 32, tile=8, sample="random:5:42")
    assert len(rnd.meta["tiles"]) == 5
    with pytest.raises(mprt.InvalidArgument):
        grid.trace(32, 32, tile=8, sample="every:2")


def test_shadow_rays_die_at_ic_or_reach_sc():
    """Blocked shadow rays end at IC; the others reach SC through OS."""
    _, (_, tr) = traced("tree", w=16, h=16)
    v, r = tr.visits, tr.rays
    shadow = r["kind"][v["ray"]] == 3
    assert np.all(v["outcome"][shadow & (v["stage"] == IC)] != 3)
    assert np.sum(shadow & (v["outcome"] == BLOCKED)) > 0
    assert np.all(v["stage"][shadow & (v["stage"] != OS) & (v["stage"] != IC)] == SC)


@pytest.mark.parametrize("fname", sorted(f for f in os.listdir(GOLDEN) if f.endswith(".npz")) if os.path.isdir(GOLDEN) else [])
def test_golden_traces_regenerate_bit_identical(fname):
    """Each committed golden trace regenerates bit-identically (1 and 2 threads) with its recorded statistics."""
    gold = mprt.load_trace(os.path.join(GOLDEN, fname))
    m = gold.meta
    name, size = m["scene"].split(":")
    grid = mprt.Scene.spd(name, int(size)).grid(tuple(m["grid"]))
    for threads in (1, 2):
        _, t = grid.trace(m["width"], m["height"], rules=m["rules"], threshold=m["threshold"], tile=m["tile"],
                          threads=threads)
        for k in ("rays", "visits", "voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material"):
            assert np.array_equal(getattr(t, k), getattr(gold, k)), k
        assert np.array_equal(t.samples, gold.samples)
    with open(os.path.join(GOLDEN, fname.replace(".npz", ".stats.json"))) as f:
        assert gold.check() == json.load(f)


def test_golden_traces_exist():
    """The golden traces are committed: every SPD scene at two grids."""
    names = sorted(f for f in os.listdir(GOLDEN) if f.endswith(".npz"))
    assert len(names) == 12


def test_format_version_1_loads_with_renamed_fields(tmp_path):
    """A version-1 file (visit fields 'voxel' and 'voxels') loads with today's names and values."""
    import zipfile

    grid = mprt.Scene.spd("tetra", 1).grid(4)
    _, tr = grid.trace(16, 16, tile=8)
    v1 = np.dtype({"names": ["voxel" if n == "voxel_id" else "voxels" if n == "steps" else n
                             for n in tr.visits.dtype.names],
                   "formats": [tr.visits.dtype.fields[n][0] for n in tr.visits.dtype.names],
                   "offsets": [tr.visits.dtype.fields[n][1] for n in tr.visits.dtype.names],
                   "itemsize": tr.visits.dtype.itemsize})
    p = tmp_path / "v2.npz"
    tr.save(p)
    old = tmp_path / "v1.npz"
    with zipfile.ZipFile(p) as src, zipfile.ZipFile(old, "w") as dst:
        for name in src.namelist():
            data = src.read(name)
            if name == "meta.json":
                meta = json.loads(data)
                meta["version"] = 1
                data = json.dumps(meta).encode()
            elif name == "visits.npy":
                buf = io.BytesIO()
                np.lib.format.write_array(buf, tr.visits.view(v1))
                data = buf.getvalue()
            dst.writestr(name, data)
    back = mprt.load_trace(old)
    assert back.meta["version"] == mprt.trace.FORMAT_VERSION
    assert np.array_equal(back.visits["steps"], tr.visits["steps"])
    assert np.array_equal(back.visits["voxel_id"], tr.visits["voxel_id"])
    meta["version"] = 99
    with zipfile.ZipFile(p) as src, zipfile.ZipFile(tmp_path / "v99.npz", "w") as dst:
        for name in src.namelist():
            dst.writestr(name, json.dumps(meta) if name == "meta.json" else src.read(name))
    with pytest.raises(mprt.TraceError, match="regenerate"):
        mprt.load_trace(tmp_path / "v99.npz")
