"""Trace files written past the page cache (mprt.tracewriter): the same bytes whether the records go
by direct I/O or through the page cache, whatever the buffers' sizes; checksums taken while
copying equal zlib's; a failed write leaves nothing behind."""
import errno
import functools
import io
import os
import zipfile
import zlib

import numpy as np
import pytest

import mprt
from mprt import tracefile, tracewriter
from mprt._lowlevel import RAY_DTYPE, VISIT_DTYPE, binding


@functools.cache
def grid():
    return mprt.Scene.spd("rings", 1).grid(5)


def member_bytes(path) -> dict:
    """Every member's stored bytes, and the file's bytes before meta.json (whose header holds the
    time it was written)."""
    with zipfile.ZipFile(path) as z:
        out = {i.filename: z.read(i) for i in z.infolist()}
        meta_at = z.getinfo("meta.json").header_offset
    with open(path, "rb") as f:
        out["<before meta.json>"] = f.read(meta_at)
    return out


@pytest.mark.parametrize("n", [0, 1, 15, 16, 63, 64, 65, 1000, 4096 * 3 + 17, 1 << 20])
def test_crc32_copy_is_zlibs_crc_and_copies(n):
    rng = np.random.default_rng(n)
    data = rng.bytes(n + 7)
    for lo in (0, 3, 7):
        src = memoryview(data)[lo:lo + n]
        dst = bytearray(n + 9)
        assert binding().crc32_copy(src, 0, memoryview(dst)[5:]) == zlib.crc32(src)
        assert bytes(dst[5:5 + n]) == bytes(src) and dst[:5] == bytes(5) and dst[5 + n:] == bytes(4)
        assert binding("single").crc32_copy(src, 12345) == zlib.crc32(src, 12345)


def test_crc32_copy_refuses_a_short_destination():
    with pytest.raises(mprt.InvalidArgument, match="dst holds 3 bytes, src 4"):
        binding().crc32_copy(b"abcd", 0, bytearray(3))


def test_crc32_combine_is_zlibs():
    rng = np.random.default_rng(1)
    for n1, n2 in ((0, 5), (7, 0), (100, 1), (3, 1 << 16), (1000, 123457)):
        a, b = rng.bytes(n1), rng.bytes(n2)
        assert tracewriter.crc32_combine(zlib.crc32(a), zlib.crc32(b), len(b)) == zlib.crc32(a + b)
    for c1, c2, n in ((123, 456, 10 ** 12), (0xFFFFFFFF, 1, 2 ** 40 + 3)):
        assert tracewriter.crc32_combine(c1, c2, n) == tracefile.crc32_combine(c1, c2, n)


def _refuse_direct(monkeypatch, direct_fds):
    """Direct writes refused (EINVAL) on the given descriptors, as a file system without them."""
    real = tracewriter._pwrite_all

    def pwrite_all(fd, data, offset):
        if fd in direct_fds:
            raise OSError(errno.EINVAL, "Invalid argument")
        real(fd, data, offset)
    monkeypatch.setattr(tracewriter, "_pwrite_all", pwrite_all)


@pytest.mark.parametrize("start", [0, 1, 188, 4095, 4096, 5000])
@pytest.mark.parametrize("how", ["direct", "page cache", "refused"])
def test_appender_writes_what_it_is_given_after_what_was_there(tmp_path, monkeypatch, start, how):
    """Pieces of every size appended from any offset: the file holds the bytes before start
    unchanged, then the pieces, nothing more; the CRC is theirs."""
    def fill(a, rng) -> bytes:
        pieces = [rng.bytes(int(k)) for k in rng.integers(0, 9000, size=12)] + [b"", rng.bytes(1)]
        for p in pieces:
            a.write(p)
        return b"".join(pieces)
    _check_appended(tmp_path / "a.bin", start, how, monkeypatch, 3, fill)


def _check_appended(path, start: int, how: str, monkeypatch, blocks: int, fill) -> None:
    """An appender of a buffer of ``blocks`` blocks from ``start`` of a file of random bytes,
    written (``how``: direct, page cache, or direct refused) with what ``fill(appender, rng)``
    appends, which it returns: the file holds the bytes before start, then those, nothing more;
    the appender's CRC and size are theirs."""
    rng = np.random.default_rng(start)
    head = rng.bytes(start)
    path.write_bytes(head)
    plain = os.open(path, os.O_RDWR)
    direct = tracewriter.direct_fd(path) if how != "page cache" else None
    if how == "refused":
        _refuse_direct(monkeypatch, {direct})
    try:
        a = tracewriter.Appender(plain, direct, start, tracewriter.aligned_buffer(blocks * tracewriter.ALIGN))
        body = fill(a, rng)
        assert a.close() == start + len(body)
        assert a.crc == zlib.crc32(body) and a.size == len(body)
    finally:
        os.close(plain)
        if direct is not None:
            os.close(direct)
    assert path.read_bytes() == head + body


