"""The trace file format: an .npz (zip) of ``meta.json`` and one ``.npy`` per array.

``meta`` carries the format name and version and a CRC-32 of every array, so
an unknown version, a truncated file or edited data are each a clear
``TraceError``.  Uncompressed members are memory-mapped on request (a trace of
any size opens in bounded memory), and a trace can be written from record
files streamed to disk without holding them in memory.  This module knows the
format only: it reads and writes (meta, arrays) pairs; ``mprt.trace`` makes
them a ``Trace``.
"""
from __future__ import annotations

import io
import json
import os
import shutil
import zipfile
import zlib

import numpy as np

from ._lowlevel import RAY_DTYPE, VISIT_DTYPE
from .errors import TraceError

FORMAT = "mprt-trace"
FORMAT_VERSION = 2
ARRAYS = ("rays", "visits", "voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material", "samples")
# Version 1 had the same layout with the visit fields 'voxel' (now 'voxel_id')
# and 'voxels' (now 'steps'); it is read by renaming them.
_V1_VISIT_NAMES = {"voxel": "voxel_id", "voxels": "steps"}
REGENERATE = "regenerate it with 'mprt trace SCENE --grid N --res WxH -o FILE'"


def as_bytes(a: np.ndarray) -> np.ndarray:
    """A contiguous array's bytes as a uint8 view."""
    return a.view(np.uint8).reshape(-1)


def crc(a: np.ndarray, chunk: int = 1 << 26) -> int:
    """CRC-32 of an array's bytes, read in chunks (a memory-mapped array is
    not read whole): detects damaged or edited data."""
    b = as_bytes(np.ascontiguousarray(a)) if a.size else np.zeros(0, np.uint8)
    value = 0
    for i in range(0, b.size, chunk):
        value = zlib.crc32(memoryview(np.ascontiguousarray(b[i:i + chunk])), value)
    return value


def _write_array(z, name, a):
    with z.open(name + ".npy", "w", force_zip64=True) as f:
        np.lib.format.write_array(f, np.ascontiguousarray(a), allow_pickle=False)


def write(path, meta: dict, arrays: dict, compress: bool = False) -> dict:
    """Write every array of ``ARRAYS`` with the metadata and checksums (deflate-compressed when
    ``compress``); returns the metadata as written."""
    meta = dict(meta, format=FORMAT, version=FORMAT_VERSION, crc32={k: crc(arrays[k]) for k in ARRAYS})
    mode = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(path, "w", compression=mode, allowZip64=True) as z:
        z.writestr("meta.json", json.dumps(meta, sort_keys=True))
        for k in ARRAYS:
            _write_array(z, k, arrays[k])
    return meta


def write_streamed(path, meta: dict, streamed: dict, arrays: dict) -> dict:
    """Write a trace whose record arrays are raw files on disk: ``streamed`` maps an array name
    to (file, dtype, count, crc32 of the file); ``arrays`` holds the others.  The raw files are
    copied in blocks, never read whole.  Returns the metadata as written."""
    sums = {k: s[3] for k, s in streamed.items()}
    sums.update({k: crc(v) for k, v in arrays.items()})
    meta = dict(meta, format=FORMAT, version=FORMAT_VERSION, crc32=sums)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as z:
        z.writestr("meta.json", json.dumps(meta, sort_keys=True))
        for k in ARRAYS:
            if k not in streamed:
                _write_array(z, k, arrays[k])
                continue
            src, dtype, count, _ = streamed[k]
            with z.open(k + ".npy", "w", force_zip64=True) as f:
                header = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False, "shape": (count,)}
                np.lib.format.write_array_header_2_0(f, header)
                with open(src, "rb") as s:
                    shutil.copyfileobj(s, f, 1 << 22)
    return meta


def _member_offset(f, info) -> int:
    """Offset of a stored zip member's data in the file."""
    f.seek(info.header_offset)
    head = f.read(30)
    if head[:4] != b"PK\x03\x04":
        raise TraceError("bad zip local header")
    name_len = int.from_bytes(head[26:28], "little")
    extra_len = int.from_bytes(head[28:30], "little")
    return info.header_offset + 30 + name_len + extra_len


