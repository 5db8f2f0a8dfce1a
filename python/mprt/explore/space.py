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
import tomllib
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


REFERENCE_DESIGNS = {"base": base_design, "M": model_m, "S": model_s}


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


# The built-in space: small enough that a search at a small resolution ends in
# seconds, wide enough to ask the paper's open questions.
DEFAULT_SPACE_TOML = """\
# mprt design space (the built-in default).  Each leaf: a value, {min, max[, step]} or {choices}.
mapping = { choices = ["OS|IC|SC", "OS+SC|IC", "OS|IC+SC", "OS+IC+SC"] }
fifo = { choices = [16, 64, 256] }       # words per send and per receive FIFO
pes = { min = 1, max = 4 }

[subdivision]                            # voxels per axis: software, chosen per scene on this lattice
nx = { choices = [1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512] }
ny = { choices = [1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512] }
nz = { choices = [1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512] }

[replication]
OS = { min = 1, max = 3 }
IC = { min = 1, max = 4 }
SC = { min = 1, max = 2 }
feed = { choices = ["shared", "round-robin", "shortest-queue"] }

[units.OS]
int = { min = 1, max = 3 }
fp = { min = 1, max = 3 }
[units.IC]
int = { min = 1, max = 2 }
fp = { min = 1, max = 4 }
[units.SC]
general = 1

[cache]                                  # KiB of cache over the global memories
IC = { choices = [0, 4, 16, 64] }
SC = { choices = [0, 4, 16] }
[resident]                               # KiB of resident memory (the hottest data, copied in every PE)
IC = { choices = [0, 16] }
SC = { choices = [0, 16] }
"""

_TOP = {"subdivision", "mapping", "replication", "units", "fifo", "cache", "resident", "pes", "cost"}


class Space:
    """The variables of a design space, in a fixed order, and the mapping
    between index vectors and points."""

    def __init__(self, variables: list[Var], shape: str, cost: dict, source: str):
        self.variables = variables
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
        return Space(fixed + keep, shape, self.cost, self.source)

    def subdivisions(self) -> list[tuple]:
        names = [v for v in self.variables if v.name.startswith("subdivision.")]
        if len(names) == 1:
            return [(n,) for n in names[0].values]
        import itertools
        return list(itertools.product(*(v.values for v in names)))


MAX_LEAF = 1 << 40     # above every machine limit (mprt.machine.config.LIMITS); keeps arithmetic exact


def _leaf(v, where: str, kind: str, lo: int | None = None, names: tuple = ()) -> tuple:
    """The values of one leaf: a scalar, {min, max, step} or {choices}."""
    def one(x, w):
        if kind == "name":
            if not isinstance(x, str) or x not in names:
                raise SpaceError(f"{w}: {x!r} is not one of {', '.join(names)}")
            return x
        if isinstance(x, bool) or not isinstance(x, int):
            raise SpaceError(f"{w}: {x!r} is not an integer")
        if lo is not None and x < lo:
            raise SpaceError(f"{w}: {x} is below the minimum {lo}")
        if x > MAX_LEAF:
            raise SpaceError(f"{w}: {x} is above the maximum {MAX_LEAF} of any design variable")
        return x

    if isinstance(v, dict):
        keys = set(v)
        if keys == {"choices"}:
            ch = v["choices"]
            if not isinstance(ch, list) or not ch:
                raise SpaceError(f"{where}.choices: must be a non-empty list")
            vals = tuple(one(x, f"{where}.choices[{i}]") for i, x in enumerate(ch))
            if len(set(vals)) != len(vals):
                raise SpaceError(f"{where}.choices: repeated values {list(vals)}")
            return vals
        if kind != "name" and keys and keys <= {"min", "max", "step"} and {"min", "max"} <= keys:
            a, b = one(v["min"], f"{where}.min"), one(v["max"], f"{where}.max")
            step = one(v.get("step", 1), f"{where}.step")
            if step < 1:
                raise SpaceError(f"{where}.step: {step} is not positive")
            if b < a:
                raise SpaceError(f"{where}: max {b} is below min {a}")
            span = range(a, b + 1, step)       # counted before it is made: max may be huge
            if len(span) > MAX_VALUES:
                raise SpaceError(f"{where}: {len(span)} values; at most {MAX_VALUES} (use a step)")
            return tuple(span)
        allowed = "{choices}" if kind == "name" else "{min, max[, step]} or {choices}"
        raise SpaceError(f"{where}: a table must be {allowed}, not keys {sorted(keys)}")
    return (one(v, where),)


def _table(d, where: str, known: set) -> dict:
    if not isinstance(d, dict):
        raise SpaceError(f"{where}: must be a table")
    extra = set(d) - known
    if extra:
        sep = "" if where.endswith(" ") else "."
        raise SpaceError(f"{where}{sep}{sorted(extra)[0]}: unknown field (known: {', '.join(sorted(known))})")
    return d


