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

The package is built in layers, each importing only those below it
(tests/test_layers.py checks the order): errors and util/ (atomic outputs,
paged arrays, figures), _lowlevel (the C calls), scene, grid, trace/ (recording,
the file format, validation, invariants, statistics), settings and
memory_estimate, then the models (cost/, machine/, fidelity/, explore/), and
last cli/, the ``mprt`` command, which nothing in the library imports.  The
modules' former paths (``mprt.tracefile``, ``mprt.options``, ...) still import
(``_aliases``).
"""
from __future__ import annotations

from . import _aliases

_aliases.install()

from .trace import tracing  # noqa: E402
from . import settings  # noqa: E402,F401 (mprt.settings)
from ._lowlevel import EXT_VERSION, KINDS, Kind, Outcome, RayKind, Rules, Stage  # noqa: E402
from .errors import InvalidArgument, MprtError, SceneParseError, SceneStateError, TraceError, WorkLimitError  # noqa: E402
from .grid import Grid, write_png  # noqa: E402
from .scene import SPD_DEFAULT_SIZES, SPD_SCENES, Scene  # noqa: E402
from .trace import Trace, load_trace  # noqa: E402

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


def __getattr__(name: str):
    """A module's former path as an attribute (``mprt.tracefile``): the module it moved to."""
    module = _aliases.attribute(__name__, name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return module


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
