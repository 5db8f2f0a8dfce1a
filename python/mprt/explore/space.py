"""The design space: what the explorer may vary, read from TOML and validated.

A *design* is one machine: how the three subtasks OS, IC and SC map onto
processors, how many copies of each processor there are and how rays are fed
to them, the functional units of each processor by kind, the FIFO capacity,
the IC and SC cache and resident-memory sizes, and the number of PEs.  A
*point* is a subdivision plus a design: the subdivision changes the trace,
the design only its replay.

Every leaf of the space file is one of
    OS = 2                              a fixed value
    OS = { min = 1, max = 4 }           the integers min..max (``step`` optional)
    OS = { choices = [64, 256, 1024] }  one of a list (numbers or names)
and becomes one variable of the search, an index into its list of values.
Errors name the file and the field.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

from ..errors import MprtError
from ..machine.config import FEEDS as MACHINE_FEEDS

STAGE_NAMES = ("OS", "IC", "SC")
# The stage mappings: '|' separates processors, '+' joins subtasks on one processor.
MAPPINGS = ("OS|IC|SC", "OS+SC|IC", "OS|IC+SC", "OS+IC+SC")
# How a processor's copies get their packets (the machine model's stage ``feed``): one receive
# FIFO that an idle copy takes the next packet from ("shared", a central queue), or a receive
# FIFO per copy, each packet assigned round-robin or to the shortest queue.
FEEDS = MACHINE_FEEDS
UNIT_KINDS = ("int", "fp", "general")
SHAPES = ("cube", "proportional")
MAX_VALUES = 4096          # values of one variable (a range longer than this is refused)


class SpaceError(MprtError, ValueError):
    """A design-space file or value is invalid; the message names the file and field."""


def _check_feed(feed, where: str) -> None:
    if feed not in FEEDS:
        raise SpaceError(f"{where}: feed {feed!r} is not one of {', '.join(FEEDS)}")


def processors(mapping: str) -> list[tuple[str, ...]]:
    """The processors of a mapping, each a tuple of the subtasks it runs, in OS, IC, SC order."""
    return [tuple(p.split("+")) for p in mapping.split("|")]


def processor_name(group) -> str:
    return "+".join(group)


@dataclass(frozen=True)
class Design:
    """One machine.  Per-stage fields (replication, units) are keyed by the
    stage; a processor running several subtasks takes the entries of its
    first subtask (OS before IC before SC)."""
    mapping: str = "OS|IC|SC"
    replication: dict = field(default_factory=lambda: {"OS": 1, "IC": 1, "SC": 1})
    feed: str = "shared"
    units: dict = field(default_factory=lambda: {"OS": {"int": 2, "fp": 2}, "IC": {"int": 1, "fp": 3},
                                                 "SC": {"general": 1}})
    fifo: int = 256                 # words per send and per receive FIFO
    cache: dict = field(default_factory=lambda: {"IC": 16, "SC": 4})      # KiB
    resident: dict = field(default_factory=lambda: {"IC": 0, "SC": 0})    # KiB
    pes: int = 1

    def __hash__(self):
        return hash(self.key())

    def __eq__(self, other):
        return isinstance(other, Design) and self.key() == other.key()

    def to_dict(self) -> dict:
        """The design as the space file's fields (JSON- and TOML-ready)."""
        return {"mapping": self.mapping, "replication": dict(self.replication), "feed": self.feed,
                "units": {s: dict(u) for s, u in self.units.items()}, "fifo": self.fifo,
                "cache": dict(self.cache), "resident": dict(self.resident), "pes": self.pes}

    @classmethod
    def from_dict(cls, d: dict, where: str = "design", base: "Design | None" = None) -> "Design":
        """A design of the space file's fields, checked (errors name ``where`` and the field).
        Without ``base``, a field left out is the default design's (a ``to_dict()`` reads back as
        it was).  With ``base`` (a Design), ``d`` is a partial design: the fields it gives replace
        the base's, tables merged key by key down to each processor's unit kinds (``{units = {OS
        = {int = 3}}}`` changes that count only; a kind left out keeps the base's, 0 removes it)."""
        known = {"mapping", "replication", "feed", "units", "fifo", "cache", "resident", "pes"}
        if not isinstance(d, dict):
            raise SpaceError(f"{where}: a table of design fields, not {d!r}")
        extra = set(d) - known
        if extra:
            raise SpaceError(f"{where}: unknown field(s) {sorted(extra)}; known: {sorted(known)}")
        fields = (base or cls()).to_dict()
        for k, v in d.items():
            keys = {"replication": STAGE_NAMES, "units": STAGE_NAMES, "cache": ("IC", "SC"),
                    "resident": ("IC", "SC")}.get(k)
            fields[k] = _merged(fields[k], v, f"{where}: {k}", keys, k == "units") if base and keys else v
        out = cls(**fields)
        out.validate(where)
        return out

    def key(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)

    def processors(self) -> list[tuple[str, ...]]:
        return processors(self.mapping)

    def processor_units(self, group) -> dict:
        return {k: v for k, v in self.units[group[0]].items() if v}

    def processor_copies(self, group) -> int:
        return int(self.replication[group[0]])

    def validate(self, where: str = "design") -> None:
        if self.mapping not in MAPPINGS:
            raise SpaceError(f"{where}: mapping {self.mapping!r} is not one of {', '.join(MAPPINGS)}")
        _check_feed(self.feed, f"{where}: feed")
        for s in STAGE_NAMES:
            for name, table in (("replication", self.replication), ("units", self.units),
                                ("cache", self.cache if s != "OS" else {"OS": 0}),
                                ("resident", self.resident if s != "OS" else {"OS": 0})):
                if s not in table:
                    raise SpaceError(f"{where}: {name}.{s} is missing")
            _need_int(self.replication[s], 1, f"{where}: replication.{s}")
            u = self.units[s]
            for k, v in u.items():
                if k not in UNIT_KINDS:
                    raise SpaceError(f"{where}: units.{s}.{k}: unknown unit kind (known: {', '.join(UNIT_KINDS)})")
                _need_int(v, 0, f"{where}: units.{s}.{k}")
            _check_units_can_run(u.get("int", 0), u.get("fp", 0), u.get("general", 0), f"{where}: units.{s}")
        for s in ("IC", "SC"):
            _need_int(self.cache[s], 0, f"{where}: cache.{s}")
            _need_int(self.resident[s], 0, f"{where}: resident.{s}")
        _need_int(self.fifo, 1, f"{where}: fifo")
        _need_int(self.pes, 1, f"{where}: pes")

    def describe(self) -> str:
        """The design in words."""
        parts = []
        for g in self.processors():
            u = self.processor_units(g)
            units = " + ".join(f"{v} {k}" for k, v in u.items())
            k = self.processor_copies(g)
            parts.append(f"{processor_name(g)} on {k}x({units})")
        text = "; ".join(parts)
        if any(self.processor_copies(g) > 1 for g in self.processors()):
            text += ", copies sharing one queue" if self.feed == "shared" else f", copies fed {self.feed}"
        if len(self.processors()) > 1:
            text += f"; FIFOs {self.fifo} words"
        text += (f"; IC cache {self.cache['IC']} KiB + resident {self.resident['IC']} KiB,"
                 f" SC cache {self.cache['SC']} KiB + resident {self.resident['SC']} KiB; {self.pes} PE(s)")
        return text


