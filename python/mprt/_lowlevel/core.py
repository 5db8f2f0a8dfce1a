"""The binding layer's ground: the compiled extensions, what their header defines, and the
plumbing every wrapper shares.

The enums (``Status``, ``Kind``, ``Rules``, ``Stage``, ``RayKind``, ``Outcome``), the status
codes' exceptions, the trace and replay records' numpy layout (``RAY_DTYPE``, ``VISIT_DTYPE``,
``REPLAY_*_DTYPE``, built from the C structs' fields and offsets), the conversion of arguments,
and ``Calls``, the base of every group of wrappers: a build's ffi and lib, its status text,
the check of a status and of every buffer handed to C.
"""
from __future__ import annotations

import enum

import numpy as np

from .. import _mprt, _mprt32
from ..errors import CapacityError, InvalidArgument, MprtError, SceneParseError, SceneStateError, WorkLimitError

_FFI = _mprt.ffi


def _enum(name: str, ctype: str, prefix: str, skip=()) -> type[enum.IntEnum]:
    """An IntEnum of the header's enum ``ctype``: members named without ``prefix``, in value order
    (its module the package, mprt._lowlevel, where callers import it from)."""
    members = sorted((value, cname[len(prefix):]) for cname, value in _FFI.typeof(ctype).relements.items()
                     if cname.startswith(prefix) and cname not in skip)
    return enum.IntEnum(name, [(n, v) for v, n in members], module=__package__)


Status = _enum("Status", "mprt_status", "MPRT_")
Kind = _enum("Kind", "mprt_kind", "MPRT_", skip=("MPRT_NKINDS",))
Rules = _enum("Rules", "mprt_rules", "MPRT_RULES_")
Stage = _enum("Stage", "mprt_stage", "MPRT_STAGE_")
RayKind = _enum("RayKind", "mprt_ray_kind", "MPRT_RAY_")
Outcome = _enum("Outcome", "mprt_outcome", "MPRT_OUT_")
if len(Kind) != _mprt.lib.MPRT_NKINDS or [k.value for k in Kind] != list(range(len(Kind))):
    raise ImportError("mprt_kind is not 0..MPRT_NKINDS-1 in the header")

KINDS = tuple(k.name.lower() for k in Kind)     # "sphere", "polygon", "cylinder", "cone"
RULES = {r.name.lower(): r for r in Rules}      # "paper", "spd"

_ERRORS = {
    Status.ERR_INVALID_ARG: InvalidArgument,
    Status.ERR_PARSE: SceneParseError,
    Status.ERR_STATE: SceneStateError,
    Status.ERR_CAPACITY: CapacityError,
    Status.ERR_OUT_OF_MEMORY: MemoryError,
    Status.ERR_IO: OSError,
    Status.ERR_LIMIT: WorkLimitError,
}


def error_class(status: int) -> type[Exception]:
    """The exception raised for a failed status code."""
    return _ERRORS.get(status, MprtError)


# ---- trace records: numpy views of the C structs ------------------------------------------

_NUMPY_OF_C = {"int64_t": "<i8", "int32_t": "<i4", "int16_t": "<i2", "uint8_t": "u1", "uint32_t": "<u4",
               "double": "<f8"}


def _record_dtype(ffi, ctype: str) -> np.dtype:
    names, formats, offsets = [], [], []
    for name, field in ffi.typeof(ctype).fields:
        t = field.type
        names.append(name)
        offsets.append(field.offset)
        formats.append((_NUMPY_OF_C[t.item.cname], (t.length,)) if t.kind == "array" else _NUMPY_OF_C[t.cname])
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": ffi.sizeof(ctype)},
                    align=True)


RAY_DTYPE = _record_dtype(_FFI, "mprt_trace_ray")
VISIT_DTYPE = _record_dtype(_FFI, "mprt_trace_visit")
REPLAY_PROC_DTYPE = _record_dtype(_FFI, "mprt_replay_proc")
REPLAY_NODE_DTYPE = _record_dtype(_FFI, "mprt_replay_node")
REPLAY_PE_DTYPE = _record_dtype(_FFI, "mprt_replay_pe")
REPLAY_MEMORY_DTYPE = _record_dtype(_FFI, "mprt_replay_memory")
# What each C element type of a buffer argument is in numpy (Binding._buffer checks it).
_CTYPE_DTYPES = {"double": np.dtype(np.float64), "float": np.dtype(np.float32), "int32_t": np.dtype(np.int32),
                 "int": np.dtype(f"i{_FFI.sizeof('int')}"),
                 "int64_t": np.dtype(np.int64), "uint32_t": np.dtype(np.uint32), "mprt_trace_ray": RAY_DTYPE,
                 "mprt_trace_visit": VISIT_DTYPE, "mprt_replay_proc": REPLAY_PROC_DTYPE,
                 "mprt_replay_node": REPLAY_NODE_DTYPE, "mprt_replay_pe": REPLAY_PE_DTYPE,
                 "mprt_replay_memory": REPLAY_MEMORY_DTYPE}
