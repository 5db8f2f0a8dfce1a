"""A trace file written while the trace is made (``TraceWriter``), in bounded memory: a file of
``tracefile``'s format, ``visits.npy`` first (its .npy header of fixed width, the count put in
place at the end), then ``rays.npy``, the grid's members, the samples and ``meta.json``, each
member the bytes ``tracefile.write`` makes of it but for the records' header.

The records go to the disk past the page cache where the file system allows it (``O_DIRECT``):
copying 0.1-0.7 GB of records into the kernel's page cache was most of what a trace to disk cost
over a render (on a virtual machine every fresh page-cache page is a host fault first: 0.13-1.8 s
of system time for 618 MB, where the direct writes take 0.02 s of CPU).  Whole, aligned blocks go
from one reused buffer straight to the device; the partial blocks at the two ends of a member,
and everything small (zip headers, the grid tables, ``meta.json``), through the page cache.
Where direct writes are refused (tmpfs, some network file systems, no ``O_DIRECT``) the same
blocks are written through the page cache: the same bytes either way.

Nothing appears under the file's name until it is whole: it is written to a temporary beside
it (``atomic.temporary``'s name, the file mode that of ``open``: 0o666 less the umask) and
renamed at the end; an error or Ctrl-C removes the temporaries, and those SIGKILL leaves are
removed by the next write of the same name.  The rays' scratch file has no name at all where
the file system allows (``O_TMPFILE``).
"""
from __future__ import annotations

import errno
import io
import json
import mmap
import os
import zipfile
import zlib
from collections import deque
from concurrent import futures
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import tracefile
from .._lowlevel import RAY_DTYPE, VISIT_DTYPE, binding
from ..util.atomic import temporary
from .tracefile import (FORMAT, FORMAT_VERSION, MEMBERS, RECORDS, _stored, _write_array, as_bytes, file_members,
                        npy_header, signature)

ALIGN = 4096                    # direct writes: offsets, lengths and addresses in whole blocks of this
BUFFER_BYTES = 4 << 20          # the visits' reused, aligned buffer: one direct write (one request); the
                                # rays' (scratch file) a quarter of it
_O_DIRECT = getattr(os, "O_DIRECT", 0)
_CRC = binding()                # the library's CRC-32 (zlib's value, several times its speed)


_POLY = 0xEDB88320              # CRC-32's polynomial, bit-reflected


def _times(a: int, b: int) -> int:
    """a * b modulo the polynomial (bit-reflected: bit 31 is x^0)."""
    m, p = 1 << 31, 0
    while a:
        if a & m:
            p ^= b
            a ^= m
        m >>= 1
        b = (b >> 1) ^ _POLY if b & 1 else b >> 1
    return p


_X2N = [1 << 30]                # [k]: x^(2^k) modulo the polynomial
for _ in range(31):
    _X2N.append(_times(_X2N[-1], _X2N[-1]))


def crc32_combine(crc1: int, crc2: int, len2: int) -> int:
    """The CRC-32 of A + B from crc1 of A, crc2 of B and len2 = len(B) (zlib's crc32_combine, as
    ``tracefile.crc32_combine``): crc1 times x^(8 len2), by squares made once (32 of them)."""
    if len2 <= 0:
        return crc1
    p, k = 1 << 31, 3
    while len2:
        if len2 & 1:
            p = _times(_X2N[k & 31], p)
        len2 >>= 1
        k += 1
    return _times(p, crc1) ^ crc2


def typed_crc(a: np.ndarray) -> int:
    """``tracefile.typed_crc`` of an array in memory (its signature, then its bytes)."""
    a = np.ascontiguousarray(a)
    return crc32_combine(zlib.crc32(signature(a.dtype, a.shape)), _CRC.crc32_copy(as_bytes(a)), a.nbytes)


