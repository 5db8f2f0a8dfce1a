"""One validation of a trace (mprt.tracevalid), run by every reader: issue 19's hostile trace
files each get one TraceError naming the member and the field (exit 1 and one line from the
CLI), in memory bounded by the file's size."""
import functools
import io
import json
import tracemalloc
import zipfile
import zlib

import numpy as np
import pytest

import mprt
from mprt import tracefile, tracevalid
from mprt.cli import main as mprt_main


@functools.cache
def source():
    return mprt.Scene.spd("balls", 1).grid(5).trace(12, 10, tile=4)[1]


def fresh():
    """A copy of the source trace's metadata and arrays (in memory, writable)."""
    t = source()
    return json.loads(json.dumps(t.meta)), {k: np.array(v) for k, v in t.arrays().items()}


def save(path, meta, arrays, compress=None):
    """Written with checksums of what is given: only the validation can refuse it."""
    tracefile.write(path, meta, arrays, compress)
    return path


def members(path):
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist()}


def write_members(path, ms, stored=()):
    with zipfile.ZipFile(path, "w") as z:
        for n, b in ms.items():
            z.writestr(n, b, zipfile.ZIP_STORED if n in stored else zipfile.ZIP_DEFLATED)
    return path


def with_meta(tmp_path, text: bytes):
    ms = members(save(tmp_path / "t.npz", *fresh()))
    return write_members(tmp_path / "m.npz", dict(ms, **{"meta.json": text}))


def one_line_error(path, *words):
    """load_trace raises one TraceError, of one line, holding each of words."""
    with pytest.raises(mprt.TraceError) as e:
        mprt.load_trace(path)
    msg = str(e.value)
    assert "\n" not in msg and len(msg) < 400, msg
    for w in words:
        assert w in msg, msg
    return msg


def edited(tmp_path, member, field, index, value):
    meta, arrays = fresh()
    a = arrays[member]
    if field is None:
        a[index] = value
    else:
        a[field][index] = value
    return save(tmp_path / "e.npz", meta, arrays)


@pytest.mark.parametrize("text, words", [
    (b"null", ["meta.json", "JSON object", "NoneType"]),
    (b"[1, 2]", ["meta.json", "JSON object", "list"]),
    (b"42", ["meta.json", "JSON object", "int"]),
    (b"[" * 100000 + b"]" * 100000, ["meta.json", "nested too deeply"]),
    (b'{"a": ' * 100000 + b"1" + b"}" * 100000, ["meta.json", "nested too deeply"]),
])
def test_meta_that_is_not_an_object_is_one_line(tmp_path, text, words):
    one_line_error(with_meta(tmp_path, text), *words)


@pytest.mark.parametrize("change, words", [
    ({"crc32": None}, ["'crc32'", "JSON object"]),
    ({"width": None}, ["'width'", "integer"]),
    ({"rules": None}, ["'rules'"]),
    ({"grid": [5, 5]}, ["'grid'"]),
    ({"grid": [5, 5, 4]}, ["voxel_gaps", "'grid'"]),
    ({"lights": 10 ** 15}, ["'lights'"]),
    ({"lights": 0}, ["rays field 'light'"]),
    ({"width": 13}, ["'samples_w'"]),
    ({"samples_w": 16}, ["'tiles_total'"]),
    ({"tiles": [0, 0]}, ["'tiles'"]),
    ({"tiles_total": 10 ** 9}, ["'tiles_total'"]),
    ({"threshold": "x"}, ["'threshold'"]),
    ({"max_depth": 0}, ["rays field 'depth'"]),
    ({"stages": ["OS"]}, ["'stages'"]),
])
def test_meta_field_out_of_schema_is_named(tmp_path, change, words):
    meta, arrays = fresh()
    ms = members(save(tmp_path / "t.npz", meta, arrays))
    meta = json.loads(ms["meta.json"])
    meta.update(change)
    one_line_error(write_members(tmp_path / "m.npz", dict(ms, **{"meta.json": json.dumps(meta).encode()})),
                   "meta.json" if "field" not in words[0] and "voxel" not in words[0] else "", *words)


