"""A workload: the scenes one machine must run, each with a weight and its own trace settings.

A chip is built once and runs every scene; only software (the voxel subdivision, by default)
may differ between scenes.  ``mprt explore SCENE [SCENE ...]`` makes a workload of the names
given (weight 1, the command's settings); ``mprt explore --workload FILE.toml`` reads one::

    [[scene]]
    name = "balls"            # an SPD name (with size: "balls:2") or an NFF path
    weight = 2                # optional, default 1
    [[scene]]
    name = "teapot.nff"       # a relative path is read from the workload file's folder
    res = "256x256"           # optional, as are rules, threshold, skip_unknown, max_rays, max_depth

A key left out takes the command's value (``--res``, ``--rules``, ...), and where the command
gives none, the library's default.  The sweep spec's ``[[scene]]`` entries take the same keys
(``scene_entries``): one grammar for a list of scenes.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, replace

from ..errors import MprtError

ENTRY_KEYS = ("name", "weight", "res", "rules", "threshold", "skip_unknown", "max_rays", "max_depth")
RULES = ("paper", "spd", "paper1992")
MAX_SCENES = 256


class WorkloadError(MprtError, ValueError):
    """A workload (file or list of scenes) is invalid; the message names the file and the field."""


@dataclass(frozen=True)
class SceneEntry:
    """One scene of a workload: what to load and how to trace it (None: the command's default)."""
    name: str
    weight: float = 1.0
    res: tuple | None = None
    rules: str | None = None
    threshold: float | None = None
    skip_unknown: bool = False
    max_rays: int | None = None
    max_depth: int | None = None
    path: str | None = None            # an NFF file's path as it is opened (None: an SPD name)

    def load(self):
        """The Scene (an SPD generator's, or the NFF file's read with ``skip_unknown``)."""
        from ..scene import Scene

        if self.path is None:
            return Scene.load(self.name)
        return Scene.from_nff(self.path, skip_unknown=self.skip_unknown)

    def trace_options(self) -> dict:
        """The keywords of the traces made of this scene (those set only)."""
        out = {"rules": self.rules or "paper", "threshold": self.threshold}
        if self.max_rays is not None:
            out["max_rays"] = self.max_rays
        if self.max_depth is not None:
            out["max_depth"] = self.max_depth
        return out

    def with_defaults(self, res=None, rules=None, threshold=None, skip_unknown=None, max_rays=None,
                      max_depth=None) -> "SceneEntry":
        """The entry with each field it leaves out taken from the command's settings."""
        ch = {}
        for k, v in (("res", res), ("rules", rules), ("threshold", threshold), ("max_rays", max_rays),
                     ("max_depth", max_depth)):
            if getattr(self, k) is None and v is not None:
                ch[k] = tuple(v) if k == "res" else v
        if skip_unknown and not self.skip_unknown:
            ch["skip_unknown"] = True
        return replace(self, **ch) if ch else self

    def to_dict(self) -> dict:
        return {"name": self.name, "weight": self.weight, "res": list(self.res) if self.res else None,
                "rules": self.rules or "paper", "threshold": self.threshold, "skip_unknown": self.skip_unknown,
                "max_rays": self.max_rays, "max_depth": self.max_depth}


@dataclass(frozen=True)
class Workload:
    """Scenes in the order given (results keep it), each at most once."""
    scenes: tuple
    source: str = "<command line>"

    def __post_init__(self):
        if not self.scenes:
            raise WorkloadError(f"{self.source}: a workload needs at least one scene")
        seen = {}
        for i, e in enumerate(self.scenes):
            key = (e.name, e.res, e.rules, e.threshold, e.skip_unknown, e.max_rays, e.max_depth)
            if key in seen:
                raise WorkloadError(f"{self.source}: scene[{i}] {e.name!r} repeats scene[{seen[key]}] "
                                    f"(give it a weight instead)")
            seen[key] = i

    def __len__(self):
        return len(self.scenes)

    def __iter__(self):
        return iter(self.scenes)

    @property
    def weights(self) -> list:
        return [e.weight for e in self.scenes]

    def with_defaults(self, **settings) -> "Workload":
        return Workload(tuple(e.with_defaults(**settings) for e in self.scenes), self.source)

    def to_dict(self) -> dict:
        return {"source": self.source, "scenes": [e.to_dict() for e in self.scenes]}


def _int_in(v, lo, hi, where):
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise WorkloadError(f"{where}: {v!r} is not an integer in {lo}..{hi}")
    return v


def scene_entry(item, where: str, folder: str | None = None) -> SceneEntry:
    """One scene entry: a name (string) or a table of ``ENTRY_KEYS``; ``folder``: where a
    relative NFF path is read from first (the file's folder), else the current folder."""
    from ..settings import DEPTH_MAX, MAX_RAYS_MAX, resolution as resolution_arg

    if isinstance(item, str):
        item = {"name": item}
    if not isinstance(item, dict):
        raise WorkloadError(f"{where}: a scene name or a table with name = ..., not {item!r}")
    extra = sorted(set(item) - set(ENTRY_KEYS))
    if extra:
        raise WorkloadError(f"{where}.{extra[0]}: unknown field (known: {', '.join(ENTRY_KEYS)})")
    name = item.get("name")
    if not isinstance(name, str) or not name:
        raise WorkloadError(f"{where}.name: missing (an SPD name such as \"balls\" or an NFF path)")
    ch: dict = {"name": name}
    if "weight" in item:
        w = item["weight"]
        if isinstance(w, bool) or not isinstance(w, (int, float)) or not 0 < w < float("inf"):
            raise WorkloadError(f"{where}.weight: {w!r} is not a positive number")
        ch["weight"] = float(w)
    if "res" in item:
        try:
            ch["res"] = tuple(resolution_arg(str(item["res"])))
        except ValueError as e:                 # settings.BadValue
            raise WorkloadError(f"{where}.res: {e}") from None
    if "rules" in item:
        if item["rules"] not in RULES:
            raise WorkloadError(f"{where}.rules: {item['rules']!r} is not one of {', '.join(RULES)}")
        ch["rules"] = item["rules"]
    if "threshold" in item:
        t = item["threshold"]
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0 <= t < 1:
            raise WorkloadError(f"{where}.threshold: {t!r} is not a number in [0, 1)")
        ch["threshold"] = float(t)
    if "skip_unknown" in item:
        if not isinstance(item["skip_unknown"], bool):
            raise WorkloadError(f"{where}.skip_unknown: {item['skip_unknown']!r} is not true or false")
        ch["skip_unknown"] = item["skip_unknown"]
    if "max_rays" in item:
        ch["max_rays"] = _int_in(item["max_rays"], 1, MAX_RAYS_MAX, f"{where}.max_rays")
    if "max_depth" in item:
        ch["max_depth"] = _int_in(item["max_depth"], 1, DEPTH_MAX, f"{where}.max_depth")
    ch["path"] = _scene_path(name, where, folder)
    if ch["path"] is None and ch.get("skip_unknown"):
        raise WorkloadError(f"{where}.skip_unknown: {name!r} is an SPD scene (no file to skip entities of)")
    return SceneEntry(**ch)


def _scene_path(name: str, where: str, folder: str | None) -> str | None:
    """None for an SPD name (always the generator); else the NFF file's path, read from
    ``folder`` first when it is relative."""
    from ..scene import SPD_SCENES

    base, colon, size = name.partition(":")
    if base in SPD_SCENES:
        if colon and not size.isdigit():
            raise WorkloadError(f"{where}.name: the SPD size in {name!r} must be a positive integer")
        return None
    tried = []
    if folder and not os.path.isabs(name):
        tried.append(os.path.join(folder, name))
    tried.append(name)
    for p in tried:
        if os.path.isfile(p):
            return p
    raise WorkloadError(f"{where}.name: {name!r} is neither an SPD scene ({', '.join(SPD_SCENES)}[:size]) nor an "
                        f"NFF file (looked for {' and '.join(repr(p) for p in dict.fromkeys(tried))})")


def scene_entries(items, where: str, folder: str | None = None) -> list:
    """A list of scene entries (names or tables), each checked; errors name ``where[i]``."""
    if not isinstance(items, list) or not items:
        raise WorkloadError(f"{where}: must be a non-empty list of scenes ([[scene]] tables or names)")
    if len(items) > MAX_SCENES:
        raise WorkloadError(f"{where}: {len(items)} scenes; at most {MAX_SCENES}")
    return [scene_entry(x, f"{where}[{i}]", folder) for i, x in enumerate(items)]


def load_workload(path) -> Workload:
    """A workload file: ``[[scene]]`` tables (see the module's text)."""
    from ..settings import read_toml

    path = os.fspath(path)
    doc = read_toml(path, "workload", WorkloadError)
    extra = sorted(set(doc) - {"scene"})
    if extra:
        raise WorkloadError(f"{path}: {extra[0]}: unknown field (a workload file holds [[scene]] tables)")
    if "scene" not in doc:
        raise WorkloadError(f"{path}: no [[scene]] table (each names a scene: name = \"balls\")")
    return Workload(tuple(scene_entries(doc["scene"], f"{path}: scene", os.path.dirname(os.path.abspath(path)))),
                    path)


def workload_of(names, source: str = "<command line>") -> Workload:
    """The workload of scene names given on the command line (weight 1 each)."""
    return Workload(tuple(scene_entry(n, f"scene {n!r}") for n in names), source)


__all__ = ["ENTRY_KEYS", "SceneEntry", "Workload", "WorkloadError", "load_workload", "scene_entries",
           "workload_of"]