def parse_space(text: str, source: str = "<space>") -> Space:
    """A Space from TOML text; errors name ``source`` and the field."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SpaceError(f"{source}: {e}") from None
    except RecursionError:
        raise SpaceError(f"{source}: not a TOML file mprt reads (nested too deeply)") from None
    base = tomllib.loads(DEFAULT_SPACE_TOML) if source != "<default space>" else {}
    _table(doc, f"{source}: ", _TOP)

    def get(path, default_doc=base):
        cur, dflt = doc, default_doc
        for p in path:
            cur = cur.get(p) if isinstance(cur, dict) else None
            dflt = dflt.get(p) if isinstance(dflt, dict) else None
        return cur if cur is not None else dflt

    w = lambda name: f"{source}: {name}"  # noqa: E731
    variables: list[Var] = []
    sub = doc.get("subdivision", base.get("subdivision"))
    _table(sub, w("subdivision"), {"n", "nx", "ny", "nz", "shape"})
    shape = sub.get("shape", "cube")
    if shape not in SHAPES:
        raise SpaceError(f"{w('subdivision.shape')}: {shape!r} is not one of {', '.join(SHAPES)}")
    if "n" in sub:
        if {"nx", "ny", "nz"} & set(sub):
            raise SpaceError(f"{w('subdivision')}: give n, or nx, ny and nz, not both")
        variables.append(Var("subdivision.n", _leaf(sub["n"], w("subdivision.n"), "int", 1)))
    elif {"nx", "ny", "nz"} <= set(sub):
        if "shape" in sub:
            raise SpaceError(f"{w('subdivision.shape')}: applies to n only (nx, ny, nz are given)")
        for a in ("nx", "ny", "nz"):
            variables.append(Var(f"subdivision.{a}", _leaf(sub[a], w(f"subdivision.{a}"), "int", 1)))
    else:
        raise SpaceError(f"{w('subdivision')}: give n, or all of nx, ny and nz")
    variables.append(Var("mapping", _leaf(get(["mapping"]), w("mapping"), "name", names=MAPPINGS)))
    rep = doc.get("replication", base.get("replication"))
    _table(rep, w("replication"), set(STAGE_NAMES) | {"feed"})
    for s in STAGE_NAMES:
        variables.append(Var(f"replication.{s}", _leaf(rep.get(s, 1), w(f"replication.{s}"), "int", 1)))
    feed = rep.get("feed", FEEDS[0])
    for f in (feed.get("choices", []) if isinstance(feed, dict) else [feed]):
        if isinstance(f, str):
            _check_feed(f, w("replication.feed"))
    variables.append(Var("replication.feed", _leaf(feed, w("replication.feed"), "name",
                                                   names=FEEDS)))
    units = doc.get("units", base.get("units"))
    _table(units, w("units"), set(STAGE_NAMES))
    for s in STAGE_NAMES:
        u = units.get(s, base["units"][s] if base else None)
        if u is None:
            raise SpaceError(f"{w('units')}.{s}: missing")
        _table(u, w(f"units.{s}"), set(UNIT_KINDS))
        lo = {}
        for k in UNIT_KINDS:
            if k in u:
                vals = _leaf(u[k], w(f"units.{s}.{k}"), "int", 0)
                variables.append(Var(f"units.{s}.{k}", vals))
                lo[k] = min(vals)
        _check_units_can_run(lo.get("int", 0), lo.get("fp", 0), lo.get("general", 0), w(f"units.{s}"))
    variables.append(Var("fifo", _leaf(get(["fifo"]), w("fifo"), "int", 1)))
    for part in ("cache", "resident"):
        t = doc.get(part, base.get(part))
        _table(t, w(part), {"IC", "SC"})
        for s in ("IC", "SC"):
            variables.append(Var(f"{part}.{s}", _leaf(t.get(s, 0), w(f"{part}.{s}"), "int", 0)))
    variables.append(Var("pes", _leaf(get(["pes"]), w("pes"), "int", 1)))
    cost = doc.get("cost", {})
    _table(cost, w("cost"), set(_cost_fields()))
    from .hwcost import UnitCosts
    UnitCosts.from_table(cost, w("cost"))     # validate now, so errors name the file
    return Space(variables, shape, cost, source)


def _cost_fields():
    from .hwcost import UnitCosts
    return UnitCosts.fields()


def default_space() -> Space:
    return parse_space(DEFAULT_SPACE_TOML, "<default space>")


def load_space(path) -> Space:
    """A Space from a TOML file; fields left out take the built-in default's."""
    try:
        with open(path, "rb") as f:
            text = f.read().decode("utf-8")
    except OSError as e:
        raise SpaceError(f"{path}: cannot read the space file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise SpaceError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    return parse_space(text, str(path))