@pytest.mark.parametrize("key", ["width", "rules", "grid", "lights", "tiles"])
def test_meta_missing_a_field_is_named(tmp_path, key):
    meta, arrays = fresh()
    ms = members(save(tmp_path / "t.npz", meta, arrays))
    meta = json.loads(ms["meta.json"])
    del meta[key]
    one_line_error(write_members(tmp_path / "m.npz", dict(ms, **{"meta.json": json.dumps(meta).encode()})),
                   "meta.json", repr(key))


@pytest.mark.parametrize("grid", [[512, 512, 512], [1024, 1024, 1024]])
def test_a_huge_grid_on_a_small_trace_allocates_nothing(tmp_path, grid):
    ms = members(save(tmp_path / "t.npz", *fresh()))
    meta = json.loads(ms["meta.json"])
    meta["grid"] = grid
    path = write_members(tmp_path / "g.npz", dict(ms, **{"meta.json": json.dumps(meta).encode()}))
    tracemalloc.start()
    try:
        one_line_error(path, "'grid'", "voxels")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 << 20


@pytest.mark.parametrize("member, field, index, value, words", [
    ("visits", "steps", 0, 1 << 27, ["visits field 'steps'", str(1 << 27)]),
    ("visits", "steps", 0, (1 << 31) - 1, ["visits field 'steps'"]),
    ("visits", "steps", 0, -1, ["visits field 'steps'"]),
    ("visits", "ray", 3, 1 << 62, ["visits field 'ray'", "record 3"]),
    ("visits", "stage", 3, 7, ["visits field 'stage'", "7"]),
    ("visits", "outcome", 3, 200, ["visits field 'outcome'"]),
    ("visits", "prim", 3, 1 << 30, ["visits field 'prim'"]),
    ("visits", "voxel_id", 3, -5, ["visits field 'voxel_id'"]),
    ("visits", "tests", 3, 1 << 30, ["visits field 'tests'"]),
    ("visits", "vertices", 3, -1, ["visits field 'vertices'"]),
    ("visits", "made", 3, 250, ["visits field 'made'"]),
    ("rays", "kind", 2, 9, ["rays field 'kind'", "record 2"]),
    ("rays", "id", 2, 7, ["rays field 'id'"]),
    ("rays", "parent", 2, 1 << 40, ["rays field 'parent'"]),
    ("rays", "pixel", 2, -3, ["rays field 'pixel'"]),
    ("rays", "light", 2, 300, ["rays field 'light'"]),
    ("rays", "contribution", 2, np.nan, ["rays field 'contribution'"]),
    ("prim_kind", None, 0, 99, ["prim_kind", "99"]),
    ("prim_kind", None, 0, -1, ["prim_kind", "-1"]),
    ("prim_words", None, 0, (1 << 31) - 1, ["prim_words"]),
    ("prim_words", None, 0, 0, ["prim_words"]),
    ("prim_material", None, 0, -1, ["prim_material"]),
    ("voxel_ids", None, 0, 1000, ["voxel_ids"]),
])
def test_record_out_of_range_names_member_and_field(tmp_path, member, field, index, value, words):
    one_line_error(edited(tmp_path, member, field, index, value), *words)


@pytest.mark.parametrize("member, field, index, value", [
    ("visits", "ray", 3, 1 << 62), ("visits", "stage", 3, 7), ("rays", "kind", 2, 9),
    ("prim_kind", None, 0, 99), ("visits", "steps", 0, 1 << 27)])
@pytest.mark.parametrize("command", [["stats", "--check"], ["stats"], ["simulate", "--engine", "simpy"],
                                     ["simulate", "--engine", "compiled"]])
