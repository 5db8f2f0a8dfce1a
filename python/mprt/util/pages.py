"""Reading large arrays in bounded memory: ``release`` lets the kernel drop the pages of a
memory-mapped array once processed (except within ``kept()``), ``chunks`` walks an array a copy
of a chunk at a time.
Used by the trace file format, its validation, its invariant check and its statistics.
``sparse_zeros`` makes a large zeroed array of which few entries will be written."""
from __future__ import annotations

import contextlib
import ctypes
import mmap
import threading

import numpy as np

try:
    _madvise = ctypes.CDLL(None, use_errno=True).madvise
    _madvise.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int)
    _DONTNEED = mmap.MADV_DONTNEED
except (AttributeError, OSError):   # no madvise: pages simply stay until the kernel wants them
    _madvise = None


_AROUND = 1 << 21   # the kernel may map pages beyond a fault (fault-around, large folios): up to 2 MiB
_KEPT = [0]         # kept() blocks open, in any thread: release lets nothing go while one is
_KEPT_LOCK = threading.Lock()


@contextlib.contextmanager
def kept():
    """Within the block (in every thread) ``release`` lets no page go: for a reader whose next
    step touches every page again at once, such as the compiled replay's loading of a trace file
    after its checksums and check (the loading maps the whole file anyway, so dropping the pages
    between the passes bounds nothing and only costs the faults of mapping them again)."""
    with _KEPT_LOCK:
        _KEPT[0] += 1
    try:
        yield
    finally:
        with _KEPT_LOCK:
            _KEPT[0] -= 1


def release(a: np.ndarray, since: np.ndarray | None = None) -> None:
    """Let the kernel drop the pages of a read-only memory-mapped array from its start to the
    end of the slice ``a`` (and a little beyond, where the kernel maps ahead) from this
    process's resident set: they stay in the page cache and are read again if touched.  Called
    on each slice once it is processed, reading a file of any size through (in order, or with
    look-ups behind) keeps memory bounded.  ``since`` (a slice of the same map, at or before
    ``a``): the pages from its start only (a reader of the map's second half, beside one of its
    first).  Anything but a read-only memory map is left alone."""
    if _KEPT[0] or _madvise is None or not isinstance(a, np.memmap) or a.mode != "r" or a.nbytes == 0 \
            or not a.flags.c_contiguous:
        return
    root = a
    while isinstance(root.base, np.ndarray):
        root = root.base
    first = root.ctypes.data if since is None else max(since.ctypes.data, root.ctypes.data)
    start = first - first % mmap.PAGESIZE
    _madvise(start, min(a.ctypes.data + a.nbytes + _AROUND, root.ctypes.data + root.nbytes) - start, _DONTNEED)


def chunks(a: np.ndarray, size: int):
    """(offset, in-memory copy of a[offset:offset + size]) over the whole array; a memory-mapped
    array's pages are released after each copy (``release``)."""
    for i in range(0, len(a), size):
        part = a[i:i + size]
        yield i, np.array(part)
        release(part)


SPARSE_MIN = 1 << 22    # bytes: smaller arrays are plain np.zeros


def sparse_zeros(n: int, dtype) -> np.ndarray:
    """A zeroed array of ``n`` entries for sparse writes (per voxel of a fine grid, of which a
    small trace visits few): a large one is an anonymous mapping of its own, whose pages the
    kernel gives, zeroed, only where written (in small pages).  NumPy asks for huge pages on large arrays
    (madvise), so that its first write to each 2 MiB zeroes all of it: 16 M voxels' counts,
    written at a few thousand places, took 0.4 s that way and 0.05 s this way."""
    dtype = np.dtype(dtype)
    nbytes = int(n) * dtype.itemsize
    if nbytes < SPARSE_MIN:
        return np.zeros(int(n), dtype)
    # private, as any other memory: a worker forked from this process writes its own copy
    m = mmap.mmap(-1, nbytes, flags=mmap.MAP_PRIVATE) if hasattr(mmap, "MAP_PRIVATE") else mmap.mmap(-1, nbytes)
    if hasattr(mmap, "MADV_NOHUGEPAGE"):       # (where the system gives huge pages unasked)
        try:
            m.madvise(mmap.MADV_NOHUGEPAGE)
        except OSError:
            pass
    return np.frombuffer(m, dtype=dtype)