def _merged(old: dict, new, where: str, keys, nested: bool) -> dict:
    """A design's table ``old`` with the keys of ``new`` (a table of ``keys``) replacing its own;
    ``nested``: each value a table merged the same way (a processor's units by kind)."""
    if not isinstance(new, dict):
        raise SpaceError(f"{where}: a table of {', '.join(keys)}, not {new!r}")
    out = dict(old)
    for k, v in new.items():
        if k not in keys:
            raise SpaceError(f"{where}.{k}: unknown field (known: {', '.join(keys)})")
        if nested:
            if not isinstance(v, dict):
                raise SpaceError(f"{where}.{k}: a table of unit counts ({', '.join(UNIT_KINDS)}), not {v!r}")
            v = {**old.get(k, {}), **v}
        out[k] = v
    return out


def _need_int(v, lo, where):
    if isinstance(v, bool) or not isinstance(v, int):
        raise SpaceError(f"{where}: {v!r} is not an integer")
    if v < lo:
        raise SpaceError(f"{where}: {v} is below the minimum {lo}")


def _check_units_can_run(i, f, g, where):
    if i + g < 1:
        raise SpaceError(f"{where}: no unit runs integer operations (give int or general at least 1)")
    if f + g < 1:
        raise SpaceError(f"{where}: no unit runs floating-point operations (give fp or general at least 1)")


