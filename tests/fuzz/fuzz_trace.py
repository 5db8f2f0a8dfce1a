"""fuzz_trace.py: the trace-file surface of fuzz_inputs.py (surface 3).

The input (after fuzz_inputs' surface byte) becomes a trace file, which then goes where a
trace from outside goes: ``tracefile.read`` and the validation (``load_trace``), the
invariant check and the statistics (what ``mprt stats --check`` runs), and, when it passes
and is small (at most ``VISITS_MAX`` visits), both engines, SimPy (``simulate``) and the
compiled replay (``replay``), at level 1 and at level 3 (ring and memories) on a small
machine.  Accepted: one ``MprtError`` of one line (TraceError for the file), or a replay on
which both engines give the same SimResult, or both the same error (class and message,
DeadlockError included).  Anything else raises: a finding.

The first byte after the surface byte is the mode: bit 0 clear, the rest of the input is
the file itself (raw bytes, the seed corpus holding whole trace files); bit 0 set, the rest
is a list of edits to a small golden trace (``trace_base.npz``, balls at 3x3 on a 4^3 grid:
37 rays, 341 visits), so that a mutation changes a field, a size, a header or a checksum
rather than asking the fuzzer to make a zip.  Bit 1 memory-maps the stored members.  Each
edit is an operation byte and its arguments (``_Bytes``: zeros once the input runs out):

  0  a record field (rays or visits, the field, the record, the value: ``_value``)
  1  an element of another array (voxel_gaps ... samples) set to a value
  2  a meta.json field set to one of ``META_VALUES`` or a small integer, or removed
  3  an array cut short, reshaped, viewed as bytes, cast, emptied, doubled or removed
  4  the checksums: left as they were before the edits, or one of them changed
  5  a byte of a member's serialized form (its .npy header or data, meta.json) changed
  6  a member deflated or stored, or an extra member added
  7  a byte of the whole file changed (zip headers, the central directory)

Edits 0-3 come first (arrays and metadata), then the checksums are made to match (unless
edit 4 says otherwise), then 5, the zip (6), and 7."""
from __future__ import annotations

import io
import json
import atexit
import os
import tempfile
import zipfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
BASE = os.path.join(HERE, "trace_base.npz")
VISITS_MAX = 3000          # replayed on both engines only up to this many visits (and rays)
META_KEYS = ("grid", "width", "height", "samples_w", "samples_h", "rules", "lights", "max_depth", "threshold",
             "ambient", "scene", "tile", "tiles_total", "tiles", "mailbox", "kinds", "stages", "outcomes",
             "ray_kinds", "format", "version", "crc32", "grid_lo", "grid_hi", "precision", "camera", "extra")
META_VALUES = (None, True, False, 0, 1, -1, 2, 3, 4, 5, 16, 255, 1024, 65536, 2 ** 31 - 1, 2 ** 31, 2 ** 63, -2 ** 63,
               10 ** 30, 0.5, 1e308, float("inf"), float("nan"), "", "x", "paper", "strict", "mprt-trace", [], {},
               [4, 4, 4], [1, 1, 1], [1024, 1024, 1024], [4, 4], [0], [0, 0], [1, 0], [-1.0, 0.0, 1.0],
               ["sphere", "polygon", "cylinder", "cone"], ["OS", "IC", "SC"], {"a": 1}, [[[[1]]]])
OTHER = ("voxel_gaps", "voxel_count", "voxel_ids", "prim_kind", "prim_words", "prim_material", "samples")
_STATE: dict = {}


class _Bytes:
    def __init__(self, data: bytes):
        self.data, self.i = data, 0

    def more(self) -> bool:
        return self.i < len(self.data)

    def u8(self) -> int:
        self.i += 1
        return self.data[self.i - 1] if self.i <= len(self.data) else 0

    def u16(self) -> int:
        return self.u8() | self.u8() << 8

    def raw(self, n: int) -> bytes:
        return bytes(self.u8() for _ in range(n))


def _value(b: _Bytes) -> bytes:
    """A value's 8 little-endian bytes: a byte k < 0x80 is the small integer k - 8 (-8..119);
    otherwise the next 8 bytes as they are (any integer, NaN, infinities)."""
    k = b.u8()
    return int(k - 8).to_bytes(8, "little", signed=True) if k < 0x80 else b.raw(8)


