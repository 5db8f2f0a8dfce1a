"""The package's layers: each module of python/mprt imports only modules of layers below its own.

The order, bottom first.  A new module must be given its place here (a module
missing from the list fails), and a subpackage (cost/, machine/, ...) is one
layer: its modules may import each other and any layer below.
"""
import ast
import os

import pytest

PACKAGE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "python", "mprt")

ORDER = [
    "_build",      # cffi builder of the extensions (imports none of the package)
    "_aliases",    # the modules' former paths (mprt.tracefile, mprt.options, ...), found by name, importing nothing
    "errors",      # exceptions
    "util",        # atomic outputs, paged arrays, figures read at a glance (none imports the package)
    "_lowlevel",   # the only importer of the compiled extensions: one wrapper per C call, enums, record dtypes
                   # (a package: core, scene, grid, records, replay; the rest imports the package, never its modules)
    "scene",       # Scene
    "grid",        # Grid (adds Scene.grid), render, intersect, camera rays, per-tile calls
    "trace",       # the trace: recording, Trace, the file format and writer, validation, invariants, statistics
    "settings",    # ranges, defaults and text forms of the settings; TOML; what a JSON output records
    "memory_estimate",  # peak memory of simulate, explore and sweep, against the memory available
    "cost",        # operation costs of stage visits (takes a Trace)
    "machine",     # the SimPy machine model (takes a Trace, never a Grid)
    "fidelity",    # levels of model detail
    "explore",     # design-space exploration: the explorer, prepass, sweep
    "cli",         # the application: the mprt command's parsers, printing, progress, reports
    "__init__",    # the package's public names
    "__main__",    # python -m mprt
]
APPLICATION = {"cli", "__main__"}    # the rest is the library: it never imports these, nor argparse
EXTENSIONS = {"_mprt", "_mprt32"}   # compiled; imported by _lowlevel's modules alone
LAYER = {name: i for i, name in enumerate(ORDER)}


def module_files():
    """(layer name, path relative to the package) of every Python file in the package."""
    out = []
    for root, dirs, files in os.walk(PACKAGE):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for f in sorted(files):
            if f.endswith(".py"):
                rel = os.path.relpath(os.path.join(root, f), PACKAGE)
                out.append((rel.split(os.sep)[0].removesuffix(".py"), rel))
    return sorted(out)


def is_module(name: str) -> bool:
    """Whether a name imported from the package root is one of its modules (not a public name)."""
    return name in LAYER or name in EXTENSIONS or os.path.exists(os.path.join(PACKAGE, name + ".py")) \
        or os.path.isdir(os.path.join(PACKAGE, name))