for _ctype, _dt in (("mprt_trace_ray", RAY_DTYPE), ("mprt_trace_visit", VISIT_DTYPE)):
    if _record_dtype(_mprt32.ffi, _ctype) != _dt:
        raise ImportError(f"{_ctype} differs between the double and the single build")


# ---- argument conversion ---------------------------------------------------------------------

def _plain(a, dtype) -> np.ndarray:
    """``a`` as a C-contiguous, aligned array of ``dtype`` (a copy only when needed): a member
    memory-mapped from a trace file lies at any offset, and C reads plain arrays in place."""
    return np.require(a, dtype, ("C", "A"))


def vec3(name: str, value) -> np.ndarray:
    """Three doubles, or InvalidArgument naming the argument."""
    a = _plain(value, np.float64).reshape(-1)
    if a.shape != (3,):
        raise InvalidArgument(f"{name}: expected 3 numbers, got {a.size}")
    return a


def points(name: str, value) -> np.ndarray:
    """An (n, 3) array of doubles, or InvalidArgument naming the argument."""
    a = _plain(value, np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InvalidArgument(f"{name} must have shape (n, 3), not {a.shape}")
    return a


def _struct_dict(ffi, cdata, ctype: str) -> dict:
    """A C struct's fields by name (arrays as lists)."""
    return {name: list(getattr(cdata, name)) if f.type.kind == "array" else getattr(cdata, name)
            for name, f in ffi.typeof(ctype).fields}


class Calls:
    """A build of the library, and what its wrappers share: each group of C calls (scene, grid,
    records, replay) is a subclass, and ``mprt._lowlevel.Binding`` joins them."""

    def __init__(self, ext, precision: str):
        self.ffi, self.lib = ext.ffi, ext.lib
        self.precision = precision
        self.version = self.ffi.string(self.lib.mprt_ext_version()).decode()

    # -- status ------------------------------------------------------------------------
    def status_str(self, status: int) -> str:
        return self.ffi.string(self.lib.mprt_status_str(status)).decode()

    def _text(self, ptr) -> str:
        return "" if ptr == self.ffi.NULL else self.ffi.string(ptr).decode(errors="replace")

    def _check(self, rc: int, errmsg, handle) -> None:
        """Raise the status's exception with the handle's message (read after the call)."""
        if rc != Status.OK:
            raise error_class(rc)(self._text(errmsg(handle)) or self.status_str(rc))

    def _buffer(self, ctype: str, a, n, writable: bool):
        """A typed view of a for C, after checking what C will do with it: a numpy array of
        ctype's exact dtype, C-contiguous (writable for outputs), holding at least n elements
        of ctype (None: C is told a's own size).  Anything else is InvalidArgument, so no
        caller can make C read or write past a buffer."""
        want = _CTYPE_DTYPES[ctype]
        if not isinstance(a, np.ndarray):
            raise InvalidArgument(f"{ctype} buffer: expected a numpy array, not {type(a).__name__}")
        if a.dtype != want:
            raise InvalidArgument(f"{ctype} buffer: dtype {a.dtype} is not {want} (C reads {ctype} records)")
        if not a.flags.c_contiguous:
            raise InvalidArgument(f"{ctype} buffer: the array is not C-contiguous")
        if writable and not a.flags.writeable:
            raise InvalidArgument(f"{ctype} buffer: the array is read-only, and C writes into it")
        if n is not None and (int(n) < 0 or a.size < int(n)):
            raise InvalidArgument(f"{ctype} buffer: holds {a.size} elements, C {'writes' if writable else 'reads'} {int(n)}")
        return self.ffi.from_buffer(ctype + "[]", a, require_writable=writable)

    def _in(self, ctype: str, a: np.ndarray, n=None):
        return self._buffer(ctype, a, n, False)

    def _out(self, ctype: str, a: np.ndarray, n=None):
        return self._buffer(ctype, a, n, True)

    @staticmethod
    def _records(name: str, a, dtype: np.dtype) -> np.ndarray:
        """A one-dimensional array of records of dtype (C takes its length as the count)."""
        if not isinstance(a, np.ndarray) or a.ndim != 1:
            raise InvalidArgument(f"{name} must be a one-dimensional numpy array of records, not "
                                  f"{getattr(a, 'shape', type(a).__name__)}")
        if a.dtype != dtype:
            raise InvalidArgument(f"{name}: dtype {a.dtype} is not the C library's record {dtype}")
        return a

    def _struct(self, ctype: str, init, fields: dict, what: str):
        """A new C struct of type ``ctype``, set to its defaults by ``init`` then field by field
        from ``fields``; a field it does not have, or a value that does not fit, is an
        InvalidArgument naming ``what`` and the field."""
        d = self.ffi.new(ctype + " *")
        init(d)
        for k, v in fields.items():
            try:
                setattr(d, k, v)
            except AttributeError:
                raise InvalidArgument(f"{what} has no field {k!r}") from None
            except (TypeError, OverflowError, IndexError) as e:
                raise InvalidArgument(f"{what} field {k!r}: {e}") from None
        return d
