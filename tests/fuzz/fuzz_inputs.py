"""fuzz_inputs.py: the Python input surfaces under a coverage-guided fuzzer (Atheris).

One target, the first byte choosing the surface, the rest its text:
  0  a machine configuration (TOML) -> load_config; a valid one is replayed by the
     compiled engine on a small golden trace;
  1  a design space (TOML) -> parse_space, and its first design built and costed;
  2  a sweep spec (TOML) -> load_spec;
  3  a trace file (raw, or edits to a small golden trace: fuzz_trace.py) -> load_trace with
     the invariant check and the statistics (stats --check), then, when small, both engines
     (SimPy and the compiled replay) at levels 1 and 3, which must agree.
Each may refuse its input with its own one-line error (ConfigError, SpaceError, TraceError,
and their MprtError / ValueError bases); anything else (a traceback: KeyError, TypeError,
OverflowError, RecursionError, MemoryError..., or engines that disagree) is a finding.

    pip install atheris
    python tests/fuzz/fuzz_inputs.py -atheris_runs=100000 tests/fuzz/corpus_inputs   # make fuzz-python

``tests/test_fuzz_inputs.py`` replays tests/fuzz/corpus_inputs and crashes_inputs through
``one_input`` in the normal test suite (no Atheris needed)."""
from __future__ import annotations

import atexit
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
TRACE = os.path.join(HERE, "..", "data", "golden", "tetra-g4.npz")
_STATE: dict = {}


def _expected():
    from mprt.errors import MprtError
    from mprt.explore import SpaceError
    from mprt.machine import ConfigError
    return (ConfigError, SpaceError, MprtError)


def _remove(path: str) -> None:
    try:
        os.remove(path)
    except OSError:
        pass


def _file(text: bytes) -> str:
    """The input as a file (load_config and load_spec read paths); one per process."""
    path = _STATE.get("path")
    if path is None:
        fd, path = tempfile.mkstemp(prefix="mprt-fuzz-", suffix=".toml")
        os.close(fd)
        _STATE["path"] = path
        atexit.register(_remove, path)      # (the fuzzer's processes leave nothing in the temporary folder)
    with open(path, "wb") as f:
        f.write(text)
    return path


def _compiled():
    if "compiled" not in _STATE:
        import mprt
        from mprt.fidelity.compiled import Compiled, costs_for
        from mprt.machine import builtin

        trace = mprt.load_trace(TRACE)
        _STATE["trace"] = trace
        _STATE["costs"] = {}
        _STATE["compiled"] = (Compiled, costs_for, builtin)
    return _STATE["compiled"]


def _replay(cfg) -> None:
    from mprt.fidelity.compiled import unsupported
    from mprt.machine import DeadlockError

    Compiled, costs_for, _ = _compiled()
    if unsupported(cfg):
        return
    trace = _STATE["trace"]
    key = tuple(sorted((k, repr(v)) for k, v in cfg.processors().items()))
    if key not in _STATE["costs"]:
        _STATE["costs"][key] = costs_for(trace, cfg)
    try:
        Compiled(trace, _STATE["costs"][key]).cycles(cfg)
    except DeadlockError:
        pass


def one_input(data: bytes) -> None:
    if not data:
        return
    which, text = data[0] % 4, data[1:]
    if which == 3:
        from fuzz_trace import one_trace
        one_trace(text)
        return
    try:
        if which == 0:
            from mprt.machine import load_config
            _replay(load_config(_file(text)))
        elif which == 1:
            from mprt.explore.space import parse_space
            try:
                source = text.decode("utf-8")
            except UnicodeDecodeError:
                return
            space = parse_space(source, "fuzz.toml")
            space.count()
        else:
            from mprt.explore.sweep import load_spec
            load_spec(_file(text))
    except _expected():
        return


def main(argv) -> None:
    import atheris

    # mprt and the parsers it hands hostile bytes to (not numpy, SimPy...: instrumented,
    # they would slow every run several times for coverage that is not mprt's)
    with atheris.instrument_imports(include=["mprt", "zipfile", "tomllib"]):
        import tomllib  # noqa: F401
        import zipfile  # noqa: F401

        import mprt  # noqa: F401
        import mprt.explore  # noqa: F401
        import mprt.fidelity.compiled  # noqa: F401
        import mprt.machine  # noqa: F401
        import mprt.stats  # noqa: F401
        import mprt.tracecheck  # noqa: F401
        import mprt.tracefile  # noqa: F401
        import mprt.tracevalid  # noqa: F401
    one_input(b"\x03\x01")   # warm: the cost model's kernel schedules, the engines, the checksums
    atheris.Setup(argv, one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main(sys.argv)
