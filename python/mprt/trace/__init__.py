"""The trace: every stage visit of every ray, the contract between the tracer and the machine models.

- ``tracing``: ``trace(grid, ...) -> (image, Trace)`` (and ``Grid.trace``): tiles, samples, threads;
  ``sampling``: the ``--sample`` grammar and the tiles a sample traces;
- ``core``: ``Trace``, ``load_trace``, the record enums (``Stage``, ``Outcome``, ``RayKind``) and dtypes;
- ``tracefile``: the ``.npz`` file format; ``tracewriter``: a file written while tracing;
- ``tracevalid``: the one validation every reader runs; ``tracecheck`` and ``recordcheck``
  (in C): the invariants; ``stats``: the paper's statistics of a trace.

The format is described in this folder's README.md.
"""
from .core import (ARRAYS, BLOCKED, FORMAT_VERSION, HIT, IC, KINDS, LATE_HIT, LEFT, LIT, OS, OUTCOMES, PRIMARY,
                   RAY_DTYPE, RAY_KINDS, REFLECT, REFRACT, RETURN, SC, SHADED, SHADOW, STAGES, TO_IC, TO_SC,
                   VISIT_DTYPE, Outcome, RayKind, Stage, Trace, TraceError, load_trace)
from .stats import trace_stats
from .tracing import Sampling, release_buffers, trace

__all__ = ["ARRAYS", "BLOCKED", "FORMAT_VERSION", "HIT", "IC", "KINDS", "LATE_HIT", "LEFT", "LIT", "OS", "OUTCOMES",
           "PRIMARY", "RAY_DTYPE", "RAY_KINDS", "REFLECT", "REFRACT", "RETURN", "SC", "SHADED", "SHADOW", "STAGES",
           "TO_IC", "TO_SC", "VISIT_DTYPE", "Outcome", "RayKind", "Sampling", "Stage", "Trace", "TraceError",
           "load_trace", "release_buffers", "trace", "trace_stats"]
