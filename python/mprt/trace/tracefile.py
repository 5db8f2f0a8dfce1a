"""The trace file format: an .npz (zip) of ``meta.json`` and one ``.npy`` per array.

``meta`` carries the format name and version and a CRC-32 of every member (the
version 1 files of the first trace format carry a SHA-256 instead), so
an unknown version, a truncated file or edited data are each a clear
``TraceError``.  The records (``rays``, ``visits``) are stored as they are in
memory, uncompressed unless asked, so that they are memory-mapped on request
(a trace of any size opens in bounded memory), and a trace can be written while
it is traced (``mprt.tracewriter``) without holding its records in memory.  The
samples follow the records (deflate gains little on them); everything else is
small once stored compactly and is always deflated: version 3 keeps the
voxel lists of the non-empty voxels only (the ids of those voxels as gaps, the
length of each list in the narrowest unsigned type, and the lists), where
versions 1 and 2 kept a list start for every voxel of the grid (a 128^3 grid
cost 8 MB whatever the trace).  This module knows the format only: it reads
and writes (meta, arrays) pairs whose arrays are those of ``ARRAYS``;
``mprt.trace`` makes them a ``Trace``.
"""
from __future__ import annotations

import hashlib
import json
import os
import math
import tokenize
import zipfile
import zlib
from concurrent.futures import ThreadPoolExecutor
from types import SimpleNamespace

import numpy as np

from .._lowlevel import binding
from ..util.atomic import replacing
from ..errors import TraceError
from . import tracecheck, tracevalid
from ..util.pages import chunks, release  # noqa: F401  (tracefile.chunks, tracefile.release: kept for callers)

FORMAT = "mprt-trace"
FORMAT_VERSION = 4
VERSIONS = (1, 2, 3, 4)   # the versions this mprt reads
# The arrays of a trace in memory (and the members of version 1 and 2 files).
ARRAYS = ("rays", "visits", "voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material", "samples")
# The members of a version 3 or 4 file: voxel_start becomes voxel_gaps and voxel_count.
MEMBERS = ("rays", "visits", "voxel_gaps", "voxel_count", "voxel_ids", "prim_kind", "prim_words", "prim_material",
           "samples")
RECORDS = ("rays", "visits")   # deflated unless large (or when asked): stored ones can be memory-mapped
# write(compress=None) deflates the records when they hold less than this many bytes; larger
# ones are stored, to be memory-mapped (deflate runs at about 130 MB/s at level 3 and shrinks
# records about 10 times).
AUTO_COMPRESS_BYTES = 256 << 20
DEFLATE_LEVEL = 3
# Version 1 had the same layout as version 2 with the visit fields 'voxel' (now
# 'voxel_id') and 'voxels' (now 'steps'); it is read by renaming them.
_V1_VISIT_NAMES = {"voxel": "voxel_id", "voxels": "steps"}
REGENERATE = "regenerate it with 'mprt trace SCENE --grid N --res WxH -o FILE'"


def narrowest_uint(values: np.ndarray) -> np.dtype:
    """The narrowest unsigned integer type holding every value (all >= 0)."""
    top = int(values.max()) if values.size else 0
    for dtype in (np.uint8, np.uint16, np.uint32):
        if top <= np.iinfo(dtype).max:
            return np.dtype(dtype)
    return np.dtype(np.uint64)


def compact_voxels(start: np.ndarray) -> dict:
    """The file form of CSR list starts over every voxel: ``voxel_gaps`` (uint32: the first
    non-empty voxel's id, then the differences between consecutive non-empty ids) and
    ``voxel_count`` (the length of each non-empty voxel's list, narrowest unsigned type)."""
    count = np.diff(start.astype(np.int64))
    nonempty = np.flatnonzero(count)
    gaps = np.diff(nonempty, prepend=0).astype(np.uint32)
    return {"voxel_gaps": gaps, "voxel_count": count[nonempty].astype(narrowest_uint(count))}


