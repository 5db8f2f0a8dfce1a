"""The package's former module paths, kept importable: ``import mprt.tracefile`` gives
``mprt.trace.tracefile`` itself (the same module object, so that what a caller sets on one,
as a test's monkeypatch does, is seen through the other).

The modules moved into rooms named for the pipeline (``trace/``, ``util/``) and the command
line into ``cli/``; this table maps each old dotted path to the new one.  A finder on
``sys.meta_path`` answers only these names, importing the new module when an old path is
first asked for (so ``mprt.options`` does not import the command line until someone asks).
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

MOVED = {
    "mprt.atomic": "mprt.util.atomic",
    "mprt.pages": "mprt.util.pages",
    "mprt.figures": "mprt.util.figures",
    "mprt.tracing": "mprt.trace.tracing",
    "mprt.tracefile": "mprt.trace.tracefile",
    "mprt.tracewriter": "mprt.trace.tracewriter",
    "mprt.tracevalid": "mprt.trace.tracevalid",
    "mprt.tracecheck": "mprt.trace.tracecheck",
    "mprt.recordcheck": "mprt.trace.recordcheck",
    "mprt.stats": "mprt.trace.stats",
    "mprt.options": "mprt.cli.options",
    "mprt.progress": "mprt.cli.progress",
    "mprt.report": "mprt.cli.report",
    "mprt.explore.cli": "mprt.cli.explore",
    "mprt.fidelity.cli": "mprt.cli.fidelity",
    "mprt.machine.cli": "mprt.cli.simulate",
}


class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old path of MOVED; loading it is importing the new module under both names."""

    def find_spec(self, name, path=None, target=None):
        return importlib.util.spec_from_loader(name, self) if name in MOVED else None

    def create_module(self, spec):
        module = importlib.import_module(MOVED[spec.name])
        spec.loader_state = module.__spec__     # the import system sets module.__spec__ to ours: put it back
        return module

    def exec_module(self, module):
        spec = module.__spec__
        if spec is not None and spec.loader is self and spec.loader_state is not None:
            module.__spec__ = spec.loader_state


def install() -> None:
    """Put the finder first on sys.meta_path (once)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.insert(0, _Finder())


def attribute(package: str, name: str):
    """The module an old path ``package.name`` names (for the package's ``__getattr__``), or None."""
    full = f"{package}.{name}"
    return importlib.import_module(full) if full in MOVED else None
