"""Levels 1 and up: a design replayed on the SimPy machine model (``mprt.machine``)."""
from __future__ import annotations


class LevelUnavailable(RuntimeError):
    """The fidelity level asked for needs a part of mprt that is not installed."""


def simulate(trace, design, level, unit_costs):
    try:
        from .. import machine  # noqa: F401
    except ImportError:
        raise LevelUnavailable(f"level {level} needs the machine model (mprt.machine), which this build lacks; "
                               "use level 0") from None
    raise LevelUnavailable(f"level {level}: the machine model's configuration is not wired to the explorer yet")