# Designs of the explorer's vocabulary.  The paper's machines themselves (3mppe, M, S) are the
# machine model's (``mprt.machine.builtin``): one definition, used by simulate, prepass, explore and sweep.
def base_design() -> Design:
    """The explorer's base design (``Design()``): the paper's three processors (OS 2 int + 2 FP,
    IC 1 int + 3 FP, SC one general unit), one copy each, 256-word FIFOs, 16/4 KiB caches, no
    resident memory, one PE.  Not the paper's 3MPPE (``mprt.machine.builtin("3mppe")``)."""
    return Design()


def paper_3mppe() -> Design:
    """Deprecated: the explorer's base design (``base_design``), which is not the paper's 3MPPE."""
    import warnings
    warnings.warn("mprt.explore.paper_3mppe() is the explorer's base design, not the paper's 3MPPE; use "
                  "base_design(), or mprt.machine.builtin('3mppe') for the 3MPPE", DeprecationWarning, stacklevel=2)
    return Design()


def model_m() -> Design:
    """Model M: the 3-stage pipeline on three identical sequential processors."""
    seq = {"general": 1}
    return Design(units={"OS": dict(seq), "IC": dict(seq), "SC": dict(seq)})


def model_s() -> Design:
    """Model S: one sequential processor running all three subtasks."""
    return Design(mapping="OS+IC+SC", units={"OS": {"general": 1}, "IC": {"general": 1}, "SC": {"general": 1}})




