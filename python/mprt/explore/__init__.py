"""The design-space explorer: which machine renders a scene fastest for a
hardware budget, and which voxel subdivision to use (see README.md here)."""
from .space import (Design, Point, Space, SpaceError, base_design, default_space, load_space, parse_space, model_m,
                    model_s, paper_3mppe)
from .hwcost import UnitCosts, cost_breakdown, hardware_cost
from .evaluate import Result, TraceEvaluator, evaluate

__all__ = ["Design", "Point", "Space", "SpaceError", "default_space", "load_space", "parse_space", "model_m",
           "model_s", "base_design", "paper_3mppe", "UnitCosts", "cost_breakdown", "hardware_cost", "TraceEvaluator", "Result",
           "evaluate"]