def _random_records(rng, n: int):
    """n random rays (a third of them primary: parent -1) and 3n random visits, as raw bytes."""
    rays = np.frombuffer(rng.bytes(n * RAY_DTYPE.itemsize), RAY_DTYPE).copy()
    rays["id"] = rng.integers(0, 1 << 40, n)
    rays["parent"] = np.where(rng.random(n) < 1 / 3, -1, rng.integers(0, 1 << 40, n))
    visits = np.frombuffer(rng.bytes(3 * n * VISIT_DTYPE.itemsize), VISIT_DTYPE).copy()
    visits["ray"] = rng.integers(0, 1 << 40, 3 * n)
    return rays, visits


def _shifted(a: np.ndarray, offset: int) -> np.ndarray:
    """Records renumbered the plain way: ids, parents that are not negative, visits' rays."""
    out = a.copy()
    if a.dtype == VISIT_DTYPE:
        out["ray"] += offset
    else:
        out["id"] += offset
        out["parent"] = np.where(out["parent"] >= 0, out["parent"] + offset, out["parent"])
    return out


@pytest.mark.parametrize("n", [0, 1, 255, 256, 257, 1000])
@pytest.mark.parametrize("at", [0, 3, 8])
def test_records_shift_renumbers_copies_and_checksums(n, at):
    """Records copied to any byte offset with their ray numbers moved on: the plain renumbering's
    bytes, nothing else touched, negative parents kept; the CRC is zlib's of the bytes written."""
    rng = np.random.default_rng(n + at)
    lib = binding()
    for a in _random_records(rng, n):
        offset = int(rng.integers(1, 1 << 30))
        want = tracefile.as_bytes(_shifted(a, offset)).tobytes()
        dst = bytearray(rng.bytes(at + len(want) + 5))
        guard = bytes(dst)
        assert lib.records_shift(a, memoryview(dst)[at:], offset, 7) == zlib.crc32(want, 7)
        assert bytes(dst) == guard[:at] + want + guard[at + len(want):]
        assert lib.records_shift(a, memoryview(dst)[at:], 0) is None     # offset 0: a plain copy
        assert bytes(dst[at:at + len(want)]) == tracefile.as_bytes(a).tobytes()
    with pytest.raises(mprt.InvalidArgument, match="dst holds"):
        lib.records_shift(_random_records(rng, 4)[0], bytearray(10), 1)
    with pytest.raises(mprt.InvalidArgument, match="trace records"):
        lib.records_shift(np.zeros(4), bytearray(64), 1)


@pytest.mark.parametrize("start", [0, 188, 4095])
@pytest.mark.parametrize("how", ["direct", "page cache", "refused"])
def test_appender_writes_records_renumbered(tmp_path, monkeypatch, start, how):
    """Records appended renumbered, in pieces of every size, after plain bytes and between them,
    through a buffer that is not a whole number of records: the file holds exactly the bytes
    before start, then each piece as given or renumbered; the CRC is theirs."""
    def fill(a, rng) -> bytes:
        body = []
        for k in rng.integers(0, 400, size=10):
            rays, visits = _random_records(rng, int(k))
            offset = int(rng.integers(1, 1 << 30))
            a.write_records(visits, offset)
            a.write(b"x" * int(k % 7))
            a.write_records(rays, offset)
            body += [tracefile.as_bytes(_shifted(visits, offset)).tobytes(), b"x" * int(k % 7),
                     tracefile.as_bytes(_shifted(rays, offset)).tobytes()]
        return b"".join(body)
    _check_appended(tmp_path / "a.bin", start, how, monkeypatch, 2, fill)