def expand_voxels(gaps: np.ndarray, count: np.ndarray, voxels: int) -> np.ndarray:
    """The CSR list starts (uint32, voxels + 1) of the file form; TraceError when it does not
    fit the grid."""
    nonempty = np.cumsum(gaps, dtype=np.int64)
    if len(gaps) != len(count) or (nonempty.size and (nonempty[-1] >= voxels or np.any(gaps[1:] == 0))):
        raise TraceError(f"voxel_gaps: the voxel lists do not fit a grid of {voxels} voxels (meta.json field 'grid')")
    start = np.zeros(voxels + 1, dtype=np.int64)
    start[nonempty + 1] = count
    return np.cumsum(start).astype(np.uint32)


def grid_voxels(meta: dict) -> int:
    """Voxels of the trace's grid, from its metadata."""
    grid = meta.get("grid")
    if not (isinstance(grid, list) and len(grid) == 3 and all(isinstance(n, int) and n >= 1 for n in grid)):
        raise TraceError(f"meta 'grid' must be three positive integers, not {grid!r}")
    return grid[0] * grid[1] * grid[2]


def file_members(meta: dict, arrays: dict) -> dict:
    """The members of a version 3 file from a trace's arrays (those of ``ARRAYS``; the records
    may be absent, when streamed)."""
    start = np.asarray(arrays["voxel_start"])
    if len(start) != grid_voxels(meta) + 1:
        raise TraceError(f"voxel_start has {len(start)} entries for a grid of {grid_voxels(meta)} voxels")
    out = {k: v for k, v in arrays.items() if k != "voxel_start"}
    out.update(compact_voxels(start))
    return out


def _stored(name: str, compress: bool) -> zipfile.ZipInfo:
    """The zip entry of a member: records and samples deflated only when compress, others always
    (deflate shrinks the samples, float64 colours, by about a tenth, at about 10 MB/s)."""
    info = zipfile.ZipInfo(name + ".npy")
    if compress or name not in RECORDS + ("samples",):
        info.compress_type = zipfile.ZIP_DEFLATED
        # the level's attribute is compress_level from Python 3.13, _compresslevel before
        setattr(info, "compress_level" if hasattr(info, "compress_level") else "_compresslevel", DEFLATE_LEVEL)
    return info


def as_bytes(a: np.ndarray) -> np.ndarray:
    """A contiguous array's bytes as a uint8 view."""
    return a.view(np.uint8).reshape(-1)


def _gf2_times(mat: list, vec: int) -> int:
    out, i = 0, 0
    while vec:
        if vec & 1:
            out ^= mat[i]
        vec >>= 1
        i += 1
    return out


_ZERO_BYTES_OPS: tuple = ()   # [k]: the operator carrying a CRC through 2^k zero bytes (made once)


def _zero_bytes_ops() -> tuple:
    global _ZERO_BYTES_OPS
    if not _ZERO_BYTES_OPS:
        op = [0xEDB88320] + [1 << n for n in range(31)]       # one zero bit
        for _ in range(3):                                      # squared: two, four, eight (one zero byte)
            op = [_gf2_times(op, v) for v in op]
        ops = []
        for _ in range(64):                                     # 1, 2, 4, ... 2^63 zero bytes
            ops.append(op)
            op = [_gf2_times(op, v) for v in op]
        _ZERO_BYTES_OPS = tuple(ops)
    return _ZERO_BYTES_OPS


def crc32_combine(crc1: int, crc2: int, len2: int) -> int:
    """The CRC-32 of A + B from crc1 of A, crc2 of B and len2 = len(B) in bytes (zlib's
    crc32_combine: crc1 carried through len2 zero bytes, an operator per bit of len2, the
    operators for 2^k zero bytes squared once per process rather than once per call)."""
    if len2 <= 0:
        return crc1
    ops = _zero_bytes_ops()
    k = 0
    while len2:
        if len2 & 1:
            crc1 = _gf2_times(ops[k], crc1)
        len2 >>= 1
        k += 1
    return crc1 ^ crc2


