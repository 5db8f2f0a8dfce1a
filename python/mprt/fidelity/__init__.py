"""The fidelity ladder: cheaper ways to the machine model's answer, and how wrong each is.

    level 0  analytical: stage loads and critical paths of the costed trace (numpy)
    level 1  ideal network and memory, replayed exactly by the compiled replay (C)
    level 2  the ring and finite FIFOs, replayed exactly by the compiled replay too
    level 3  caches, resident and global memories, replayed exactly by the compiled replay too

    >>> import mprt
    >>> from mprt.fidelity import evaluate, measure, replay
    >>> trace = mprt.load_trace("tests/data/golden/balls-g9.npz")
    >>> replay(trace, "M").cycles                       # the SimPy model's cycles, to the cycle
    >>> evaluate(trace, "3mppe", level=1).cycles        # 3mppe without ring and memories
    >>> table = measure(trace, ["M", "3mppe"], sample=None)
    >>> table.choose(0.05)                              # cheapest level within 5%

Sampled replay (``sampled.py``) replays a sample of the frame's tiles and scales
up with a 95% interval.  See README.md.
"""
from .analytical import Analytical, Estimate
from .compiled import Compiled, replay, unsupported
from .ladder import Row, Table, choose, measure
from .levels import ENGINES, LEVELS, Evaluation, Evaluator, at_level, engine_for, evaluate, native_level
from .sampled import SampledTrace, Sampling, Scaled, sample_trace, trace_sample

__all__ = ["Analytical", "Estimate", "Compiled", "replay", "unsupported", "Row", "Table", "choose", "measure",
           "ENGINES", "LEVELS", "Evaluation", "Evaluator", "at_level", "engine_for", "evaluate", "native_level",
           "SampledTrace", "Sampling", "Scaled", "sample_trace", "trace_sample"]