def _mmap_npy(path, f, info):
    """Memory-map an uncompressed .npy member (no copy, bounded memory)."""
    off = _member_offset(f, info)
    f.seek(off)
    version = np.lib.format.read_magic(f)
    read_header = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    if version not in read_header:
        raise TraceError(f"unsupported .npy version {version}")
    shape, fortran, dtype = read_header[version](f)
    if fortran:
        raise TraceError("Fortran-ordered arrays are not expected in a trace")
    count = int(np.prod(shape))
    if f.tell() - off + count * dtype.itemsize > info.file_size:
        raise TraceError("array is truncated")
    if count == 0:
        return np.zeros(shape, dtype=dtype)
    return np.memmap(path, dtype=dtype, mode="r", offset=f.tell(), shape=shape)


def _read_meta(path, z, names) -> dict:
    if "meta.json" not in names:
        raise TraceError(f"{path}: no meta.json: not an mprt trace")
    try:
        meta = json.loads(z.read("meta.json"))
    except (ValueError, zipfile.BadZipFile) as e:
        raise TraceError(f"{path}: meta.json is unreadable ({e})") from None
    if meta.get("format") != FORMAT:
        raise TraceError(f"{path}: not an mprt trace (format {meta.get('format')!r})")
    if meta.get("version") not in (1, FORMAT_VERSION):
        raise TraceError(f"{path}: trace format version {meta.get('version')!r} is not supported "
                         f"(this mprt reads versions 1 and {FORMAT_VERSION}); {REGENERATE}")
    return meta


def _rename_v1(visits: np.ndarray) -> np.ndarray:
    """Version 1 visits (same bytes) seen with today's field names."""
    if visits.dtype.names is None:
        return visits
    names = visits.dtype.names
    return visits.view(np.dtype({"names": [_V1_VISIT_NAMES.get(n, n) for n in names],
                                 "formats": [visits.dtype.fields[n][0] for n in names],
                                 "offsets": [visits.dtype.fields[n][1] for n in names],
                                 "itemsize": visits.dtype.itemsize}))


def read(path, mmap: bool | None = None, verify: bool = True):
    """Read a trace file: (meta, arrays).  Checks the format version, that every array is
    present and whole, and (``verify``) the checksums.  Uncompressed members are memory-mapped
    when ``mmap`` (default: when the file is over 256 MB).  A version-1 file is returned with
    today's field names and version."""
    path = os.fspath(path)
    try:
        z = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as e:
        raise TraceError(f"{path}: not a readable trace file ({e})") from None
    if mmap is None:
        mmap = os.path.getsize(path) > (256 << 20)
    with z, open(path, "rb") as raw:
        names = set(z.namelist())
        meta = _read_meta(path, z, names)
        arrays = {}
        for k in ARRAYS:
            if k + ".npy" not in names:
                raise TraceError(f"{path}: array {k!r} is missing")
            info = z.getinfo(k + ".npy")
            try:
                if mmap and info.compress_type == zipfile.ZIP_STORED:
                    arrays[k] = _mmap_npy(path, raw, info)
                else:
                    with z.open(info) as f:
                        data = f.read()
                    arrays[k] = np.lib.format.read_array(io.BytesIO(data), allow_pickle=False)
            except (ValueError, EOFError, zipfile.BadZipFile, OSError, TraceError) as e:
                raise TraceError(f"{path}: array {k!r} is truncated or corrupt ({e})") from None
            if verify and meta.get("crc32", {}).get(k) != crc(arrays[k]):
                raise TraceError(f"{path}: array {k!r} does not match its checksum (tampered or damaged)")
    if meta["version"] == 1:
        arrays["visits"] = _rename_v1(arrays["visits"])
        meta["version"] = FORMAT_VERSION
    if arrays["rays"].dtype != RAY_DTYPE or arrays["visits"].dtype != VISIT_DTYPE:
        raise TraceError(f"{path}: rays/visits have an unexpected layout; {REGENERATE}")
    return meta, arrays