def test_cli_refuses_bad_records_in_one_line(tmp_path, capsys, member, field, index, value, command):
    path = edited(tmp_path, member, field, index, value)
    assert mprt_main([command[0], str(path), *command[1:]]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "error:" in err and (field or member) in err, err


def test_simulate_runs_the_invariant_check(tmp_path, capsys):
    """A trace whose records are each in range but break an invariant (a ray that does not start
    at OS) is refused by simulate as by stats --check."""
    meta, arrays = fresh()
    arrays["visits"]["stage"][0] = 1
    path = save(tmp_path / "i.npz", meta, arrays)
    assert mprt_main(["stats", str(path), "--check"]) == 1
    assert "does not start at OS" in capsys.readouterr().err
    assert mprt_main(["simulate", str(path)]) == 1
    assert "does not start at OS" in capsys.readouterr().err


def test_checksum_covers_shape_and_dtype(tmp_path):
    """visits reshaped (2, -1), or rays seen as bytes, under their old checksums: refused."""
    ms = members(save(tmp_path / "t.npz", *fresh()))
    visits = np.lib.format.read_array(io.BytesIO(ms["visits.npy"]))
    for name, a in (("visits", visits.reshape(2, -1)), ("visits", visits.view(np.uint8))):
        buf = io.BytesIO()
        np.lib.format.write_array(buf, a)
        one_line_error(write_members(tmp_path / "r.npz", dict(ms, **{name + ".npy": buf.getvalue()})),
                       f"'{name}'", "checksum")


def test_version_3_checksums_of_bytes_load_and_shape_is_still_checked(tmp_path):
    """A version 3 file (CRC-32 of the bytes only) loads; reshaped visits with a matching byte
    checksum are refused by the shape check."""
    ms = members(save(tmp_path / "t.npz", *fresh()))
    meta = json.loads(ms["meta.json"])
    arrays = {n[:-4]: np.lib.format.read_array(io.BytesIO(b)) for n, b in ms.items() if n.endswith(".npy")}
    meta["version"] = 3
    meta["crc32"] = {k: tracefile.crc(a) for k, a in arrays.items()}
    v3 = write_members(tmp_path / "v3.npz", dict(ms, **{"meta.json": json.dumps(meta).encode()}))
    back = mprt.load_trace(v3)
    assert back.meta["version"] == tracefile.FORMAT_VERSION and len(back.visits) == len(source().visits)
    buf = io.BytesIO()
    np.lib.format.write_array(buf, arrays["visits"].reshape(2, -1))
    one_line_error(write_members(tmp_path / "r.npz", dict(ms, **{"meta.json": json.dumps(meta).encode(),
                                                                 "visits.npy": buf.getvalue()})),
                   "visits", "shape")


@pytest.mark.parametrize("mmap", [False, True])
def test_every_flipped_byte_of_a_npy_header_is_one_line(tmp_path, mmap):
    """Each byte of the rays' .npy header flipped (a stored member, memory-mapped or read):
    the file loads (a flip in the padding) or raises one TraceError, never another error."""
    meta, arrays = fresh()
    ms = members(save(tmp_path / "t.npz", meta, arrays, compress=False))
    head = ms["rays.npy"]
    hlen = 10 + int.from_bytes(head[8:10], "little") if head[6] == 1 else 12 + int.from_bytes(head[8:12], "little")
    refused = 0
    for i in range(hlen):
        b = bytearray(head)
        b[i] ^= 0x5A if i % 2 else 0x21
        path = write_members(tmp_path / "f.npz", dict(ms, **{"rays.npy": bytes(b)}), stored=("rays.npy",))
        try:
            mprt.load_trace(path, mmap=mmap)
        except mprt.TraceError as e:
            assert "\n" not in str(e) and "'rays'" in str(e)
            refused += 1
    assert refused > hlen // 2


def test_a_npy_header_that_fails_to_tokenize_is_one_line(tmp_path):
    ms = members(save(tmp_path / "t.npz", *fresh(), compress=False))
    head = ms["rays.npy"]
    b = bytearray(head)
    at = head.index(b"'descr'")
    b[at] = ord('"')                    # an unterminated string: tokenize.TokenError inside numpy
    one_line_error(write_members(tmp_path / "f.npz", dict(ms, **{"rays.npy": bytes(b)})), "'rays'", "corrupt")


def test_flipped_bytes_inside_compressed_data_are_one_line(tmp_path):
    """Bytes flipped inside the deflated visits: zlib's error or the zip's CRC, one TraceError."""
    path = save(tmp_path / "t.npz", *fresh(), compress=True)
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as z, open(path, "rb") as f:
        info = z.getinfo("visits.npy")
        start = tracefile._member_offset(f, info)
    for k in range(0, info.compress_size, max(1, info.compress_size // 23)):
        bad = bytearray(data)
        bad[start + k] ^= 0xFF
        (tmp_path / "z.npz").write_bytes(bytes(bad))
        one_line_error(tmp_path / "z.npz", "'visits'")


def test_zlib_error_is_caught():
    """The reader's error list holds zlib's error (what a damaged deflate stream raises)."""
    with pytest.raises(zlib.error):
        zlib.decompress(b"\x78\x9c\xff\xff")
    assert zlib.error in tracefile._NPY_ERRORS


def test_object_dtype_array_is_refused(tmp_path):
    ms = members(save(tmp_path / "t.npz", *fresh()))
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.array([1, "x", None], dtype=object), allow_pickle=True)
    one_line_error(write_members(tmp_path / "o.npz", dict(ms, **{"prim_kind.npy": buf.getvalue()})),
                   "'prim_kind'", "object")
    meta, arrays = fresh()
    arrays["prim_kind"] = np.array([1, "x"], dtype=object)
    with pytest.raises(mprt.TraceError, match="prim_kind: holds Python objects"):
        mprt.Trace.from_arrays(meta, arrays).validate()


def test_python_api_trace_validate_names_the_field():
    """Trace.validate (and check) run the same validation on a trace built in memory."""
    meta, arrays = fresh()
    arrays["visits"]["stage"][5] = 7
    tr = mprt.Trace.from_arrays(meta, arrays)
    with pytest.raises(mprt.TraceError, match="visits field 'stage': record 5 holds 7"):
        tr.validate()
    with pytest.raises(mprt.TraceError, match="visits field 'stage'"):
        tr.check()
    meta, arrays = fresh()
    arrays["visits"] = arrays["visits"].view(np.uint8)
    with pytest.raises(mprt.TraceError, match="visits: has dtype uint8"):
        mprt.Trace.from_arrays(meta, arrays).validate()


def test_valid_traces_pass_in_any_chunk_size():
    meta, arrays = fresh()
    for chunk in (1, 7, 1 << 18):
        tracevalid.validate(meta, arrays, chunk=chunk)
    source().validate()


def test_voxel_budget_grows_with_the_file():
    assert tracevalid.voxel_budget(0) >= 256 ** 3
    assert tracevalid.voxel_budget(10 << 20) > tracevalid.voxel_budget(1 << 20)


@pytest.mark.parametrize("field, value", [("voxel_id", (1 << 32) - 1), ("voxel_id", -(1 << 32) - 1),
                                          ("ray", 1 << 32), ("ray", -1), ("suppressed", 255), ("outcome", 9)])
@pytest.mark.parametrize("fast", [True, False])
def test_visit_ranges_fast_and_field_by_field_agree(monkeypatch, field, value, fast):
    """The block check on 32-bit words and the check field by field refuse the same values
    (those that hide in one half of a 64-bit field too) with the same message."""
    if not fast:
        monkeypatch.setattr(tracevalid._VisitBounds, "usable", staticmethod(lambda n: False))
    meta, arrays = fresh()
    arrays["visits"][field][len(arrays["visits"]) // 2] = value
    with pytest.raises(mprt.TraceError, match=f"visits field '{field}': record {len(arrays['visits']) // 2} "):
        tracevalid.validate(meta, arrays, chunk=1000)


def test_a_member_claiming_a_huge_size_allocates_nothing(tmp_path):
    """A deflated member whose zip directory claims 2 GB: refused before reading, in one line."""
    path = save(tmp_path / "t.npz", *fresh(), compress=True)
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as z:
        info = z.getinfo("visits.npy")
    at = 0
    while True:                         # the visits' central directory entry
        at = data.index(b"PK\x01\x02", at + 1)
        name_len = int.from_bytes(data[at + 28:at + 30], "little")
        if data[at + 46:at + 46 + name_len] == b"visits.npy":
            break
    assert int.from_bytes(data[at + 24:at + 28], "little") == info.file_size
    data[at + 24:at + 28] = (1 << 31).to_bytes(4, "little")
    (tmp_path / "h.npz").write_bytes(bytes(data))
    tracemalloc.start()
    try:
        one_line_error(tmp_path / "h.npz", "'visits'")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 64 << 20