CRC_PART = 1 << 26      # bytes: arrays of two parts or more are checksummed by threads, a part each


def _crc_range(b: np.ndarray, lo: int, hi: int, chunk: int) -> int:
    """zlib.crc32 of b[lo:hi], by the library's CRC-32 (``crc32_copy``: zlib's value, folded
    with carry-less multiplications where it can, 2 to 3 times zlib's speed), a chunk at a time."""
    crc32 = binding("double").crc32_copy
    value = 0
    for i in range(lo, hi, chunk):
        j = min(i + chunk, hi)
        value = crc32(memoryview(b[i:j]), value)
        release(b[i:j])
    return value


def crc(a: np.ndarray, chunk: int = 1 << 24, threads: int | None = None) -> int:
    """CRC-32 of an array's bytes, read in chunks (a memory-mapped array is
    not read whole, nor kept resident): detects damaged or edited data.  A
    large array is cut into parts checksummed by ``threads`` threads (default:
    the cores, at most 4; the library's CRC lets go of the GIL) and the parts' CRCs combined:
    the same value whatever the count."""
    if not a.size:
        return 0
    b = as_bytes(a if a.flags.c_contiguous else np.ascontiguousarray(a))
    threads = min(os.cpu_count() or 1, 4) if threads is None else max(1, int(threads))
    parts = min(threads, b.size // CRC_PART)
    if parts < 2:
        return _crc_range(b, 0, b.size, chunk)
    from concurrent.futures import ThreadPoolExecutor

    edges = [b.size * k // parts for k in range(parts + 1)]
    with ThreadPoolExecutor(parts) as pool:
        sums = list(pool.map(lambda k: _crc_range(b, edges[k], edges[k + 1], chunk), range(parts)))
    value = sums[0]
    for k in range(1, parts):
        value = crc32_combine(value, sums[k], edges[k + 1] - edges[k])
    return value


def signature(dtype: np.dtype, shape) -> bytes:
    """What a version 4 checksum covers before the bytes: the array's dtype and shape."""
    return f"{np.lib.format.dtype_to_descr(np.dtype(dtype))!r} {tuple(int(n) for n in shape)!r}\n".encode()


def typed_crc(a: np.ndarray, data_crc: int | None = None) -> int:
    """The version 4 checksum of an array: CRC-32 of its signature (dtype and shape) followed by
    its bytes (``data_crc``: the bytes' CRC-32, when already known), so that an array
    reinterpreted or reshaped under its old checksum is refused as well as edited bytes."""
    return crc32_combine(zlib.crc32(signature(a.dtype, a.shape)), crc(a) if data_crc is None else data_crc,
                         a.nbytes)


def _write_array(z, name, a, compress):
    with z.open(_stored(name, compress), "w", force_zip64=True) as f:
        np.lib.format.write_array(f, np.ascontiguousarray(a), allow_pickle=False)


def write(path, meta: dict, arrays: dict, compress: bool | None = None) -> dict:
    """Write a trace (every array of ``ARRAYS``) with its metadata and checksums.  The records
    are deflate-compressed when ``compress``, stored when False, and when None (the default)
    compressed unless they hold ``AUTO_COMPRESS_BYTES`` or more; the other members always.
    The file is written beside ``path`` and moved onto it whole (``atomic.replacing``): an
    interrupt leaves ``path`` as it was (and a trace memory-mapped from ``path`` may be saved
    onto it).  Returns the metadata as written."""
    if compress is None:
        compress = sum(np.asarray(arrays[k]).nbytes for k in RECORDS) < AUTO_COMPRESS_BYTES
    members = file_members(meta, arrays)
    meta = dict(meta, format=FORMAT, version=FORMAT_VERSION, crc32={k: typed_crc(members[k]) for k in MEMBERS})
    with replacing(path) as tmp, zipfile.ZipFile(tmp, "w", allowZip64=True) as z:
        z.writestr("meta.json", json.dumps(meta, sort_keys=True))
        for k in MEMBERS:
            _write_array(z, k, members[k], compress)
    return meta


_COUNT_DIGITS = 20   # a record count's width in a streamed member's header: any count fits


def npy_header(dtype: np.dtype, count: int) -> bytes:
    """The .npy (version 2.0) header of a 1-d array of count records, its count right-aligned in
    a fixed width (a valid tuple literal), so that the header of any count has the same length
    and can be written before the count is known, then overwritten in place."""
    d = "{'descr': %r, 'fortran_order': False, 'shape': (%*d,), }" % (
        np.lib.format.dtype_to_descr(np.dtype(dtype)), _COUNT_DIGITS, count)
    total = -(-(12 + len(d) + 1) // 64) * 64   # magic, version, length, dict, newline: 64-byte aligned
    return b"\x93NUMPY\x02\x00" + (total - 12).to_bytes(4, "little") + (d.ljust(total - 13) + "\n").encode("latin1")


def _member_offset(f, info) -> int:
    """Offset of a stored zip member's data in the file."""
    f.seek(info.header_offset)
    head = f.read(30)
    if head[:4] != b"PK\x03\x04":
        raise TraceError("bad zip local header")
    name_len = int.from_bytes(head[26:28], "little")
    extra_len = int.from_bytes(head[28:30], "little")
    return info.header_offset + 30 + name_len + extra_len


META_MAX = 1 << 20          # bytes of meta.json
DEFLATE_RATIO_MAX = 1032    # deflate's largest expansion: what a member holds is bounded by the file
# What zipfile raises for a damaged or foreign archive or member, besides BadZipFile: a newer
# zip version, an unknown compression method (NotImplementedError), an encrypted member
# (RuntimeError), a damaged deflate, bzip2 or LZMA stream (zlib.error, OSError, LZMAError).
try:
    from lzma import LZMAError as _LZMAError
except ImportError:             # Python built without lzma: zipfile cannot raise it either
    _LZMAError = zlib.error
_ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, _LZMAError, OSError, ValueError, EOFError, NotImplementedError,
               RuntimeError)
_NPY_ERRORS = _ZIP_ERRORS + (SyntaxError, OverflowError, RecursionError, MemoryError, tokenize.TokenError, TraceError)


def _npy_header(f, size: int):
    """(shape, dtype, header bytes) of a .npy member of ``size`` bytes read from ``f``; TraceError
    unless its data is exactly the rest of the member (a count in a damaged header never
    decides what is allocated) and its dtype holds numbers."""
    begin = f.tell()
    version = np.lib.format.read_magic(f)
    read_header = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    if version not in read_header:
        raise TraceError(f"unsupported .npy version {version}")
    shape, fortran, dtype = read_header[version](f)
    if fortran:
        raise TraceError("Fortran-ordered arrays are not expected in a trace")
    if dtype.hasobject:
        raise TraceError(f"dtype {dtype} holds Python objects")
    head = f.tell() - begin
    if not all(isinstance(n, int) and n >= 0 for n in shape) or \
            head + math.prod(shape) * dtype.itemsize != size:
        raise TraceError(f"shape {shape} of {dtype} does not fill its {size - head} bytes")
    return shape, dtype, head


def _read_npy(path, z, raw, info, mmap: bool):
    """A member as an array: memory-mapped (no copy) when stored and ``mmap``, read otherwise."""
    if mmap and info.compress_type == zipfile.ZIP_STORED:
        off = _member_offset(raw, info)
        raw.seek(off)
        shape, dtype, head = _npy_header(raw, info.file_size)
        if math.prod(shape) == 0:
            return np.zeros(shape, dtype=dtype)
        return np.memmap(path, dtype=dtype, mode="r", offset=off + head, shape=shape)
    if info.file_size > DEFLATE_RATIO_MAX * info.compress_size + 4096:
        raise TraceError(f"{info.file_size} bytes cannot come from {info.compress_size} deflated")
    with z.open(info) as f:
        shape, dtype, head = _npy_header(f, info.file_size)
        data = f.read(info.file_size - head)
    a = np.frombuffer(bytearray(data), dtype=dtype)
    return a.reshape(shape)


def _read_meta(path, z, names) -> dict:
    if "meta.json" not in names:
        raise TraceError(f"{path}: no meta.json: not an mprt trace")
    if z.getinfo("meta.json").file_size > META_MAX:
        raise TraceError(f"{path}: meta.json is over {META_MAX} bytes")
    try:
        meta = json.loads(z.read("meta.json"))
    except _ZIP_ERRORS + (RecursionError,) as e:
        reason = "nested too deeply" if isinstance(e, RecursionError) else str(e).splitlines()[0] if str(e) else \
            type(e).__name__
        raise TraceError(f"{path}: meta.json is unreadable ({reason})") from None
    if not isinstance(meta, dict):
        raise TraceError(f"{path}: meta.json must be a JSON object, not {type(meta).__name__}")
    if meta.get("format") != FORMAT:
        raise TraceError(f"{path}: not an mprt trace (meta.json field 'format' is {meta.get('format')!r:.60})")
    if meta.get("version") not in VERSIONS or isinstance(meta.get("version"), bool):
        raise TraceError(f"{path}: trace format version {meta.get('version')!r:.60} is not supported "
                         f"(this mprt reads versions 1 to {FORMAT_VERSION}); {REGENERATE}")
    return meta


def sha256(a: np.ndarray, chunk: int = 1 << 24) -> str:
    """SHA-256 (hex) of an array's bytes, in chunks (memory-mapped arrays page in and out)."""
    h = hashlib.sha256()
    b = a.reshape(-1).view(np.uint8) if a.flags.c_contiguous else np.ascontiguousarray(a).reshape(-1).view(np.uint8)
    for i in range(0, len(b), chunk):
        h.update(memoryview(np.ascontiguousarray(b[i:i + chunk])))
    return h.hexdigest()


def _checksum_matches(meta: dict, name: str, a: np.ndarray) -> bool:
    """The member's checksum in ``meta``: CRC-32 of dtype, shape and bytes (``crc32``, version 4),
    of the bytes (``crc32``, versions 2 and 3 and later version 1 files) or SHA-256 of the
    bytes (``sha256``, the version 1 files of the first trace format)."""
    if "crc32" in meta:
        want = meta["crc32"].get(name)
        if not isinstance(want, int):
            return False
        return want == (typed_crc(a) if meta["version"] >= 4 else crc(a))
    if "sha256" in meta and meta.get("version") == 1:
        want = meta["sha256"].get(name)
        return isinstance(want, str) and want == sha256(a)
    return False


def _rename_v1(visits: np.ndarray) -> np.ndarray:
    """Version 1 visits (same bytes) seen with today's field names."""
    if visits.dtype.names is None:
        return visits
    names = visits.dtype.names
    return visits.view(np.dtype({"names": [_V1_VISIT_NAMES.get(n, n) for n in names],
                                 "formats": [visits.dtype.fields[n][0] for n in names],
                                 "offsets": [visits.dtype.fields[n][1] for n in names],
                                 "itemsize": visits.dtype.itemsize}))


BACKGROUND_CRC = 64 << 20  # bytes: a memory-mapped record member this large is checksummed on a thread


def _settle(pending: list, path: str) -> None:
    """Wait for the checksums computed in the background; raise the first that does not match."""
    for k, done in pending:
        if not done.result():
            raise TraceError(f"{path}: array {k!r} does not match its checksum (tampered or damaged)")
    pending.clear()


def read(path, mmap: bool | None = None, verify: bool = True, invariants: bool = False, keys: dict | None = None):
    """Read a trace file: (meta, arrays), the arrays those of ``ARRAYS``.  Checks the format
    version, the metadata (``tracevalid.check_meta``: before any array is read), that every
    member is present and whole, (``verify``) the checksums, and the arrays
    (``tracevalid.check_arrays``), then (``invariants``) the invariants between the records
    (``mprt.tracecheck``).  Uncompressed members are memory-mapped when ``mmap``
    (default: when the file is over 256 MB).  A version 1, 2 or 3 file is returned with
    today's field names and version.  Every failure is one TraceError naming the file, the
    member and the field (an invariant: the rule and the ray, as ``tracecheck.check`` names
    it); memory is bounded by the file's size.  The checksum of a large memory-mapped record
    member is computed on a thread while the rest is read and checked (CRC-32 lets go of the
    interpreter), the errors raised in the order a sequential reading would meet them.  ``keys``
    (a dict): level 3's memory keys made while the records are checked, added to it
    (``tracevalid.check_arrays``'s ``keys``) when the checks pass."""
    path = os.fspath(path)
    try:
        z = zipfile.ZipFile(path)
        size = os.path.getsize(path)
    except _ZIP_ERRORS as e:
        reason = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise TraceError(f"{path}: not a readable trace file ({reason:.200})") from None
    if mmap is None:
        mmap = size > (256 << 20)
    pending, pool = [], None
    try:
        with z, open(path, "rb") as raw:
            names = set(z.namelist())
            meta = _read_meta(path, z, names)
            try:
                tracevalid.check_meta(meta, size)
            except TraceError as e:
                raise TraceError(f"{path}: {e}") from None
            version = meta["version"]
            arrays = {}
            for k in MEMBERS if version >= 3 else ARRAYS:
                if k + ".npy" not in names:
                    raise TraceError(f"{path}: array {k!r} is missing")
                info = z.getinfo(k + ".npy")
                try:
                    arrays[k] = _read_npy(path, z, raw, info, mmap)
                except _NPY_ERRORS as e:
                    reason = str(e).splitlines()[0] if str(e) else type(e).__name__
                    raise TraceError(f"{path}: array {k!r} is truncated or corrupt ({reason:.200})") from None
                if verify and isinstance(arrays[k], np.memmap) and arrays[k].nbytes >= BACKGROUND_CRC:
                    pool = pool or ThreadPoolExecutor(max_workers=1)
                    pending.append((k, pool.submit(_checksum_matches, meta, k, arrays[k])))
                elif verify and not _checksum_matches(meta, k, arrays[k]):
                    raise TraceError(f"{path}: array {k!r} does not match its checksum (tampered or damaged)")
        try:
            if version >= 3:
                for k in ("voxel_gaps", "voxel_count"):
                    if arrays[k].ndim != 1 or arrays[k].dtype.kind != "u":
                        raise TraceError(f"{k}: has dtype {arrays[k].dtype} and shape {arrays[k].shape}, "
                                         "expected one dimension of unsigned integers")
                arrays["voxel_start"] = expand_voxels(arrays.pop("voxel_gaps"), arrays.pop("voxel_count"),
                                                      grid_voxels(meta))
                if arrays["voxel_start"][-1] != len(arrays["voxel_ids"]):
                    raise TraceError(f"the voxel lists hold {arrays['voxel_start'][-1]} entries, "
                                     f"voxel_ids {len(arrays['voxel_ids'])}")
            if version == 1:
                arrays["visits"] = _rename_v1(arrays["visits"])
            meta["version"] = FORMAT_VERSION
            found = tracevalid.check_arrays(meta, arrays, invariants=invariants, keys=keys)
        except TraceError as e:
            raise TraceError(f"{path}: {e}") from None
        _settle(pending, path)
        if invariants:
            tracecheck.settle(SimpleNamespace(rays=arrays["rays"], visits=arrays["visits"]), found)
    except TraceError:
        _settle(pending, path)      # a member's checksum, met first by a sequential reading
        raise
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    return meta, arrays