@dataclass(frozen=True)
class Var:
    """One search variable: a dotted field name and its ordered values."""
    name: str
    values: tuple

    @property
    def size(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class Point:
    """A subdivision (nx, ny, nz) or an n to be shaped by the scene, and a design."""
    subdivision: tuple
    design: Design

    def key(self) -> str:
        return json.dumps([list(self.subdivision), self.design.to_dict()], sort_keys=True)


class Space:
    """The variables of a design space, in a fixed order, and the mapping
    between index vectors and points."""

    def __init__(self, variables: list[Var], shape: str, cost: dict, source: str, software: tuple = ()):
        self.variables = variables
        self.software = tuple(software)   # variables chosen per scene, like the subdivision (not hardware)
        self.shape = shape
        self.cost = cost              # the [cost] table (validated by hwcost.UnitCosts)
        self.source = source
        self.names = [v.name for v in variables]
        self._pos = {v.name: i for i, v in enumerate(variables)}

    @property
    def sizes(self) -> list[int]:
        return [v.size for v in self.variables]

    def count(self) -> int:
        n = 1
        for v in self.variables:
            n *= v.size
        return n

    def value(self, idx, name):
        return self.variables[self._pos[name]].values[idx[self._pos[name]]]

    def point(self, idx) -> Point:
        """The point of an index vector (one index per variable)."""
        get = lambda name: self.value(idx, name)  # noqa: E731
        if "subdivision.n" in self._pos:
            sub = (get("subdivision.n"),)
        else:
            sub = (get("subdivision.nx"), get("subdivision.ny"), get("subdivision.nz"))
        d = Design(
            mapping=get("mapping"),
            replication={s: get(f"replication.{s}") for s in STAGE_NAMES},
            feed=get("replication.feed"),
            units={s: {k: get(f"units.{s}.{k}") for k in UNIT_KINDS if f"units.{s}.{k}" in self._pos}
                   for s in STAGE_NAMES},
            fifo=get("fifo"),
            cache={s: get(f"cache.{s}") for s in ("IC", "SC")},
            resident={s: get(f"resident.{s}") for s in ("IC", "SC")},
            pes=get("pes"),
        )
        return Point(sub, d)

    def canonical(self, idx) -> tuple:
        """The index vector with every variable that cannot change the machine
        set to its first value: units and replication of a subtask that shares
        its processor with an earlier one, the FIFOs
        when one processor runs everything, the feed when no processor
        has copies.  Two vectors
        with the same canonical form are one design."""
        idx = list(int(i) for i in idx)
        mapping = self.value(idx, "mapping")
        live_stage = {g[0] for g in processors(mapping)}
        for i, v in enumerate(self.variables):
            parts = v.name.split(".")
            if parts[0] in ("units", "replication") and parts[1] in STAGE_NAMES and parts[1] not in live_stage:
                idx[i] = 0
        if len(live_stage) == 1:          # one processor: no packets, so no FIFOs
            idx[self._pos["fifo"]] = 0
        if all(self.value(idx, f"replication.{s}") == 1 for s in live_stage):    # no copies to feed
            idx[self._pos["replication.feed"]] = 0
        return tuple(idx)

    def index_of(self, point: Point) -> tuple:
        """The index vector of a point (every value must be in the space)."""
        d = point.design
        want = {"mapping": d.mapping, "replication.feed": d.feed, "fifo": d.fifo, "pes": d.pes}
        for s in STAGE_NAMES:
            want[f"replication.{s}"] = d.replication[s]
            for k in UNIT_KINDS:
                want[f"units.{s}.{k}"] = d.units[s].get(k, 0)
        for s in ("IC", "SC"):
            want[f"cache.{s}"] = d.cache[s]
            want[f"resident.{s}"] = d.resident[s]
        sub = point.subdivision
        if "subdivision.n" in self._pos:
            want["subdivision.n"] = sub[0]
        else:
            want.update({"subdivision.nx": sub[0], "subdivision.ny": sub[1], "subdivision.nz": sub[2]})
        out = []
        for v in self.variables:
            if want[v.name] not in v.values:
                raise SpaceError(f"{self.source}: {v.name} = {want[v.name]!r} is not in the space {list(v.values)}")
            out.append(v.values.index(want[v.name]))
        return tuple(out)

    def with_subdivision(self, sub) -> "Space":
        """The same space with the subdivision fixed (one n, or nx, ny, nz)."""
        keep = [v for v in self.variables if not v.name.startswith("subdivision.")]
        sub = tuple(sub)
        if len(sub) == 1:
            fixed = [Var("subdivision.n", (int(sub[0]),))]
            shape = self.shape
        else:
            fixed = [Var(f"subdivision.n{a}", (int(x),)) for a, x in zip("xyz", sub)]
            shape = "cube"
        return Space(fixed + keep, shape, self.cost, self.source, self.software)

    def hardware(self) -> "Space":
        """The space the machine is searched in: the subdivision held (at 1, a placeholder: each scene
        has its own) and each software variable at its first value (each scene chooses its own)."""
        sp = self.with_subdivision((1, 1, 1))
        return Space([Var(v.name, v.values[:1]) if v.name in self.software else v for v in sp.variables],
                     sp.shape, sp.cost, sp.source, self.software)

    def software_values(self) -> list:
        """Every choice of the software variables' values, as {name: value} (one empty choice
        where there are none)."""
        import itertools
        vars_ = [self.variables[self._pos[n]] for n in self.software]
        return [dict(zip(self.software, combo)) for combo in itertools.product(*(v.values for v in vars_))]

    def subdivisions(self) -> list[tuple]:
        names = [v for v in self.variables if v.name.startswith("subdivision.")]
        if len(names) == 1:
            return [(n,) for n in names[0].values]
        import itertools
        return list(itertools.product(*(v.values for v in names)))


# The space file (TOML): its grammar, the built-in space and the readers live in spacefile.py
from .spacefile import (DEFAULT_SPACE_TOML, MAX_LEAF, default_space, load_space, parse_space)  # noqa: E402,F401