def direct_fd(path) -> int | None:
    """A write descriptor on path that bypasses the page cache, or None where there is none."""
    if not _O_DIRECT:
        return None
    try:
        return os.open(path, os.O_RDWR | _O_DIRECT)
    except OSError:             # EINVAL: the file system has no direct I/O
        return None


def _pwrite_all(fd: int, data: memoryview, offset: int) -> None:
    while len(data):
        n = os.pwrite(fd, data, offset)
        data, offset = data[n:], offset + n


def aligned_buffer(nbytes: int) -> memoryview:
    """A writable buffer of nbytes rounded up to whole blocks, page-aligned (fit for direct I/O);
    unmapped once the last view of it is gone."""
    return memoryview(mmap.mmap(-1, max(ALIGN, nbytes + -nbytes % ALIGN)))


class Appender:
    """Bytes appended to a file from offset ``start`` (any offset), with their CRC-32: whole
    aligned blocks written from ``buf`` (an ``aligned_buffer`` of two blocks or more, reused)
    through ``direct`` (an ``O_DIRECT`` descriptor, or None), the partial block at each end
    through ``plain``.  The bytes of the first block before ``start`` are read back from the
    file (what was written there before) and written again unchanged."""

    def __init__(self, plain: int, direct: int | None, start: int, buf: memoryview):
        self.plain, self.direct, self.view = plain, direct, buf
        self.cap = len(buf)
        self.base = start - start % ALIGN               # the file offset of buf[0]
        self.n = start - self.base                      # bytes held in buf
        if self.n:
            head = os.pread(plain, self.n, self.base)
            self.view[:len(head)] = head
            self.view[len(head):self.n] = bytes(self.n - len(head))   # a hole: reads as zeros
        self.start, self.size, self.crc = start, 0, 0

    def write(self, data) -> None:
        """Append data (any contiguous bytes-like object)."""
        mv = memoryview(data).cast("B")
        self.size += len(mv)
        while len(mv):
            k = min(len(mv), self.cap - self.n)
            # copied into the buffer and checksummed in one pass, other threads running meanwhile
            self.crc = _CRC.crc32_copy(mv[:k], self.crc, self.view[self.n:self.n + k])
            self.n += k
            mv = mv[k:]
            if self.n == self.cap:
                self._blocks()

    def write_records(self, records: np.ndarray, offset: int) -> None:
        """Append trace records (a contiguous RAY_DTYPE or VISIT_DTYPE array) with their ray
        numbers moved on by offset (``Binding.records_shift``): copied, renumbered and
        checksummed in one pass."""
        size = records.dtype.itemsize
        self.size += records.nbytes
        i = 0
        while i < len(records):
            k = min(len(records) - i, (self.cap - self.n) // size)
            if k == 0:            # less than a record's room left: write the whole blocks first
                self._blocks()
                continue
            self.crc = _CRC.records_shift(records[i:i + k], self.view[self.n:self.n + k * size], offset, self.crc)
            self.n += k * size
            i += k
            if self.cap - self.n < size:
                self._blocks()

    def _blocks(self) -> None:
        """Write the whole blocks held; keep the partial one."""
        whole = self.n - self.n % ALIGN
        if not whole:
            return
        if self.direct is not None:
            try:
                _pwrite_all(self.direct, self.view[:whole], self.base)
            except OSError as e:     # refused after all: the page cache from here on
                if e.errno != errno.EINVAL:
                    raise
                self.direct = None
        if self.direct is None:
            _pwrite_all(self.plain, self.view[:whole], self.base)
        tail = self.n - whole
        self.view[:tail] = self.view[whole:self.n]
        self.base += whole
        self.n = tail

    def close(self) -> int:
        """Write what is held (the last partial block through the page cache); returns the end
        offset.  The buffer is free again."""
        self._blocks()
        if self.n:
            _pwrite_all(self.plain, self.view[:self.n], self.base)
            self.n = 0
        return self.start + self.size


def _read_blocks(fd: int, direct: int | None, size: int, bufs: list, pool: ThreadPoolExecutor):
    """The first size bytes of a file, a buffer at a time (each view valid until the next is
    asked for), the next read in flight on ``pool`` while the caller uses one (two ``bufs``)."""
    def read(buf: memoryview, at: int) -> int:
        nonlocal direct
        want = min(len(buf), size - at)
        if direct is not None:
            try:
                return os.preadv(direct, [buf[:want + -want % ALIGN]], at)   # whole blocks; short at the end
            except OSError as e:
                if e.errno != errno.EINVAL:
                    raise
                direct = None
        return os.preadv(fd, [buf[:want]], at)

    at, k = 0, 0
    ahead = pool.submit(read, bufs[0], 0) if size else None
    while at < size:
        got = min(ahead.result(), size - at)
        if got <= 0:
            raise OSError(f"the records' scratch file ends at {at} of {size} bytes")
        if at + got < size:
            ahead = pool.submit(read, bufs[1 - k], at + got)
        yield bufs[k][:got]
        at, k = at + got, 1 - k


class StaticMembers:
    """The members of a trace file that depend on the grid and scene alone (``voxel_gaps`` to
    ``prim_material``: the grid's lists stored compactly, deflated), made ahead, on any thread,
    as a run of zip entries: ``TraceWriter.finish`` copies them into the file as they are.  The
    samples, filled while tracing, are not among them."""

    NAMES = tuple(k for k in MEMBERS if k not in RECORDS + ("samples",))

    def __init__(self, meta: dict, arrays: dict):
        members = file_members(meta, {k: v for k, v in arrays.items() if k not in RECORDS + ("samples",)})
        buf = io.BytesIO()
        z = zipfile.ZipFile(buf, "w", allowZip64=True)
        self.sums = {}
        for k in self.NAMES:
            _write_array(z, k, members[k], False)
            self.sums[k] = typed_crc(np.asarray(members[k]))
        self.infos = list(z.infolist())     # their offsets from the run's start
        self.data = buf.getbuffer()[:z.start_dir].tobytes()
        z.fp = None                         # not closed: no central directory (the file has its own)

    def append_to(self, z: zipfile.ZipFile) -> dict:
        """Copy the entries to the end of zip archive z (open for writing); their checksums."""
        base = z.start_dir
        z.fp.seek(base)
        z.fp.write(self.data)
        for info in self.infos:
            info.header_offset += base
            z.filelist.append(info)
            z.NameToInfo[info.filename] = info
        z.start_dir = base + len(self.data)
        self.infos = []                     # copied once
        return dict(self.sums)


class TraceWriter:
    """A trace file written while the trace is made, in bounded memory: ``write`` hands over a
    chunk of records, written in the background (visits straight into the file's stored
    ``visits.npy``, rays into an unnamed scratch file beside it) while the caller makes the
    next ones (``depth`` chunks in flight at most); ``finish`` completes the file (the visits'
    count and checksum put in place, the rays copied in, the other arrays, ``meta.json`` last)
    and moves it onto the path; ``abort`` leaves the path untouched.  The records' CRC-32s are
    taken as they are written (one pass, over bytes still in cache); the zip's and ``meta``'s
    checksums are combined from them.  With ``compress`` the file so made is a scratch file
    beside the path (``.NAME.PID.stream.tmp.npz``), deflated into the path by ``finish``
    (``tracefile.write``, itself through a temporary)."""

    def __init__(self, path, depth: int = 1, compress: bool = False):
        self.path = os.fspath(path)
        self.compress = bool(compress)
        self.part = temporary(self.path, "stream" if self.compress else "")   # made by ZipFile: open's mode
        self.mapped = None                  # with compress, after finish: the records mapped from the scratch file
        self.z = self.visits = self.rays = None
        self.pending: deque = deque()
        self.depth = max(1, int(depth))      # writes in flight at most
        self.fds: list = []
        self.bufs: list = []
        self.pool = ThreadPoolExecutor(max_workers=1)
        self.count = {"rays": 0, "visits": 0}
        self.records_at: dict = {}          # after finish: name -> (offset of the data, count)
        try:
            self.z = zipfile.ZipFile(self.part, "w", allowZip64=True)
            self.info = _stored("visits", False)
            with self.z.open(self.info, "w", force_zip64=True) as f:   # the local header; sizes come later
                f.write(npy_header(VISIT_DTYPE, 0))
            self.z.fp.flush()
            plain = self._open(self.part)
            self.bufs = [aligned_buffer(BUFFER_BYTES + ALIGN), aligned_buffer(BUFFER_BYTES // 4 + ALIGN)]
            self.visits = Appender(plain, self._direct(self.part), self.z.start_dir, self.bufs[0])
            fd = self._scratch()
            self.rays = Appender(fd, self.rays_direct, 0, self.bufs[1])
        except BaseException:
            self.abort()
            raise

    def _scratch(self) -> int:
        """The rays' scratch file beside the path, unnamed (``O_TMPFILE``: nothing to leave behind
        whatever ends the process), or where the file system cannot, named (``.NAME.PID.rays.tmp.npz``)
        and unlinked once opened twice; sets ``rays_direct``.  Returns its plain descriptor."""
        tmpfile = getattr(os, "O_TMPFILE", 0)
        if tmpfile:
            try:
                fd = os.open(os.path.dirname(os.path.abspath(self.path)), tmpfile | os.O_RDWR, 0o600)
            except OSError:
                pass
            else:
                self.fds.append(fd)
                self.rays_direct = self._direct(f"/proc/self/fd/{fd}")     # (None without /proc)
                return fd
        scratch = temporary(self.path, "rays")
        try:
            fd = os.open(scratch, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o600)
            self.fds.append(fd)
            self.rays_direct = self._direct(scratch)
        finally:
            os.unlink(scratch)
        return fd

    def _open(self, path) -> int:
        fd = os.open(path, os.O_RDWR)
        self.fds.append(fd)
        return fd

    def _direct(self, path) -> int | None:
        fd = direct_fd(path)
        if fd is not None:
            self.fds.append(fd)
        return fd

    def _write(self, rays: np.ndarray, visits: np.ndarray, offset: int) -> None:
        for f, a in ((self.rays, rays), (self.visits, visits)):
            if len(a) and offset:
                f.write_records(a, offset)
            elif len(a):
                f.write(as_bytes(a))       # crc32 and the writes let other threads run

    def _wait(self, left: int = 0) -> None:
        """Wait until at most ``left`` writes are in flight (raising the first error)."""
        while len(self.pending) > left:
            self.pending.popleft().result()

    def write(self, rays: np.ndarray, visits: np.ndarray, offset: int = 0) -> None:
        """Append records (contiguous RAY_DTYPE and VISIT_DTYPE arrays), their ray numbers moved
        on by offset as they are copied (records numbered from 0 for a group of tiles), written
        in the background, in order: the caller leaves the arrays alone until ``depth`` more
        calls of write, or ``settle``, finish or abort, have returned (the writes in flight
        are at most ``depth``)."""
        self._wait(self.depth - 1)
        self.count["rays"] += len(rays)
        self.count["visits"] += len(visits)
        self.pending.append(self.pool.submit(self._write, rays, visits, offset))

    def settle(self) -> None:
        """Wait until no write is in flight, keeping their errors for ``finish`` to raise: the
        arrays handed to write are the caller's again."""
        futures.wait(list(self.pending))

    def _complete(self, info, appender: Appender, dtype, count: int) -> int:
        """Put a streamed member's count, sizes and CRC in place (its .npy header and local zip
        header) and move the zip past its data; returns meta's checksum of the records."""
        end = appender.close()
        nbytes = count * dtype.itemsize
        if appender.size != nbytes:
            raise OSError(f"{info.filename}: {appender.size} bytes written for {count} records")
        header = npy_header(dtype, count)
        info.CRC = crc32_combine(zlib.crc32(header), appender.crc, nbytes)
        info.file_size = info.compress_size = len(header) + nbytes
        local = info.FileHeader(True)
        fp = self.z.fp
        fp.seek(info.header_offset)
        fp.write(local + header)
        fp.seek(end)
        self.z.start_dir = end
        self.records_at[info.filename[:-4]] = (appender.start, count)
        return crc32_combine(zlib.crc32(signature(dtype, (count,))), appender.crc, nbytes)

    def finish(self, meta: dict, arrays: dict, static: StaticMembers | None = None) -> dict:
        """Complete the file with the arrays other than the records and the metadata, and move it
        onto the path (``static``: the members of the grid and scene made ahead, or None to make
        them now).  Returns the metadata as written."""
        try:
            self._wait()
            sums = {"visits": self._complete(self.info, self.visits, VISIT_DTYPE, self.count["visits"])}
            self.visits = None
            scratch, scratch_size = self.rays.plain, self.rays.close()
            self.rays = None
            info = _stored("rays", False)
            with self.z.open(info, "w", force_zip64=True) as f:
                f.write(npy_header(RAY_DTYPE, 0))
            self.z.fp.flush()
            # the rays copied in from the scratch file: read a buffer ahead (the pool is idle now)
            out = Appender(self._open(self.part), self._direct(self.part), self.z.start_dir, self.bufs[0])
            reads = [self.bufs[1], aligned_buffer(len(self.bufs[1]))]
            for block in _read_blocks(scratch, self.rays_direct, scratch_size, reads, self.pool):
                out.write(block)
            sums["rays"] = self._complete(info, out, RAY_DTYPE, self.count["rays"])
            sums.update((static or StaticMembers(meta, arrays)).append_to(self.z))
            _write_array(self.z, "samples", arrays["samples"], False)
            sums["samples"] = typed_crc(np.asarray(arrays["samples"]))
            meta = dict(meta, format=FORMAT, version=FORMAT_VERSION, crc32=sums)
            self.z.writestr("meta.json", json.dumps(meta, sort_keys=True))
            self.z.close()
            self.z = None
            if self.compress:       # deflated into the path from the records mapped from the scratch file
                self.mapped = self._map(self.part)
                meta = tracefile.write(self.path, {k: v for k, v in meta.items() if k != "crc32"},
                                       dict(arrays, **self.mapped), compress=True)
            else:
                os.replace(self.part, self.path)
        finally:
            self.abort()
        return meta

    def _map(self, path) -> dict:
        out = {}
        for name, dtype in (("rays", RAY_DTYPE), ("visits", VISIT_DTYPE)):
            offset, count = self.records_at[name]
            out[name] = np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=(count,)) if count \
                else np.zeros(0, dtype=dtype)
        return out

    def records(self) -> dict:
        """After ``finish``: the records as read-only arrays mapped from the file (nothing read;
        an empty array where there are none, as ``tracefile.read`` gives); with ``compress``,
        from the uncompressed scratch file, removed but mapped still."""
        return dict(self.mapped) if self.compress else self._map(self.path)

    def abort(self) -> None:
        """Close and remove what was written (the path is left as it was)."""
        for p in self.pending:
            p.cancel()
        while self.pending:     # what has started ends (its error, if any, was raised already or is moot)
            try:
                self.pending.popleft().result()
            except Exception:
                pass
        self.pool.shutdown()
        self.visits = self.rays = None
        if self.z is not None:
            try:
                self.z.close()
            except (OSError, ValueError, zipfile.BadZipFile):
                pass
            self.z = None
        for fd in self.fds:
            os.close(fd)
        self.fds = []
        if os.path.exists(self.part):
            os.unlink(self.part)
