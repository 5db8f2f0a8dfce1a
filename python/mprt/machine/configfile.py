"""Machine files: a configuration read from TOML, checked field by field, and written back.

``config_from_dict`` checks parsed TOML (or equal data) and builds a ``SystemConfig``;
``load_config`` reads a file, ``resolve`` the configuration a command asks for (a file, a
built-in model, a number of PEs), and ``config_toml`` writes the machine file that
``load_config`` reads back as an equal configuration.  Every error names the field and the
file.  The dataclasses, their checks and the built-ins are ``mprt.machine.config``'s, which
also re-exports these names (import either; this module imports config, never the reverse
but for that re-export).
"""
from __future__ import annotations

import dataclasses
import os

from .config import (BUILTIN, DIS_POLICIES, FEEDS, SUBTASKS, CacheConfig, GlobalMemoryConfig, LocalMemoryConfig,
                     RingConfig, StageConfig, SystemConfig, _int, builtin, make_processor, rule_window)
from .errors import ConfigError

_TOP = {"base", "name", "pes", "dis", "window", "stage", "ring", "ic_memory", "sc_memory", "icgm", "scgm"}
_STAGE = {"subtasks", "processor", "replicas", "send_fifo", "receive_fifo", "feed"}
_RING = {"flit_time", "buffer_classes"}
_LOCAL = {"resident", "cache"}
_CACHE = {"size", "line", "ways"}
_GLOBAL = {"latency", "bandwidth", "contention"}


def _table(value, where, name, keys):
    if not isinstance(value, dict):
        raise ConfigError(f"{where}{name}: must be a table, not {value!r}")
    unknown = sorted(set(value) - keys)
    if unknown:
        raise ConfigError(f"{where}{name}.{unknown[0]}: unknown field (known: {', '.join(sorted(keys))})")
    return value


def _fifo(value, where, name):
    if value == "unbounded":
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{where}{name}: must be a positive integer or \"unbounded\", not {value!r}")
    if value < 1:
        raise ConfigError(f"{where}{name}: a FIFO holds at least 1 packet, not {value}")
    return value


def _feed(value, where, name):
    if not isinstance(value, str) or value not in FEEDS:
        raise ConfigError(f"{where}{name}: must be one of \"shared\", \"round-robin\", \"shortest-queue\", "
                          f"not {value!r}")
    return value


def _need(tbl, key, where, name):
    if key not in tbl:
        raise ConfigError(f"{where}{name}.{key}: missing")
    return tbl[key]


def _optional(data, key, where, build):
    """A table, or "none" to leave the part out; absent: the base's part."""
    v = data[key]
    if v == "none":
        return None
    return build(v)


