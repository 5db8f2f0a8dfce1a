"""Traces at the cost of renders: records written once, in place, into arrays reused across traces,
and trace files written while tracing; every record the same bits whatever the buffers' sizes."""
import functools
import io
import os
import zlib

import numpy as np
import pytest

import mprt
from mprt import tracefile, tracing
from mprt.trace import RAY_DTYPE, VISIT_DTYPE


@functools.cache
def grid():
    return mprt.Scene.spd("rings", 1).grid(5)


@functools.cache
def reference():
    """The trace made tile by tile through Grid.trace_tile, renumbered by hand."""
    g = grid()
    desc = g.resolve(mprt.grid.render_desc(24, 20, tile=4))
    sw, sh, tx, ty = g.tiling(desc)
    rays, visits, samples = [], [], np.zeros((sh, sw, 3))
    buf_r, buf_v = np.empty(1 << 14, dtype=RAY_DTYPE), np.empty(1 << 17, dtype=VISIT_DTYPE)
    first = 0
    for t in range(tx * ty):
        x0, y0, x1, y1 = g.tile_rect(desc, t)
        smp = np.empty((y1 - y0) * (x1 - x0) * 3)
        nr, nv, fitted = g.trace_tile(desc, t, smp, buf_r, buf_v)
        assert fitted
        r, v = buf_r[:nr].copy(), buf_v[:nv].copy()
        r["id"] += first
        r["parent"][r["parent"] >= 0] += first
        v["ray"] += first
        rays.append(r)
        visits.append(v)
        samples[y0:y1, x0:x1] = smp.reshape(y1 - y0, x1 - x0, 3)
        first += nr
    return np.concatenate(rays), np.concatenate(visits), samples


def assert_reference(tr):
    rays, visits, samples = reference()
    assert np.array_equal(tr.rays, rays) and np.array_equal(tr.visits, visits)
    assert np.array_equal(tr.samples, samples)


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_a_trace_is_its_tiles_traced_one_by_one(threads):
    """Records written in place, numbered as one trace, equal the tiles' records renumbered."""
    assert_reference(grid().trace(24, 20, tile=4, threads=threads)[1])


@pytest.mark.parametrize("threads", [1, 2])
def test_small_buffers_give_the_same_records(monkeypatch, tmp_path, threads):
    """Arrays that must grow many times, chunks written many times and groups that outgrow their
    buffers: the same records, in memory and on disk."""
    monkeypatch.setattr(tracing, "RESERVE_RAYS", 1)
    monkeypatch.setattr(tracing, "RESERVE_VISITS", 1)
    monkeypatch.setattr(tracing, "CHUNK_RAYS", 64)
    monkeypatch.setattr(tracing, "CHUNK_VISITS", 512)
    monkeypatch.setattr(tracing, "TILES_PER_CALL", 3)
    monkeypatch.setattr(tracing, "_POOL", [])
    monkeypatch.setattr(tracing, "_GROUP_BUFFERS", [])
    monkeypatch.setattr(tracing, "_take_buffer_sets",
                        lambda n, samples: [{"rays": np.empty(8, dtype=RAY_DTYPE),
                                             "visits": np.empty(16, dtype=VISIT_DTYPE)} for _ in range(n)])
    assert_reference(grid().trace(24, 20, tile=4, threads=threads)[1])
    _, disk = grid().trace(24, 20, tile=4, threads=threads, path=tmp_path / "t.npz")
    assert_reference(disk)
    assert mprt.load_trace(tmp_path / "t.npz", verify=True).stats() == disk.stats()   # checksums hold


def test_record_arrays_are_reused_once_no_trace_holds_them():
    """A second trace writes into the first one's arrays once that trace is gone, never while
    it is alive (its records stay as they were)."""
    tracing.release_buffers()                        # arrays left by earlier tests would be taken first
    g = mprt.Scene.spd("balls", 1).grid(4)
    _, a = g.trace(16, 16)
    where = a.visits.__array_interface__["data"][0]
    kept = a.visits.copy()
    _, b = g.trace(16, 16, rules="spd")            # a is alive: other arrays
    assert b.visits.__array_interface__["data"][0] != where
    assert np.array_equal(a.visits, kept)
    del a
    _, c = g.trace(16, 16)                          # a is gone: its arrays again
    assert c.visits.__array_interface__["data"][0] == where
    assert np.array_equal(c.visits, kept)
    tracing.release_buffers()
    assert tracing._POOL == []


