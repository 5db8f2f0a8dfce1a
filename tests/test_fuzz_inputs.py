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