def config_from_dict(data: dict, source: str | None = None) -> SystemConfig:
    """A SystemConfig from parsed TOML (or equivalent) data, checked field by field."""
    w = f"{source}: " if source else ""
    unknown = sorted(set(data) - _TOP)
    if unknown:
        raise ConfigError(f"{w}{unknown[0]}: unknown field (known: {', '.join(sorted(_TOP))})")
    base = data.get("base")
    if base is not None:
        if not isinstance(base, str) or base not in BUILTIN:
            raise ConfigError(f"{w}base: unknown model {base!r} (known: {', '.join(BUILTIN)})")
        cfg = builtin(base)
    else:
        cfg = None
    ch: dict = {}
    if "name" in data:
        if not isinstance(data["name"], str) or not data["name"]:
            raise ConfigError(f"{w}name: must be a non-empty string")
        ch["name"] = data["name"]
    elif cfg is None:
        ch["name"] = os.path.splitext(os.path.basename(source))[0] if source else "custom"
    if isinstance(data.get("window"), str) and data["window"] != "auto":
        raise ConfigError(f"{w}window: must be a positive integer or \"auto\", not {data['window']!r}")
    if data.get("window") == "auto":
        ch["window_rule"] = "auto"
        data = {k: v for k, v in data.items() if k != "window"}
    elif "window" in data:
        ch["window_rule"] = None
    for key in ("pes", "window"):
        if key in data:
            ch[key] = _int(data[key], w, key)
    if "dis" in data:
        if data["dis"] not in DIS_POLICIES:
            raise ConfigError(f"{w}dis: unknown policy {data['dis']!r} (known: {', '.join(DIS_POLICIES)})")
        ch["dis"] = data["dis"]
    if "stage" in data:
        stages = data["stage"]
        if not isinstance(stages, list) or not stages:
            raise ConfigError(f"{w}stage: must be an array of tables ([[stage]]), one per stage")
        out = []
        for i, st in enumerate(stages):
            nm = f"stage[{i}]"
            _table(st, w, nm, _STAGE)
            subs = _need(st, "subtasks", w, nm)
            if isinstance(subs, str):
                subs = [subs]
            if not isinstance(subs, list) or not all(isinstance(x, str) for x in subs):
                raise ConfigError(f"{w}{nm}.subtasks: must be a list of OS, IC, SC")
            for x in subs:
                if x not in SUBTASKS:
                    raise ConfigError(f"{w}{nm}.subtasks: unknown subtask {x!r} (known: {', '.join(SUBTASKS)})")
            spec = st.get("processor", "sequential")
            proc = make_processor(spec, tuple(subs), where=f"{w}{nm}.processor")
            out.append(StageConfig(tuple(subs), proc, _int(st.get("replicas", 1), w, f"{nm}.replicas"),
                                   _fifo(st.get("send_fifo", "unbounded"), w, f"{nm}.send_fifo"),
                                   _fifo(st.get("receive_fifo", "unbounded"), w, f"{nm}.receive_fifo"), spec,
                                   _feed(st.get("feed", "shared"), w, f"{nm}.feed")))
        ch["stages"] = tuple(out)
    if "ring" in data:
        def ring(v):
            _table(v, w, "ring", _RING)
            return RingConfig(_int(v.get("flit_time", 1), w, "ring.flit_time"),
                              _int(v.get("buffer_classes", 3), w, "ring.buffer_classes"))
        ch["ring"] = _optional(data, "ring", w, ring)
    for tag in ("ic", "sc"):
        key = f"{tag}_memory"
        if key in data:
            def local(v, key=key):
                _table(v, w, key, _LOCAL)
                cache = None
                if "cache" in v and v["cache"] != "none":
                    c = _table(v["cache"], w, f"{key}.cache", _CACHE)
                    cache = CacheConfig(*(_int(_need(c, k, w, f"{key}.cache"), w, f"{key}.cache.{k}")
                                          for k in ("size", "line", "ways")))
                return LocalMemoryConfig(_int(v.get("resident", 0), w, f"{key}.resident", lo=0), cache)
            ch[key] = _optional(data, key, w, local)
        gkey = f"{tag}gm"
        if gkey in data:
            def glob(v, gkey=gkey):
                _table(v, w, gkey, _GLOBAL)
                cont = v.get("contention", True)
                if not isinstance(cont, bool):
                    raise ConfigError(f"{w}{gkey}.contention: must be true or false, not {cont!r}")
                return GlobalMemoryConfig(_int(_need(v, "latency", w, gkey), w, f"{gkey}.latency", lo=0),
                                          _int(_need(v, "bandwidth", w, gkey), w, f"{gkey}.bandwidth"), cont)
            ch[gkey] = _optional(data, gkey, w, glob)
    ch["source"] = source
    if cfg is None:
        if "stages" not in ch:
            raise ConfigError(f"{w}stage: missing (give [[stage]] tables, or base = \"S\"|\"M\"|\"3mppe\")")
        try:
            out = SystemConfig(**ch)
            return _ruled(out) if out.window_rule == "auto" else out
        except TypeError as e:
            raise ConfigError(f"{w}{e}") from None
    # the base's checks ran without a file name; run them again with it
    out = dataclasses.replace(cfg, **ch)
    return _ruled(out) if ch.get("window_rule") == "auto" else out