def _set(a: np.ndarray, index: int, raw8: bytes, field: str | None = None) -> None:
    """Element ``index`` (a record's ``field``) of a flat array set to the low bytes of raw8
    (wrapping, as a C cast would; a float field takes them as its bits)."""
    if a.size == 0:
        return
    flat = a.reshape(-1)
    index %= len(flat)
    if field is None:
        target, size = flat[index:index + 1].view(np.uint8), a.dtype.itemsize
    else:
        off, size = flat.dtype.fields[field][1], flat.dtype.fields[field][0].itemsize
        target = flat[index:index + 1].view(np.uint8)[off:off + size]
    target[:] = np.frombuffer((raw8 * 2)[:size], dtype=np.uint8)


def base():
    """The golden trace's meta.json (a dict) and members (arrays), read without validation."""
    if "base" not in _STATE:
        with zipfile.ZipFile(BASE) as z:
            meta = json.loads(z.read("meta.json"))
            arrays = {n[:-4]: np.lib.format.read_array(io.BytesIO(z.read(n)), allow_pickle=False)
                      for n in z.namelist() if n.endswith(".npy")}
        _STATE["base"] = meta, arrays
    meta, arrays = _STATE["base"]
    return json.loads(json.dumps(meta)), {k: np.array(v) for k, v in arrays.items()}


def _edit_arrays(op: int, b: _Bytes, meta: dict, arrays: dict) -> None:
    if op == 0:
        name = ("rays", "visits")[b.u8() & 1]
        a = arrays.get(name)
        if a is None or a.dtype.names is None:
            return
        names = a.dtype.names
        field = names[b.u8() % len(names)]
        _set(a, b.u16(), _value(b), field)
    elif op == 1:
        a = arrays.get(OTHER[b.u8() % len(OTHER)])
        if a is not None:
            _set(a, b.u16(), _value(b))
    elif op == 2:
        key, k = META_KEYS[b.u8() % len(META_KEYS)], b.u8()
        if k == 0xff:
            meta.pop(key, None)
        elif k >= 0x80:
            meta[key] = META_VALUES[(k - 0x80) % len(META_VALUES)]
        elif isinstance(meta.get(key), list) and meta[key]:
            meta[key][k % len(meta[key])] = b.u8() - 8     # one element of a list (grid, tiles...)
        else:
            meta[key] = k - 8
    elif op == 3:
        names = sorted(arrays)
        name = names[b.u8() % len(names)] if names else None
        how, n = b.u8() % 8, b.u16()
        if name is None:
            return
        a = arrays[name]
        if how == 0:
            arrays[name] = a[:n % (len(a) + 1)] if a.ndim else a
        elif how == 1 and a.size % 2 == 0 and a.size:
            arrays[name] = a.reshape(2, -1)
        elif how == 2:
            arrays[name] = np.ascontiguousarray(a).view(np.uint8).reshape(-1)
        elif how == 3:
            dt = (np.int8, np.uint16, np.int32, np.int64, np.uint64, np.float32, np.float64, np.bool_)[n % 8]
            arrays[name] = np.zeros(len(a) if a.ndim else 1, dt) if a.dtype.names else a.astype(dt)
        elif how == 4:
            arrays[name] = a[:0]
        elif how == 5 and a.ndim:
            arrays[name] = np.concatenate([a, a])
        elif how == 6:
            del arrays[name]
        elif how == 7 and a.ndim == 1 and len(a):
            arrays[name] = np.ascontiguousarray(a[::-1])