def imported_paths(source: str, rel: str):
    """(line, dotted path as a list, "mprt" first) of every import of the package's own modules in
    a file's source (function bodies included); rel is the file's path relative to the package."""
    package = ["mprt"] + rel.split(os.sep)[:-1]       # the file's package, as a dotted path
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            targets = [a.name.split(".") for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            mod = base + (node.module.split(".") if node.module else [])
            # 'from mprt import name': name is a module of the package, or one of its public names;
            # 'from mprt.sub import name': name may be a module of the subpackage
            targets = [mod + [a.name if is_module(a.name) else "__init__"] if mod == ["mprt"] else
                       mod + [a.name] if is_module(os.path.join(*mod[1:], a.name)) else mod for a in node.names]
        else:
            continue
        found += [(node.lineno, t) for t in targets if t[0] == "mprt"]
    return found


def imported_layers(source: str, rel: str):
    """(line, layer imported) for every import of the package's own modules in a file's source."""
    return [(line, t[1] if len(t) > 1 else "__init__") for line, t in imported_paths(source, rel)]


def violations(layer: str, rel: str, source: str):
    """The imports of a file that break the order, as messages."""
    out = []
    if layer not in LAYER:
        return [f"{rel}: module {layer!r} has no place in tests/test_layers.py ORDER"]
    for line, target in imported_layers(source, rel):
        where = f"{rel}:{line}"
        if target in EXTENSIONS:
            if layer != "_lowlevel":
                out.append(f"{where}: only _lowlevel may import the compiled extension {target}")
        elif target not in LAYER:
            out.append(f"{where}: imports {target!r}, which has no place in ORDER")
        elif target == layer and os.sep not in rel:
            out.append(f"{where}: imports itself")
        elif LAYER[target] > LAYER[layer]:
            out.append(f"{where}: {layer} imports {target}, a layer above it")
    if layer != "_lowlevel":
        out += [f"{rel}:{line}: imports {'.'.join(t)}; import from mprt._lowlevel, not its modules"
                for line, t in imported_paths(source, rel) if len(t) > 2 and t[1] == "_lowlevel"]
    tops = set()
    for n in ast.walk(ast.parse(source)):
        if isinstance(n, ast.Import):
            tops |= {a.name.split(".")[0] for a in n.names}
        elif isinstance(n, ast.ImportFrom) and n.level == 0:
            tops.add(n.module.split(".")[0])
    if layer != "_build" and "cffi" in tops:
        out.append(f"{rel}: only _build imports cffi")
    return out


@pytest.mark.parametrize("layer, rel", module_files(), ids=[r for _, r in module_files()])
def test_module_imports_only_layers_below_it(layer, rel):
    """The module has a place in the order and imports only modules of lower layers."""
    with open(os.path.join(PACKAGE, rel)) as f:
        assert violations(layer, rel, f.read()) == []


@pytest.mark.parametrize("layer, rel, source, words", [
    ("grid", "grid.py", "def f():\n    from .trace.tracing import trace\n", "grid imports trace, a layer above"),
    ("scene", "scene.py", "from . import grid\n", "scene imports grid"),
    ("trace", os.path.join("trace", "core.py"), "from mprt import Scene\n", "trace imports __init__"),
    ("trace", os.path.join("trace", "stats.py"), "from .. import _mprt\n", "only _lowlevel"),
    ("machine", os.path.join("machine", "pe.py"), "from ..explore import run\n", "machine imports explore"),
    ("newthing", "newthing.py", "", "no place"),
    ("trace", os.path.join("trace", "tracing.py"), "from ..elsewhere import x\n", "'elsewhere', which has no place"),
    ("grid", "grid.py", "from cffi import FFI\n", "only _build imports cffi"),
    ("trace", os.path.join("trace", "core.py"), "from .._lowlevel.core import RAY_DTYPE\n", "not its modules"),
    ("cost", os.path.join("cost", "fast.py"), "from .._lowlevel import replay\n", "not its modules"),
    ("scene", "scene.py", "import mprt._lowlevel.scene\n", "not its modules"),
], ids=["lazy import upward", "from-package import of a module", "package root", "extension", "subpackage",
        "unplaced module", "unplaced import", "cffi", "a _lowlevel module", "a _lowlevel module by name",
        "a _lowlevel module imported"])
def test_the_check_catches_a_broken_order(layer, rel, source, words):
    """The checker reports an upward import, an import of the extensions outside _lowlevel and an unplaced module."""
    found = violations(layer, rel, source)
    assert any(words in v for v in found), found


def library_violations(layer: str, rel: str, source: str):
    """The imports that tie a library module (any but APPLICATION's) to the command line: the
    cli package, or argparse."""
    if layer in APPLICATION:
        return []
    out = [f"{rel}:{line}: the library imports the command line ({target})"
           for line, target in imported_layers(source, rel) if target in APPLICATION]
    for n in ast.walk(ast.parse(source)):
        names = [a.name for a in n.names] if isinstance(n, ast.Import) else \
            [n.module or ""] if isinstance(n, ast.ImportFrom) and n.level == 0 else []
        out += [f"{rel}:{n.lineno}: the library imports argparse" for m in names if m.split(".")[0] == "argparse"]
    return out


@pytest.mark.parametrize("layer, rel", module_files(), ids=[r for _, r in module_files()])
def test_the_library_never_imports_the_command_line(layer, rel):
    """Nothing outside cli/ (and __main__) imports cli/ or argparse: the library reads without them."""
    with open(os.path.join(PACKAGE, rel)) as f:
        assert library_violations(layer, rel, f.read()) == []


@pytest.mark.parametrize("layer, rel, source", [
    ("explore", os.path.join("explore", "sweep.py"), "def f():\n    from ..cli import report\n"),
    ("__init__", "__init__.py", "from .cli import main\n"),
    ("machine", os.path.join("machine", "config.py"), "import argparse\n"),
    ("settings", "settings.py", "def f():\n    from argparse import ArgumentTypeError\n"),
], ids=["lazy import of cli", "package root", "import argparse", "from argparse"])
def test_the_library_check_catches_the_command_line(layer, rel, source):
    assert library_violations(layer, rel, source)


def test_the_command_line_may_import_the_library_and_argparse():
    rel = os.path.join("cli", "explore.py")
    assert library_violations("cli", rel, "import argparse\nfrom ..explore import sweep\n") == []
    assert violations("cli", rel, "import argparse\nfrom ..explore import sweep\nfrom . import options\n") == []


def test_the_binding_package_alone_imports_the_extensions():
    """_lowlevel is a package: its modules (and only they) import the compiled extensions and
    each other; every other layer imports the package itself."""
    mods = [rel for layer, rel in module_files() if layer == "_lowlevel"]
    assert os.path.join("_lowlevel", "__init__.py") in mods and os.path.join("_lowlevel", "core.py") in mods
    for rel in mods:
        assert violations("_lowlevel", rel, "from .. import _mprt, _mprt32\nfrom .core import Calls\n"
                                            "from ..errors import MprtError\n") == []
    assert violations("grid", "grid.py", "from ._lowlevel import RULES, binding\n") == []
    assert violations("grid", "grid.py", "from . import _mprt\n")


def test_subpackage_modules_may_import_each_other_and_lower_layers():
    """Within a subpackage, sibling imports and imports of lower layers are allowed."""
    rel = os.path.join("machine", "pe.py")
    assert violations("machine", rel, "from . import fifo\nfrom ..trace import Trace\nfrom .. import errors\n") == []
