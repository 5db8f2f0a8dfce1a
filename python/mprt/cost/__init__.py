"""The cost model: kernels as operation graphs, list-scheduled on processor
configurations, turning a trace's visits into cycles; calibrated against the
paper's per-unit averages.

    >>> from mprt.cost import CostModel, ProcessorConfig
    >>> cm = CostModel.default()
    >>> cm.kernel_cycles("os_step", ProcessorConfig.sequential())    # doctest: +SKIP
    >>> vc = cm.visit_costs(trace, {s: ProcessorConfig.paper(s) for s in ("OS", "IC", "SC")})  # doctest: +SKIP
    >>> fast = cm.counted(trace)     # the same costs, each processor set priced in milliseconds  # doctest: +SKIP
"""
from .errors import CostModelError
from .counts import CountedCostModel, KernelCounts
from .kernels import KERNELS, OP_CLASSES, Graph
from .model import CostModel, VisitCosts
from .packets import packet_flits
from .schedule import UNIT_KINDS, ProcessorConfig

__all__ = ["CostModel", "CostModelError", "CountedCostModel", "KernelCounts", "Graph", "KERNELS", "OP_CLASSES",
           "ProcessorConfig", "UNIT_KINDS", "VisitCosts", "packet_flits"]
