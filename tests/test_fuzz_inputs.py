"""The Python fuzz target (tests/fuzz/fuzz_inputs.py) replayed on its corpus and on every
input that ever failed: each is accepted or refused with mprt's own one-line error,
never a traceback, and a trace file that passes stats --check replays the same on SimPy
and the compiled replay (issue 19).  The fuzzer itself (Atheris) runs with make fuzz-python."""
from pathlib import Path

import pytest

import sys

sys.path.insert(0, str(Path(__file__).parent / "fuzz"))
from fuzz_inputs import one_input  # noqa: E402

FUZZ = Path(__file__).parent / "fuzz"
INPUTS = sorted(p for d in ("corpus_inputs", "crashes_inputs") for p in (FUZZ / d).iterdir()
                if not p.name.startswith("."))


def test_corpus_is_there():
    kinds = {p.read_bytes()[:1] for p in INPUTS}
    assert {b"\x00", b"\x01", b"\x02", b"\x03"} <= kinds


@pytest.mark.parametrize("path", INPUTS, ids=lambda p: p.name[:12])
def test_replay(path):
    one_input(path.read_bytes())


# ---- findings of the fuzzers, as named tests ---------------------------------------------

def _patched_zip(tmp_path, member, field, value):
    """The small trace with one field of a member's zip headers (central directory, and the
    local header for flags and method) set to value: 'version' needed to extract, 'flags',
    'method' of compression."""
    import zipfile

    import mprt

    data = bytearray((FUZZ / "trace_base.npz").read_bytes())
    with zipfile.ZipFile(FUZZ / "trace_base.npz") as z:
        info = z.getinfo(member)
    central = {"version": 6, "flags": 8, "method": 10}[field]
    local = {"version": 4, "flags": 6, "method": 8}[field]
    at = 0
    while True:
        at = data.index(b"PK\x01\x02", at + 1)
        n = int.from_bytes(data[at + 28:at + 30], "little")
        if data[at + 46:at + 46 + n] == member.encode():
            break
    data[at + central:at + central + 2] = value.to_bytes(2, "little")
    data[info.header_offset + local:info.header_offset + local + 2] = value.to_bytes(2, "little")
    path = tmp_path / "z.npz"
    path.write_bytes(bytes(data))
    with pytest.raises(mprt.TraceError) as e:
        mprt.load_trace(path)
    return str(e.value)


@pytest.mark.parametrize("member", ["meta.json", "visits.npy"])
@pytest.mark.parametrize("field, value", [("version", 251), ("method", 99), ("method", 12), ("method", 14),
                                          ("flags", 1)])
def test_zip_headers_of_another_kind_are_one_line(tmp_path, member, field, value):
    """A member needing a newer zip (Atheris found 'zip file version 25.1' raised as
    NotImplementedError), compressed by an unknown method, by bzip2 or LZMA over deflate
    data, or marked encrypted: one TraceError of one line naming the file."""
    msg = _patched_zip(tmp_path, member, field, value)
    assert "\n" not in msg and "z.npz" in msg, msg


def test_crc32_combine_over_any_length_is_the_operator_squared():
    """crc32_combine with its operators made once (a checksum's signature took about 10 ms a
    member when each call squared them again: Atheris timed out reading small traces) against
    the operator squared per bit of the length, up to 2^63 - 1 bytes."""
    from mprt import tracefile

    def reference(crc1, crc2, len2):
        g = tracefile._gf2_times
        op = [0xEDB88320] + [1 << n for n in range(31)]
        for _ in range(3):
            op = [g(op, v) for v in op]
        while len2:
            if len2 & 1:
                crc1 = g(op, crc1)
            len2 >>= 1
            op = [g(op, v) for v in op]
        return crc1 ^ crc2

    for n in (1, 2, 3, 48, 16688, (1 << 26) + 5, (1 << 40) + 12345, (1 << 63) - 1):
        assert tracefile.crc32_combine(0x12345678, 0x9ABCDEF0, n) == reference(0x12345678, 0x9ABCDEF0, n), n


@pytest.mark.parametrize("rules", [["paper"], {"paper": 1}])
def test_meta_rules_of_another_type_are_one_line(tmp_path, rules):
    """meta.json 'rules' as a list or an object (Atheris found TypeError: unhashable type):
    one TraceError naming the field."""
    import json
    import zipfile

    import mprt

    with zipfile.ZipFile(FUZZ / "trace_base.npz") as z:
        members = {n: z.read(n) for n in z.namelist()}
    meta = json.loads(members["meta.json"])
    meta["rules"] = rules
    members["meta.json"] = json.dumps(meta).encode()
    path = tmp_path / "r.npz"
    with zipfile.ZipFile(path, "w") as z:
        for n, b in members.items():
            z.writestr(n, b)
    with pytest.raises(mprt.TraceError, match=r"^[^\n]*meta.json field 'rules': must be one of [^\n]*$"):
        mprt.load_trace(path)