def make_file(data: bytes) -> bytes:
    """The trace file the edits in ``data`` make of the golden trace."""
    from mprt import tracefile

    meta, arrays = base()
    b = _Bytes(data)
    late, keep, bump = [], False, []
    while b.more():
        op = b.u8() % 8
        if op < 4:
            _edit_arrays(op, b, meta, arrays)
        elif op == 4:
            k = b.u8()
            if k & 1:
                keep = True
            else:
                bump.append((k >> 1, b.u8() + 1))
        else:
            late.append((op, b.u8(), b.u16(), b.u8()))
    if not keep:
        old = meta.get("crc32")
        meta["crc32"] = dict(old) if isinstance(old, dict) else {}
        meta["crc32"].update({k: tracefile.typed_crc(a) for k, a in arrays.items()})
    if isinstance(meta.get("crc32"), dict):
        for which, delta in bump:
            keys = sorted(meta["crc32"])
            if keys:
                k = keys[which % len(keys)]
                meta["crc32"][k] = meta["crc32"][k] + delta if isinstance(meta["crc32"][k], int) else delta
    members = {"meta.json": json.dumps(meta, sort_keys=True).encode()}
    for k, a in arrays.items():
        buf = io.BytesIO()
        np.lib.format.write_array(buf, np.ascontiguousarray(a), allow_pickle=False)
        members[k + ".npy"] = buf.getvalue()
    names = sorted(members)
    stored = {n for n in names if n in ("rays.npy", "visits.npy", "samples.npy")}
    for op, which, at, x in late:
        if op == 5:
            n = names[which % len(names)]
            m = bytearray(members[n])
            if m:
                m[at % len(m)] ^= x or 0xff
                members[n] = bytes(m)
        elif op == 6:
            n = names[which % len(names)]
            if at & 1:
                stored.symmetric_difference_update({n})
            else:
                members[f"extra{x}.npy" if at & 2 else n + "x"] = members[n][:x]
                names = sorted(members)
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        for n in names:
            z.writestr(n, members[n], zipfile.ZIP_STORED if n in stored else zipfile.ZIP_DEFLATED)
    f = bytearray(out.getvalue())
    for op, which, at, x in late:
        if op == 7:
            f[(which << 16 | at) % len(f)] ^= x or 0xff
    return bytes(f)


def _remove(path: str) -> None:
    try:
        os.remove(path)
    except OSError:
        pass


def _path() -> str:
    path = _STATE.get("path")
    if path is None:
        fd, path = tempfile.mkstemp(prefix="mprt-fuzz-", suffix=".npz")
        os.close(fd)
        _STATE["path"] = path
        atexit.register(_remove, path)      # (the fuzzer's processes leave nothing in the temporary folder)
    return path


def machines():
    """Level 1 (model M on 2 PEs) and level 3 (the 3MPPE on 2 PEs with small memories that
    miss, behind a ring of 2 buffer classes): small machines, quick on a small trace."""
    if "machines" not in _STATE:
        from mprt.machine import builtin
        from mprt.machine.config import CacheConfig, GlobalMemoryConfig, LocalMemoryConfig, RingConfig

        three = builtin("3mppe").replace(
            pes=2, ring=RingConfig(1, 2), ic_memory=LocalMemoryConfig(64, CacheConfig(256, 16, 2)),
            sc_memory=LocalMemoryConfig(32, None), icgm=GlobalMemoryConfig(7, 3, True),
            scgm=GlobalMemoryConfig(5, 8, False))
        _STATE["machines"] = (builtin("M").replace(pes=2), three)
    return _STATE["machines"]


def _outcome(fn):
    from mprt.errors import MprtError

    try:
        return fn()
    except MprtError as e:
        return e


def _figures(r) -> dict:
    d = r.to_dict()
    d.pop("wall_seconds", None)
    return d


def replay_both(trace) -> None:
    """Both engines on both machines: the same SimResult, or the same error."""
    from mprt.errors import MprtError
    from mprt.fidelity import replay
    from mprt.machine import simulate

    for cfg in machines():
        a = _outcome(lambda: simulate(trace, cfg))
        b = _outcome(lambda: replay(trace, cfg))
        if isinstance(a, MprtError) or isinstance(b, MprtError):
            assert type(a) is type(b) and str(a) == str(b), f"{cfg.name}: simpy {a!r:.300}, compiled {b!r:.300}"
            assert "\n" not in str(a), f"{cfg.name}: an error of more than one line: {a!r:.300}"
        else:
            assert _figures(a) == _figures(b), f"{cfg.name}: simpy {a.cycles} cycles, compiled {b.cycles}"


def one_trace(data: bytes) -> None:
    """Surface 3: a trace file from data (mode byte, then raw file or edits), read, checked,
    its statistics made, and (small enough) replayed on both engines at levels 1 and 3."""
    import mprt
    from mprt.errors import MprtError, TraceError

    if not data:
        return
    mode, rest = data[0], data[1:]
    path = _path()
    with open(path, "wb") as f:
        f.write(make_file(rest) if mode & 1 else rest)
    try:
        trace = mprt.load_trace(path, mmap=bool(mode & 2), invariants=True)    # stats --check
        trace.stats()
    except TraceError as e:
        assert "\n" not in str(e), f"a TraceError of more than one line: {e!r:.300}"
        return
    except MprtError as e:
        raise AssertionError(f"a trace refused with {type(e).__name__}, not TraceError: {e}") from None
    if len(trace.visits) <= VISITS_MAX and len(trace.rays) <= VISITS_MAX:
        replay_both(trace)