def pixels(g, desc, tile):
    sw = g.tiling(desc)[0]
    x0, y0, x1, y1 = g.tile_rect(desc, tile)
    return [y * sw + x for y in range(y0, y1) for x in range(x0, x1)]


def test_grid_trace_tiles_stops_before_what_does_not_fit():
    """Grid.trace_tiles: (tiles traced, rays, visits); (0, sizes needed) when the first does not fit."""
    g = grid()
    desc = g.resolve(mprt.grid.render_desc(24, 20, tile=4))
    sw, sh, tx, ty = g.tiling(desc)
    samples = np.empty((sh, sw, 3))
    tiles = np.arange(tx * ty, dtype=np.intc)
    rays, visits, _ = reference()
    r, v = np.empty(2 * len(rays), dtype=RAY_DTYPE), np.empty(2 * len(visits), dtype=VISIT_DTYPE)
    assert g.trace_tiles(desc, tiles, samples, 0, r, v) == (len(tiles), len(rays), len(visits))
    assert np.array_equal(r[:len(rays)], rays) and np.array_equal(v[:len(visits)], visits)
    # exactly the trace's size: it may stop before a last tile as large as the largest so far
    n, nr, nv = g.trace_tiles(desc, tiles, samples, 0, r[:len(rays)], v[:len(visits)])
    assert 0 < n <= len(tiles) and np.array_equal(r[:nr], rays[:nr]) and np.array_equal(v[:nv], visits[:nv])
    assert nr == np.count_nonzero(np.isin(rays["pixel"], [p for t in range(n) for p in pixels(g, desc, t)]))
    n, nr, nv = g.trace_tiles(desc, tiles, samples, 0, r[:1], v[:1])
    assert n == 0 and nr == np.count_nonzero(np.isin(rays["pixel"], pixels(g, desc, 0))) and nv > 1
    with pytest.raises(mprt.InvalidArgument, match="tiles"):
        g.trace_tiles(desc, np.array([tx * ty], dtype=np.intc), samples, 0, r, v)


def test_a_failed_trace_leaves_the_file_as_it_was(tmp_path):
    """A trace to disk that fails (a sample over its ray budget) leaves an existing file untouched
    and nothing beside it."""
    path = tmp_path / "t.npz"
    path.write_bytes(b"before")
    with pytest.raises(mprt.WorkLimitError):
        grid().trace(24, 20, tile=4, path=path, max_rays=2)
    assert path.read_bytes() == b"before"
    assert os.listdir(tmp_path) == ["t.npz"]


def test_crc32_combine_is_zlibs():
    rng = np.random.default_rng(1)
    for n1, n2 in ((0, 5), (7, 0), (100, 1), (3, 1 << 16), (1000, 123457)):
        a, b = rng.bytes(n1), rng.bytes(n2)
        assert tracefile.crc32_combine(zlib.crc32(a), zlib.crc32(b), len(b)) == zlib.crc32(a + b)


@pytest.mark.parametrize("dtype", [RAY_DTYPE, VISIT_DTYPE])
def test_a_streamed_header_has_one_length_for_every_count(dtype):
    """The .npy header written before the count is known has the length of any count's, and numpy
    reads it."""
    lengths = set()
    for count in (0, 1, 12345, 10 ** 19):
        h = tracefile.npy_header(dtype, count)
        lengths.add(len(h))
        f = io.BytesIO(h)
        assert np.lib.format.read_magic(f) == (2, 0)
        assert np.lib.format.read_array_header_2_0(f) == ((count,), False, dtype)
    assert len(lengths) == 1 and lengths.pop() % 64 == 0


def test_traces_on_several_python_threads_at_once_keep_their_own_buffers(tmp_path):
    """Traces made at once from several Python threads (on 1 and 2 library threads, in memory and
    to disk) each get buffers of their own: every one equals the reference."""
    from concurrent.futures import ThreadPoolExecutor

    def one(k):
        path = tmp_path / f"t{k}.npz" if k % 2 else None
        return grid().trace(24, 20, tile=4, threads=1 + k % 3 // 2, path=path)[1]

    with ThreadPoolExecutor(max_workers=4) as pool:
        for tr in pool.map(one, range(8)):
            assert_reference(tr)
