"""The binding layer: the only package that imports the compiled extensions.

A ``Binding`` wraps one build of the C library (``double``: ``mprt._mprt``;
``single``: ``mprt._mprt32``, float geometry) with one method per C call.
Each method turns its arguments into C buffers (numpy arrays handed over
without copies by a typed ``ffi.from_buffer``, which keeps them alive for the
call), makes the call, and turns a failed status into the matching exception
of ``mprt.errors`` carrying the library's own message.  Nothing from cffi
leaves this package but opaque handles, which callers only hand back.

Everything the header defines is read from it, never written again here:
the enums (``Status``, ``Kind``, ``Rules``, ``Stage``, ``RayKind``,
``Outcome``), the render description's fields and defaults, the counters'
names, and the trace records' numpy layout (``RAY_DTYPE``, ``VISIT_DTYPE``,
built from the C structs' fields and offsets).

Its modules, by the C units they bind: ``core`` (the extensions, enums,
errors, record dtypes, argument conversion, the checks every call shares),
``scene``, ``grid`` (grid, render, tiles traced, images), ``records`` (the
records' costs, memory keys, CRC-32, shift) and ``replay``.  Callers import
from the package, ``mprt._lowlevel``, never from its modules.
"""
from __future__ import annotations

from .. import _mprt, _mprt32
from ..errors import InvalidArgument
from .core import (KINDS, RAY_DTYPE, REPLAY_MEMORY_DTYPE, REPLAY_NODE_DTYPE, REPLAY_PE_DTYPE, REPLAY_PROC_DTYPE,
                   RULES, VISIT_DTYPE, Kind, Outcome, RayKind, Rules, Stage, Status, error_class, points, vec3)
from .grid import GridCalls
from .records import RecordCalls
from .replay import ReplayCalls
from .scene import SceneCalls

__all__ = ["Binding", "EXT_VERSION", "KINDS", "PRECISIONS", "RAY_DTYPE", "REPLAY_MEMORY_DTYPE", "REPLAY_NODE_DTYPE",
           "REPLAY_PE_DTYPE", "REPLAY_PROC_DTYPE", "RULES", "VISIT_DTYPE", "Kind", "Outcome", "RayKind", "Rules",
           "Stage", "Status", "binding", "error_class", "points", "vec3"]


class Binding(SceneCalls, GridCalls, RecordCalls, ReplayCalls):
    """One build of the library; one method per C function."""


_BINDINGS = {"double": Binding(_mprt, "double"), "single": Binding(_mprt32, "single")}
PRECISIONS = tuple(_BINDINGS)
EXT_VERSION = _BINDINGS["double"].version


def binding(precision: str = "double") -> Binding:
    """The build of the library for ``precision`` ('double' or 'single')."""
    try:
        return _BINDINGS[precision]
    except (KeyError, TypeError):
        raise InvalidArgument(f"precision must be 'double' or 'single', not {precision!r}") from None
