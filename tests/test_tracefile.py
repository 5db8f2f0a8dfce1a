"""Trace files: round trips, streaming, damaged files, old versions, golden traces."""
import functools
import io
import json
import os
import zipfile

import numpy as np
import pytest

import mprt
from mprt.tracefile import ARRAYS, FORMAT_VERSION

GOLDEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "golden")
GOLDEN_FILES = sorted(f for f in os.listdir(GOLDEN) if f.endswith(".npz"))
RECORDS = [k for k in ARRAYS if k != "samples"]


@functools.cache
def balls_grid():
    return mprt.Scene.spd("balls", 1).grid(6)


@functools.cache
def in_memory():
    return balls_grid().trace(20, 20, tile=4)[1]


def test_saved_trace_loads_back_equal(tmp_path):
    """Every array of a saved trace loads back equal, with the grid and format version in meta."""
    mem = in_memory()
    mem.save(tmp_path / "t.npz")
    back = mprt.load_trace(tmp_path / "t.npz")
    for k in ARRAYS:
        assert np.array_equal(getattr(back, k), getattr(mem, k), equal_nan=k == "samples"), k
    assert back.meta["grid"] == [6, 6, 6] and back.meta["version"] == FORMAT_VERSION


def test_trace_streamed_to_disk_equals_the_one_built_in_memory(tmp_path):
    """A trace streamed to disk is memory-mapped and holds the in-memory trace's records."""
    _, disk = balls_grid().trace(20, 20, tile=4, path=tmp_path / "s.npz")
    assert isinstance(disk.visits, np.memmap)
    assert np.array_equal(disk.rays, in_memory().rays) and np.array_equal(disk.visits, in_memory().visits)


def test_memory_mapped_trace_has_the_same_statistics(tmp_path):
    """Loading with mmap=True gives the statistics of the in-memory trace."""
    in_memory().save(tmp_path / "t.npz")
    assert mprt.load_trace(tmp_path / "t.npz", mmap=True).stats() == in_memory().stats()


@pytest.fixture(scope="module")
def tetra_file(tmp_path_factory):
    """A small saved trace's file bytes and its zip members."""
    _, tr = mprt.Scene.spd("tetra", 2).grid(8).trace(12, 12)
    good = tmp_path_factory.mktemp("tetra") / "good.npz"
    tr.save(good)
    with zipfile.ZipFile(good) as z:
        return good.read_bytes(), {n: z.read(n) for n in z.namelist()}


def write_members(path, members):
    with zipfile.ZipFile(path, "w") as z:
        for n, b in members.items():
            z.writestr(n, b)


def test_truncated_trace_file_is_a_trace_error_naming_it(tmp_path, tetra_file):
    """A trace file cut in half raises TraceError naming the file."""
    data, _ = tetra_file
    (tmp_path / "trunc.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(mprt.TraceError, match="trunc.npz"):
        mprt.load_trace(tmp_path / "trunc.npz")


def test_tampered_trace_file_fails_its_checksum(tmp_path, tetra_file):
    """One changed byte inside the visits array raises TraceError about the checksum."""
    _, members = tetra_file
    v = bytearray(members["visits.npy"])
    v[-5] ^= 0xFF
    write_members(tmp_path / "tamper.npz", dict(members, **{"visits.npy": bytes(v)}))
    with pytest.raises(mprt.TraceError, match="checksum"):
        mprt.load_trace(tmp_path / "tamper.npz")


def test_unknown_format_version_says_how_to_regenerate(tmp_path, tetra_file):
    """A file of format version 99 raises TraceError naming the version and how to regenerate the trace."""
    _, members = tetra_file
    meta = json.loads(members["meta.json"])
    meta["version"] = 99
    write_members(tmp_path / "v99.npz", dict(members, **{"meta.json": json.dumps(meta).encode()}))
    with pytest.raises(mprt.TraceError, match="version 99.*regenerate"):
        mprt.load_trace(tmp_path / "v99.npz")


def test_format_version_1_loads_with_renamed_fields(tmp_path):
    """A version-1 file (visit fields 'voxel' and 'voxels') loads with today's names and values."""
    with zipfile.ZipFile(os.path.join(GOLDEN, "tetra-g9.npz")) as z:   # a version 2 file: v1's layout
        members = {n: z.read(n) for n in z.namelist()}
    visits = np.lib.format.read_array(io.BytesIO(members["visits.npy"]))
    names = visits.dtype.names
    v1 = np.dtype({"names": [{"voxel_id": "voxel", "steps": "voxels"}.get(n, n) for n in names],
                   "formats": [visits.dtype.fields[n][0] for n in names],
                   "offsets": [visits.dtype.fields[n][1] for n in names],
                   "itemsize": visits.dtype.itemsize})
    buf = io.BytesIO()
    np.lib.format.write_array(buf, visits.view(v1))
    meta = json.loads(members["meta.json"])
    meta["version"] = 1
    write_members(tmp_path / "v1.npz", dict(members, **{"meta.json": json.dumps(meta).encode(),
                                                        "visits.npy": buf.getvalue()}))
    back = mprt.load_trace(tmp_path / "v1.npz")
    assert back.meta["version"] == FORMAT_VERSION
    assert np.array_equal(back.visits["steps"], visits["steps"])
    assert np.array_equal(back.visits["voxel_id"], visits["voxel_id"])


def test_golden_traces_exist():
    """The golden traces are committed: every SPD scene at two grids."""
    assert len(GOLDEN_FILES) == 2 * len(mprt.SPD_SCENES)


@functools.cache
def golden(fname):
    return mprt.load_trace(os.path.join(GOLDEN, fname))


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("fname", GOLDEN_FILES)
def test_golden_trace_regenerates_bit_identical(fname, threads):
    """Each committed golden trace regenerates bit-identically on 1 and 2 threads."""
    gold = golden(fname)
    m = gold.meta
    name, size = m["scene"].split(":")
    grid = mprt.Scene.spd(name, int(size)).grid(tuple(m["grid"]))
    _, t = grid.trace(m["width"], m["height"], rules=m["rules"], threshold=m["threshold"], tile=m["tile"],
                      threads=threads)
    for k in ARRAYS:
        assert np.array_equal(getattr(t, k), getattr(gold, k)), k


@pytest.mark.parametrize("fname", GOLDEN_FILES)
def test_golden_trace_has_its_recorded_statistics(fname):
    """Each golden trace keeps its invariants and the statistics recorded beside it (a pinned regression)."""
    with open(os.path.join(GOLDEN, fname.replace(".npz", ".stats.json"))) as f:
        assert golden(fname).check() == json.load(f)


def test_crc_in_parts_by_threads_is_zlibs_crc(monkeypatch):
    import zlib

    from mprt import tracefile as tf

    rng = np.random.default_rng(5)
    for n in (1, 9, 4096, 100_003):
        a = rng.integers(0, 256, n, dtype=np.uint8)
        b = rng.integers(0, 256, n // 3 + 1, dtype=np.uint8)
        assert tf.crc32_combine(zlib.crc32(a), zlib.crc32(b), b.size) == zlib.crc32(np.concatenate([a, b]))
    monkeypatch.setattr(tf, "CRC_PART", 1 << 12)     # parts of 4 KiB: several threads on a small array
    x = rng.integers(0, 256, 300_007, dtype=np.uint8)
    for threads in (1, 2, 3, 4, 7):
        assert tf.crc(x, chunk=5000, threads=threads) == zlib.crc32(x)
