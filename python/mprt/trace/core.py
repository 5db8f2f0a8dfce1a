"""Per-ray cost traces of the 3MPRT stages: the records, their enums and ``Trace``.

A trace is the contract between the tracer and every machine model: what each
ray did (voxels walked, tests made, what it hit, which rays it spawned) does
not depend on timing, so one trace serves every machine configuration.
Machine models take a ``Trace``, never a grid.

``rays`` and ``visits`` are numpy structured arrays with the layout of the C
records (``RAY_DTYPE``: ``mprt_trace_ray``, ``VISIT_DTYPE``:
``mprt_trace_visit``); ``kind``, ``stage`` and ``outcome`` hold ``RayKind``,
``Stage`` and ``Outcome`` values.  Ray ids are global: tiles are traced
independently and numbered in tile order, so a trace is the same bits
whatever the thread count.  The visits are grouped by ray, each ray's visits
in order.  A trace also carries what a machine model needs without the scene:
the grid's voxel lists (CSR), each primitive's kind, size in words and
material, the samples, and the settings that made it (``meta``).

Make one with ``grid.trace(...)`` (``mprt.tracing``); read one with
``load_trace``.
"""
from __future__ import annotations

import dataclasses
import os

import numpy as np

from . import stats as _stats
from . import tracecheck, tracefile, tracevalid
from .._lowlevel import KINDS, RAY_DTYPE, RULES, VISIT_DTYPE, Outcome, RayKind, Stage, binding
from ..errors import TraceError
from .tracefile import ARRAYS, FORMAT_VERSION

__all__ = ["Trace", "load_trace", "RAY_DTYPE", "VISIT_DTYPE", "Stage", "Outcome", "RayKind", "KINDS", "ARRAYS",
           "FORMAT_VERSION", "TraceError", "STAGES", "OUTCOMES", "RAY_KINDS"]

# names as they appear in a trace's meta and in messages
STAGES = tuple(s.name for s in Stage)                  # "OS", "IC", "SC"
OUTCOMES = tuple(o.name.lower() for o in Outcome)      # "to_ic", "left", ...
RAY_KINDS = tuple(k.name.lower() for k in RayKind)     # "primary", "reflect", "refract", "shadow"

# the members as plain module names, for short expressions over the arrays
OS, IC, SC = Stage
PRIMARY, REFLECT, REFRACT, SHADOW = RayKind
TO_IC, LEFT, TO_SC, HIT, BLOCKED, RETURN, SHADED, LIT, LATE_HIT = Outcome


@dataclasses.dataclass(eq=False)
class Trace:
    """A trace: rays, visits, voxel lists, primitive table, samples and metadata.

    Arrays may be memory-mapped (a loaded or streamed trace); ``path`` is the
    file the trace lives in, if any."""

    meta: dict
    rays: np.ndarray            # RAY_DTYPE, one per ray, in id order
    visits: np.ndarray          # VISIT_DTYPE, grouped by ray
    voxel_start: np.ndarray     # uint32[voxels + 1]: voxel v lists voxel_ids[voxel_start[v]:voxel_start[v + 1]]
    voxel_ids: np.ndarray       # int32 primitive ids
    prim_kind: np.ndarray       # int32 Kind per primitive id
    prim_words: np.ndarray      # int32 shape data size in 32-bit words per primitive id
    prim_material: np.ndarray   # int32 material index per primitive id
    samples: np.ndarray         # float64 (samples_h, samples_w, 3); NaN outside the traced tiles
    path: str | None = None

    @classmethod
    def from_arrays(cls, meta: dict, arrays: dict, path=None) -> "Trace":
        """A trace from its metadata and a dict holding every array of ``ARRAYS``."""
        missing = [k for k in ARRAYS if k not in arrays]
        if missing:
            raise TraceError(f"trace arrays missing: {', '.join(missing)}")
        return cls(meta, **{k: arrays[k] for k in ARRAYS}, path=None if path is None else os.fspath(path))

    def arrays(self) -> dict:
        """Every array of ``ARRAYS`` by name."""
        return {k: getattr(self, k) for k in ARRAYS}

    def __repr__(self) -> str:
        m = self.meta
        return (f"<Trace {m.get('scene')} grid {m.get('grid')} {m.get('width')}x{m.get('height')} "
                f"{m.get('rules')}: {len(self.rays)} rays, {len(self.visits)} visits>")

    @property
    def image(self) -> np.ndarray:
        """The traced pixels, reconstructed from the samples as the renderer does."""
        return binding(self.meta.get("precision", "double")).samples_to_image(RULES[self.meta["rules"]],
                                                                              self.samples)

    def save(self, path, compress: bool | None = None) -> None:
        """Write the trace as .npz with its format version and checksums.  The records are
        deflate-compressed when ``compress``, stored (to be memory-mapped) when False, and by
        default compressed unless large (``tracefile.AUTO_COMPRESS_BYTES``)."""
        self.meta = tracefile.write(path, self.meta, self.arrays(), compress)
        self.path = os.fspath(path)

    def validate(self, invariants: bool = True) -> None:
        """The one validation every reader runs (``mprt.tracevalid``): the metadata against its
        schema, each array's dtype, shape and ranges, then (``invariants``) the invariants
        between records (``mprt.tracecheck``), all in bounded memory; raise TraceError naming
        the member and the field of the first fault."""
        found = tracevalid.validate(self.meta, self.arrays(), invariants=invariants)
        tracevalid.mark_checked(self)
        if invariants:
            tracecheck.settle(self, found)

    def check(self) -> dict:
        """Validate the trace (``validate``: schema, ranges and invariants); raise TraceError
        naming the first fault.  Returns the statistics."""
        self.validate()
        return self.stats()

    def stats(self) -> dict:
        """The paper's table rows for this trace, tests by kind and per-ray distributions."""
        return _stats.trace_stats(self)


def load_trace(path, mmap: bool | None = None, verify: bool = True, invariants: bool = False,
               memory_keys: bool = False) -> Trace:
    """Read a trace saved by Trace.save or streamed by trace(); checks the
    format version, that every array is present and whole, (``verify``) the
    checksums, and the metadata and arrays (``mprt.tracevalid``: one TraceError
    naming the member and the field), then (``invariants``) the invariants
    (``mprt.tracecheck``).  Uncompressed traces are memory-mapped (``mmap``; default:
    when the file is over 256 MB), so a trace of any size opens in bounded
    memory.  ``memory_keys``: level 3's per-visit memory keys made in the same pass as the
    checks (kept as ``trace.memory_keys``: (keys, voxel_refs, material_refs), for
    ``fidelity.memdata``; absent where they were not made there)."""
    keys = {} if memory_keys else None
    meta, arrays = tracefile.read(path, mmap, verify, invariants, keys)   # (the invariants in the same pass)
    trace = Trace.from_arrays(meta, arrays, path)
    tracevalid.mark_checked(trace)      # tracefile.read ran tracevalid's checks
    if keys and "keys" in keys:
        trace.memory_keys = (keys["keys"], keys["voxel_refs"], keys["material_refs"])
    return trace
