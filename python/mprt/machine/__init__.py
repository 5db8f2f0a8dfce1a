"""The machine model: a SimPy replay of traces on the 3MPPE and its relatives.

    >>> import mprt
    >>> from mprt.machine import simulate
    >>> trace = mprt.load_trace("tests/data/golden/balls-g9.npz")
    >>> result = simulate(trace, "M")          # or "S", "3mppe", or a SystemConfig
    >>> result.cycles, result.stages["IC"]["processing"]

Parts under the paper's names: Stage, Fifo, Ring, Cache, ResidentMemory,
GlobalMemory, PE, System.  Configurations: SystemConfig (built-ins S, M,
3mppe; TOML files via load_config).  The event semantics are in README.md.
"""
from .config import (BUILTIN, CacheConfig, GlobalMemoryConfig, LocalMemoryConfig, RingConfig, StageConfig,
                     SystemConfig, builtin, check_config, config_from_dict, load_config, make_stage)
from .errors import ConfigError, DeadlockError
from .fifo import Fifo
from .memory import Cache, GlobalMemory, ResidentMemory
from .pe import PE
from .result import SimResult
from .ring import Ring
from .stage import Stage
from .system import System, simulate

__all__ = ["BUILTIN", "CacheConfig", "GlobalMemoryConfig", "LocalMemoryConfig", "RingConfig", "StageConfig",
           "SystemConfig", "builtin", "check_config", "config_from_dict", "load_config", "make_stage", "ConfigError", "DeadlockError",
           "Fifo", "Cache", "GlobalMemory", "ResidentMemory", "PE", "SimResult", "Ring", "Stage", "System",
           "simulate"]
