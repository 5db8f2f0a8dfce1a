"""The design-space file (TOML): the built-in space, the grammar of its leaves and the readers.

Every leaf of a space file is one of
    OS = 2                              a fixed value
    OS = { min = 1, max = 4 }           the integers min..max (``step`` optional)
    OS = { choices = [64, 256, 1024] }  one of a list (numbers or names)
and becomes one variable of the search, an index into its list of values.  A field left out takes
the built-in space's.  Errors name the file and the field.
"""
from __future__ import annotations

import tomllib

from .space import (FEEDS, MAPPINGS, MAX_VALUES, SHAPES, STAGE_NAMES, UNIT_KINDS, Space, SpaceError, Var,
                    _check_feed, _check_units_can_run)


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

_TOP = {"subdivision", "mapping", "replication", "units", "fifo", "cache", "resident", "pes", "cost", "software"}
# Variables a space file may mark software (chosen per scene, as the subdivision always is): how a
# processor's copies take their packets.  A software variable must not change what the chip costs.
SOFTWARE = ("replication.feed",)


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
    software = doc.get("software", [])
    if not isinstance(software, list) or not all(isinstance(x, str) for x in software):
        raise SpaceError(f"{w('software')}: a list of variable names (may be: {', '.join(SOFTWARE)})")
    for name in software:
        if name not in SOFTWARE:
            raise SpaceError(f"{w('software')}: {name!r} cannot be software (may be: {', '.join(SOFTWARE)}; the "
                             f"subdivision always is)")
    return Space(variables, shape, cost, source, tuple(dict.fromkeys(software)))


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


__all__ = ["DEFAULT_SPACE_TOML", "MAX_LEAF", "default_space", "load_space", "parse_space"]