def _ruled(cfg: SystemConfig) -> SystemConfig:
    """A configuration of ``window = "auto"``: its window the rule's most until a trace applies it."""
    return dataclasses.replace(cfg, window=rule_window(cfg))


def load_config(path) -> SystemConfig:
    """Read and check a machine configuration file (TOML)."""
    from ..settings import read_toml

    path = os.fspath(path)
    return config_from_dict(read_toml(path, "configuration", ConfigError), source=path)


def resolve(model: str | None = None, config_path=None, pes: int | None = None) -> SystemConfig:
    """The configuration a command asks for: a file, else a built-in model
    (default M); ``pes`` overrides the number of PEs."""
    if config_path and model:
        raise ConfigError("give --model or --config, not both (a file may start from a model with base = ...)")
    cfg = load_config(config_path) if config_path else builtin(model or "M")
    if pes is not None:
        cfg = cfg.replace(pes=_int(pes, "", "--pes"))
    return cfg


def _toml_value(v) -> str:
    """A TOML value of the machine file's kinds: strings, booleans, integers, floats, inline tables."""
    import json
    import math

    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ConfigError(f"a machine file holds finite numbers only, not {v!r}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }" if v else "{}"
    raise ConfigError(f"a machine file cannot hold {type(v).__name__} {v!r}")


def config_toml(cfg: SystemConfig, header: str = "") -> str:
    """The machine file of a configuration: TOML that ``load_config`` reads back as an equal
    configuration (``window = "auto"`` where it has that rule).  ``header``: comment lines first."""
    out = [f"# {line}".rstrip() for line in header.splitlines()]
    out += [f"name = {_toml_value(cfg.name)}", f"pes = {cfg.pes}", f"dis = {_toml_value(cfg.dis)}",
            f"window = {_toml_value(cfg.window_rule) if cfg.window_rule else cfg.window}"]
    for key, part in (("ring", cfg.ring), ("ic_memory", cfg.ic_memory), ("sc_memory", cfg.sc_memory),
                      ("icgm", cfg.icgm), ("scgm", cfg.scgm)):
        if part is None:
            out.append(f'{key} = "none"')
    for s in cfg.stages:
        spec = s.processor_spec
        if not isinstance(spec, (str, dict)):
            raise ConfigError(f"stage {s.name}: its processor was given as an object, which a machine file "
                              f"cannot hold (give 'sequential', 'paper' or a table)")
        out += ["", "[[stage]]", f"subtasks = {_toml_value(list(s.subtasks))}", f"processor = {_toml_value(spec)}",
                f"replicas = {s.replicas}",
                f"send_fifo = {_toml_value('unbounded' if s.send_fifo is None else s.send_fifo)}",
                f"receive_fifo = {_toml_value('unbounded' if s.receive_fifo is None else s.receive_fifo)}",
                f"feed = {_toml_value(s.feed)}"]
    if cfg.ring is not None:
        out += ["", "[ring]", f"flit_time = {cfg.ring.flit_time}", f"buffer_classes = {cfg.ring.buffer_classes}"]
    for key, mem in (("ic_memory", cfg.ic_memory), ("sc_memory", cfg.sc_memory)):
        if mem is not None:
            out += ["", f"[{key}]", f"resident = {mem.resident}"]
            out.append("cache = " + ('"none"' if mem.cache is None else
                                     _toml_value({"size": mem.cache.size, "line": mem.cache.line,
                                                  "ways": mem.cache.ways})))
    for key, gm in (("icgm", cfg.icgm), ("scgm", cfg.scgm)):
        if gm is not None:
            out += ["", f"[{key}]", f"latency = {gm.latency}", f"bandwidth = {gm.bandwidth}",
                    f"contention = {_toml_value(gm.contention)}"]
    return "\n".join(out) + "\n"
