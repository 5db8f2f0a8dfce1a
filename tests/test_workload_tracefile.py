"""Trace files of format version 3: voxel lists of the non-empty voxels only (no table over every
voxel of the grid), records deflated unless large, old versions still read."""
import io
import json
import os
import zipfile

import numpy as np
import pytest

import mprt
from mprt import tracefile
from mprt.tracefile import ARRAYS

GOLDEN_V2 = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "golden", "tetra-g9.npz")


def csr(counts) -> np.ndarray:
    """CSR list starts (uint32) of the given list lengths."""
    return np.concatenate([[0], np.cumsum(counts)]).astype(np.uint32)


@pytest.mark.parametrize("counts", [
    [0, 0, 0, 0],                       # every voxel empty
    [3, 0, 0, 1],                       # the first and the last voxel listed
    [0, 2, 0, 0, 5, 0],
    [300, 0, 1],                        # a list longer than uint8 holds
    [0] * 1000 + [70000] + [0] * 7,     # longer than uint16 holds, after a long gap
], ids=["empty", "ends", "middle", "uint16", "uint32"])
def test_voxel_lists_compact_and_expand_exactly(counts):
    """The non-empty voxels' gaps and list lengths give back the list starts of every voxel, in
    the narrowest type that holds the lengths."""
    start = csr(counts)
    packed = tracefile.compact_voxels(start)
    assert len(packed["voxel_gaps"]) == sum(c > 0 for c in counts)
    assert packed["voxel_count"].dtype == tracefile.narrowest_uint(np.array(counts))
    assert np.array_equal(tracefile.expand_voxels(packed["voxel_gaps"], packed["voxel_count"], len(counts)), start)


def members(path) -> dict:
    with zipfile.ZipFile(path) as z:
        return {i.filename: (z.read(i.filename), i.compress_type) for i in z.infolist()}


@pytest.fixture(scope="module")
def fine_grid_trace():
    """A small trace over a large, sparse grid: tetra at size 2 (64 triangles) in 96^3 voxels."""
    grid = mprt.Scene.spd("tetra", 2).grid(96)
    return grid, grid.trace(16, 16)[1]


def test_a_trace_file_holds_no_table_over_every_voxel(tmp_path, fine_grid_trace):
    """With the records stored as they are, the file is the records plus a few bytes per listed
    primitive and per non-empty voxel: far below the 3.5 MB a start per voxel took."""
    grid, tr = fine_grid_trace
    st = grid.stats()
    tr.save(tmp_path / "t.npz", compress=False)
    records = tr.rays.nbytes + tr.visits.nbytes
    bound = records + 5 * (st["refs"] + st["nonempty"]) + tr.samples.nbytes + (64 << 10)
    assert 4 * (st["voxels"] + 1) > bound - records            # the old table alone would not fit
    assert os.path.getsize(tmp_path / "t.npz") < bound
    back = mprt.load_trace(tmp_path / "t.npz")
    for k in ARRAYS:
        assert np.array_equal(getattr(back, k), getattr(tr, k), equal_nan=k == "samples"), k


def test_small_records_are_deflated_and_large_ones_stored(tmp_path, fine_grid_trace, monkeypatch):
    """By default records under AUTO_COMPRESS_BYTES are deflated; over it (or with compress=False)
    they are stored and load memory-mapped; the grid's members are always deflated."""
    _, tr = fine_grid_trace
    tr.save(tmp_path / "small.npz")
    m = members(tmp_path / "small.npz")
    assert all(m[k + ".npy"][1] == zipfile.ZIP_DEFLATED for k in tracefile.MEMBERS)
    monkeypatch.setattr(tracefile, "AUTO_COMPRESS_BYTES", 1000)
    tr.save(tmp_path / "large.npz")
    m = members(tmp_path / "large.npz")
    assert m["visits.npy"][1] == m["rays.npy"][1] == zipfile.ZIP_STORED
    assert m["voxel_gaps.npy"][1] == zipfile.ZIP_DEFLATED
    assert isinstance(mprt.load_trace(tmp_path / "large.npz", mmap=True).visits, np.memmap)


def test_a_version_2_file_loads_and_saves_as_version_3(tmp_path):
    """A committed version 2 trace (a start per voxel) loads, and saved again as version 3 loads
    back to the same arrays."""
    old = mprt.load_trace(GOLDEN_V2)
    assert json.loads(members(GOLDEN_V2)["meta.json"][0])["version"] == 2
    old.save(tmp_path / "v3.npz")
    assert "voxel_start.npy" not in members(tmp_path / "v3.npz")
    new = mprt.load_trace(tmp_path / "v3.npz")
    assert new.meta["version"] == tracefile.FORMAT_VERSION
    for k in ARRAYS:
        assert np.array_equal(getattr(new, k), getattr(old, k)), k


def rewrite(path, out, name, array):
    """Copy a trace file with member name replaced by array, its checksum updated."""
    m = members(path)
    meta = json.loads(m["meta.json"][0])
    meta["crc32"][name] = tracefile.typed_crc(array)
    buf = io.BytesIO()
    np.lib.format.write_array(buf, array)
    with zipfile.ZipFile(out, "w") as z:
        for n, (data, _) in m.items():
            z.writestr(n, json.dumps(meta) if n == "meta.json" else buf.getvalue() if n == name + ".npy" else data)


@pytest.mark.parametrize("name, change, words", [
    ("voxel_gaps", lambda a: np.append(a, np.uint32(5)), "do not fit a grid"),
    ("voxel_gaps", lambda a: a + np.uint32(10 ** 6), "do not fit a grid"),
    ("voxel_count", lambda a: a * 2, "voxel lists hold"),
], ids=["one gap too many", "beyond the grid", "lengths"])
def test_voxel_lists_that_do_not_fit_are_a_trace_error(tmp_path, fine_grid_trace, name, change, words):
    """Voxel lists that do not fit the grid or the primitive ids raise TraceError naming the file."""
    _, tr = fine_grid_trace
    tr.save(tmp_path / "good.npz")
    packed = tracefile.compact_voxels(tr.voxel_start)
    rewrite(tmp_path / "good.npz", tmp_path / "bad.npz", name, change(packed[name]))
    with pytest.raises(mprt.TraceError, match=f"bad.npz: .*{words}"):
        mprt.load_trace(tmp_path / "bad.npz")
