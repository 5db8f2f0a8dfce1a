"""mprt: explore the design of the Nesshisen 3MPRT ray-tracing machine.

The C library (bound here with cffi) loads NFF scenes and generates Haines'
SPD scenes, builds a uniform voxel grid, and traces rays through the three
stages of the paper's macropipeline: object search (OS, the 3DDDA walk),
intersection calculation (IC) and shading calculation (SC).

    >>> import mprt
    >>> scene = mprt.Scene.spd("balls", size=1)
    >>> grid = scene.grid(16)
    >>> image, counters = grid.render(width=64, height=64)
    >>> image, trace = grid.trace(32, 32)

The package is built in layers, each module importing only those before it
(tests/test_layers.py checks the order): _lowlevel (the C calls), errors,
scene, grid, tracefile, tracecheck, stats, trace, tracing, then the models
and the command line.
"""
from __future__ import annotations

from . import tracing
from ._lowlevel import EXT_VERSION, KINDS, Kind, Outcome, RayKind, Rules, Stage
from .errors import InvalidArgument, MprtError, SceneParseError, SceneStateError, TraceError, WorkLimitError
from .grid import Grid, write_png
from .scene import SPD_DEFAULT_SIZES, SPD_SCENES, Scene
from .trace import Trace, load_trace

__version__ = EXT_VERSION

# The package's version, as pyproject.toml has it (tests/test_setup.py checks that they agree).
# The compiled extension must be of the same: Python sources updated over an extension built
# before them are refused here (compared with this constant rather than the installed package's
# metadata, whose reading, importlib.metadata, cost every command 40-80 ms).
PACKAGE_VERSION = "0.1.0"
if PACKAGE_VERSION != __version__:
    raise ImportError(
        f"mprt: the compiled extension is version {__version__} but the package is {PACKAGE_VERSION}; "
        "rebuild with 'pip install -e .' (make install)"
    )

__all__ = [
    "KINDS",
    "SPD_DEFAULT_SIZES",
    "SPD_SCENES",
    "Grid",
    "InvalidArgument",
    "Kind",
    "MprtError",
    "Outcome",
    "RayKind",
    "Rules",
    "Scene",
    "SceneParseError",
    "SceneStateError",
    "Stage",
    "Trace",
    "TraceError",
    "WorkLimitError",
    "load_trace",
    "tracing",
    "write_png",
]