def test_trace_file_is_the_same_bytes_by_any_write_path(tmp_path, monkeypatch):
    """Direct writes, the page cache alone, direct writes refused mid-way, and buffers of one or
    two blocks: the same file (every member, every byte before meta.json), which loads with its
    checksums."""
    _, ref = grid().trace(24, 20, tile=4, path=tmp_path / "ref.npz")
    want = member_bytes(tmp_path / "ref.npz")
    with monkeypatch.context() as m:
        m.setattr(tracewriter, "_O_DIRECT", 0)
        grid().trace(24, 20, tile=4, path=tmp_path / "plain.npz")
    with monkeypatch.context() as m:
        m.setattr(tracewriter, "BUFFER_BYTES", tracewriter.ALIGN)
        grid().trace(24, 20, tile=4, path=tmp_path / "small.npz", threads=2)
    with monkeypatch.context() as m:
        opened = set()
        real = tracewriter.direct_fd

        def direct_fd(path):
            fd = real(path)
            opened.add(fd)
            return fd
        m.setattr(tracewriter, "direct_fd", direct_fd)
        _refuse_direct(m, opened)
        grid().trace(24, 20, tile=4, path=tmp_path / "refused.npz")
    for name in ("plain", "small", "refused"):
        assert member_bytes(tmp_path / f"{name}.npz") == want, name
        assert mprt.load_trace(tmp_path / f"{name}.npz", verify=True).stats() == ref.stats()


def test_streamed_trace_is_the_file_as_a_reader_loads_it(tmp_path):
    """The trace handed back by a trace to disk (mapped from the file as written, not read back)
    has the metadata, arrays and dtypes a reader of the file gets; its records are mapped."""
    _, streamed = grid().trace(24, 20, tile=4, path=tmp_path / "t.npz", sample="random:5:2")
    loaded = mprt.load_trace(tmp_path / "t.npz", mmap=True)
    assert streamed.meta == loaded.meta and streamed.path == loaded.path
    for k in tracefile.ARRAYS:
        a, b = getattr(streamed, k), getattr(loaded, k)
        assert a.dtype == b.dtype and a.shape == b.shape, k
        assert np.array_equal(a, b, equal_nan=k == "samples"), k
    assert isinstance(streamed.visits, np.memmap) and isinstance(streamed.rays, np.memmap)
    assert streamed.stats() == loaded.stats()


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("after", [0, 3])
def test_a_failed_write_raises_and_leaves_nothing(tmp_path, monkeypatch, threads, after):
    """A write that fails (the disk full), at once or after a few writes, is the trace's error on
    one thread or several (where the writer takes the records from the threads' buffers); the
    path is left as it was, no scratch file stays beside it, and the next trace is whole."""
    path = tmp_path / "t.npz"
    path.write_bytes(b"before")
    real, calls = tracewriter._pwrite_all, []

    def full(fd, data, offset):
        calls.append(offset)
        if len(calls) > after:
            raise OSError(errno.ENOSPC, "No space left on device")
        real(fd, data, offset)
    with monkeypatch.context() as m:
        m.setattr(tracewriter, "_pwrite_all", full)
        m.setattr(tracewriter, "BUFFER_BYTES", tracewriter.ALIGN)
        with pytest.raises(OSError, match="No space left"):
            grid().trace(24, 20, tile=4, path=path, threads=threads)
    assert path.read_bytes() == b"before"
    assert os.listdir(tmp_path) == ["t.npz"]
    _, ref = grid().trace(24, 20, tile=4)
    _, again = grid().trace(24, 20, tile=4, path=tmp_path / "u.npz", threads=threads)
    assert mprt.load_trace(tmp_path / "u.npz", verify=True).stats() == ref.stats()
    assert tracefile.as_bytes(np.asarray(again.visits)).tobytes() == tracefile.as_bytes(ref.visits).tobytes()


def test_streamed_members_equal_those_the_whole_trace_writer_makes(tmp_path):
    """Every member of a streamed file but the records (the grid's members made ahead, the
    samples, meta.json) holds the bytes tracefile.write makes of the same trace; the records the
    same records (their .npy header is written before the count is known: another form)."""
    _, streamed = grid().trace(24, 20, tile=4, path=tmp_path / "s.npz")
    _, mem = grid().trace(24, 20, tile=4)
    mem.save(tmp_path / "w.npz", compress=False)
    a, b = member_bytes(tmp_path / "s.npz"), member_bytes(tmp_path / "w.npz")
    del a["<before meta.json>"], b["<before meta.json>"]
    for k in ("rays.npy", "visits.npy"):
        x, y = np.load(io.BytesIO(a.pop(k))), np.load(io.BytesIO(b.pop(k)))
        assert x.dtype == y.dtype and x.tobytes() == y.tobytes(), k
    assert a == b
