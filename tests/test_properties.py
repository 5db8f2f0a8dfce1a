"""Properties over every machine configuration (Hypothesis), where a property says more
than a corpus (issue 19):

- any valid configuration, levels 1 to 3 (stages in any mapping and order, processors,
  replicas and feeds, FIFOs, the ring, caches, resident memories, global memories and
  their ports, PEs, DIS policies, windows), replayed on a small golden trace: SimPy and
  the compiled replay give the same SimResult in every figure, or both raise the same
  error (class and message; a DeadlockError with the same state);
- any configuration made invalid in one field: building it raises a one-line ConfigError
  naming the field, and the same object changed after it was built (bypassing the
  dataclass's check) is refused by both engines with that same ConfigError.

Deterministic (derandomize: the same examples on every run), a few seconds each."""
import dataclasses
import os

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mprt
from mprt.errors import MprtError
from mprt.fidelity import replay
from mprt.machine import ConfigError, DeadlockError, SystemConfig, make_stage, simulate
from mprt.machine.config import (DIS_POLICIES, FEEDS, LIMITS, CacheConfig, GlobalMemoryConfig, LocalMemoryConfig,
                                 RingConfig)

from test_fidelity import head, same

HERE = os.path.dirname(os.path.abspath(__file__))
TRACES = {n: os.path.join(HERE, "data", "golden", n + ".npz") for n in ("balls-g4", "rings-g9", "mount-g4",
                                                                         "tetra-g4")}
TRACES["fuzz-base"] = os.path.join(HERE, "fuzz", "trace_base.npz")
SETTINGS = settings(max_examples=70, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))
_LOADED: dict = {}


def trace(name: str, trees: int):
    if name not in _LOADED:
        _LOADED[name] = mprt.load_trace(TRACES[name])
    return head(_LOADED[name], trees)


# ---- strategies ------------------------------------------------------------------------

UNITS = st.one_of(st.fixed_dictionaries({"general": st.integers(1, 2)}),
                  st.fixed_dictionaries({"int": st.integers(1, 3), "fp": st.integers(1, 3)},
                                        optional={"mem": st.integers(1, 2), "fdiv": st.integers(1, 2)}))


@st.composite
def processors(draw, subtasks):
    """'sequential', the paper's processors, or a table of units, latencies and issue width."""
    kind = draw(st.sampled_from(["sequential", "paper", "table"]))
    if kind == "paper":
        return draw(st.sampled_from(["paper:OS", "paper:IC", "paper:SC"] + (["paper"] if len(subtasks) == 1 else [])))
    if kind == "table":
        table = {"units": draw(UNITS), "issue_width": draw(st.integers(1, 4)), "pipelined": draw(st.booleans())}
        if draw(st.booleans()):
            table["latency"] = {"fadd": draw(st.integers(1, 6)), "fmul": draw(st.integers(1, 6))}
        return table
    return "sequential"


@st.composite
def stages(draw):
    order = draw(st.permutations(["OS", "IC", "SC"]))
    cuts = sorted(draw(st.sets(st.sampled_from([1, 2]))))
    groups = [tuple(order[a:b]) for a, b in zip([0] + cuts, cuts + [3])]
    out = []
    for subs in groups:
        finite = draw(st.booleans())
        fifo = st.one_of(st.none(), st.integers(1, 8)) if finite else st.none()
        out.append(make_stage(subs, draw(processors(subs)), replicas=draw(st.integers(1, 3)),
                              send_fifo=draw(fifo), receive_fifo=draw(fifo), feed=draw(st.sampled_from(FEEDS))))
    return tuple(out)


@st.composite
def memories(draw):
    resident = draw(st.sampled_from([0, 0, 16, 64, 200, 1024, 1 << 40]))
    cache = None
    if draw(st.booleans()):
        line, ways, sets = (draw(st.sampled_from([1, 4, 8, 16, 32, 64])), draw(st.integers(1, 4)),
                            draw(st.sampled_from([1, 2, 3, 4, 8, 64])))
        cache = CacheConfig(line * ways * sets, line, ways)
    return LocalMemoryConfig(resident, cache)


GLOBAL = st.builds(GlobalMemoryConfig, st.sampled_from([0, 1, 5, 20, 100]), st.sampled_from([1, 3, 8, 64]),
                   st.booleans())


@st.composite
def configs(draw, level=None):
    sts = draw(stages())
    level = draw(st.integers(1, 3)) if level is None else level
    ring = None
    if level >= 2 and len(sts) >= 2 and (level == 2 or draw(st.booleans())):
        ring = RingConfig(draw(st.integers(1, 3)), draw(st.integers(1, len(sts))))
    ic = sc = icgm = scgm = None
    if level == 3:
        ic = draw(st.one_of(st.none(), memories()))
        sc = draw(st.one_of(st.none(), memories())) if ic else draw(memories())
        icgm = draw(GLOBAL) if ic else None
        scgm = draw(GLOBAL) if sc else None
    return SystemConfig("drawn", sts, ring=ring, ic_memory=ic, sc_memory=sc, icgm=icgm, scgm=scgm,
                        pes=draw(st.integers(1, 3)), dis=draw(st.sampled_from(DIS_POLICIES)),
                        window=draw(st.sampled_from([1, 2, 4, 16, 256])))


TRACE_CHOICE = st.tuples(st.sampled_from(sorted(TRACES)), st.sampled_from([3, 8, 20]))


def outcome(fn):
    try:
        return fn()
    except MprtError as e:
        return e


def assert_engines_agree(t, cfg):
    a, b = outcome(lambda: simulate(t, cfg)), outcome(lambda: replay(t, cfg))
    assert type(a) is type(b), (cfg, a, b)
    if isinstance(a, MprtError):
        assert str(a) == str(b), cfg
        if isinstance(a, DeadlockError):
            assert a.state == b.state, cfg
        else:
            assert "\n" not in str(a), cfg
    else:
        assert a.cycles == b.cycles, cfg
        assert same(a, b), cfg
    return a


# ---- valid configurations: the engines agree --------------------------------------------

@pytest.mark.parametrize("level", [1, 2, 3])
@SETTINGS
@given(data=st.data())
def test_any_valid_configuration_replays_the_same_on_both_engines(level, data):
    cfg = data.draw(configs(level))
    name, trees = data.draw(TRACE_CHOICE)
    assert (cfg.level == 3) == (level == 3) and (level > 1 or cfg.ring is None)
    assert_engines_agree(trace(name, trees), cfg)


# ---- malformed configurations: one ConfigError, the same from both engines ---------------

def _stage_change(cfg, i, **change):
    sts = list(cfg.stages)
    sts[i % len(sts)] = dataclasses.replace(sts[i % len(sts)], **change)
    return {"stages": tuple(sts)}


BAD_INTS = [0, -1, 1.5, True, "2", None]


@st.composite
def breakages(draw, cfg):
    """(field named in the message, changes to the configuration's fields) making it invalid."""
    n = len(cfg.stages)
    what = draw(st.sampled_from(["pes", "window", "dis", "name", "replicas", "send_fifo", "receive_fifo", "feed",
                                 "subtasks", "ring", "cache", "resident", "gm", "no_gm"]))
    i = draw(st.integers(0, 2))
    if what in ("pes", "window"):
        return what, {what: draw(st.sampled_from([x for x in BAD_INTS if x is not None] + [LIMITS[what] + 1]))}
    if what == "dis":
        return "dis", {"dis": draw(st.sampled_from(["x", "Dynamic", None]))}
    if what == "name":
        return "name", {"name": ""}
    if what == "replicas":
        return "replicas", _stage_change(cfg, i, replicas=draw(st.sampled_from([0, -2, 2.0, LIMITS["replicas"] + 1])))
    if what in ("send_fifo", "receive_fifo"):
        return what, _stage_change(cfg, i, **{what: draw(st.sampled_from([0, -3, "8", LIMITS[what] + 1]))})
    if what == "feed":
        return "feed", _stage_change(cfg, i, feed=draw(st.sampled_from(["fifo", None])))
    if what == "subtasks":
        return "subtasks", _stage_change(cfg, i, subtasks=draw(st.sampled_from([(), ("XX",), ("OS", "OS")])))
    if what == "ring":
        if n < 2:
            return "ring", {"ring": RingConfig(1, 1)}
        ft, bc, field = draw(st.sampled_from([(0, 1, "flit_time"), (LIMITS["flit_time"] + 1, 1, "flit_time"),
                                              (True, 1, "flit_time"), (1, 0, "buffer_classes"),
                                              (1, n + 1, "buffer_classes")]))
        return field, {"ring": RingConfig(ft, bc)}
    mem = LocalMemoryConfig(64, CacheConfig(256, 16, 2))
    gm = GlobalMemoryConfig(5, 8, True)
    if what == "cache":
        c = draw(st.sampled_from([CacheConfig(100, 16, 2), CacheConfig(96, 3, 1), CacheConfig(8, 16, 1),
                                  CacheConfig(1 << 41, 16, 1), CacheConfig(0, 16, 1), CacheConfig(256, 16, 0)]))
        return "cache", {"ic_memory": LocalMemoryConfig(0, c), "icgm": gm}
    if what == "resident":
        return "resident", {"sc_memory": LocalMemoryConfig(draw(st.sampled_from([-1, (1 << 40) + 1, 0.5])), None),
                            "scgm": gm}
    if what == "gm":
        bad = draw(st.sampled_from([GlobalMemoryConfig(-1, 8), GlobalMemoryConfig(LIMITS["latency"] + 1, 8),
                                    GlobalMemoryConfig(5, 0), GlobalMemoryConfig(5, 8, 1),
                                    GlobalMemoryConfig(5, 8, "yes")]))
        return "gm", {"ic_memory": mem, "icgm": bad}
    return "gm", {"ic_memory": mem, "icgm": None}


@SETTINGS
@given(data=st.data())
def test_any_malformed_configuration_is_refused_alike_by_both_engines(data):
    cfg = data.draw(configs())
    field, change = data.draw(breakages(cfg))
    with pytest.raises(ConfigError) as built:
        cfg.replace(**change)
    msg = str(built.value)
    assert "\n" not in msg and field in msg, msg
    broken = dataclasses.replace(cfg)           # a valid copy, then changed past its check
    for k, v in change.items():
        object.__setattr__(broken, k, v)
    name, trees = data.draw(TRACE_CHOICE)
    t = trace(name, trees)
    for engine in (simulate, replay):
        with pytest.raises(ConfigError) as e:
            engine(t, broken)
        assert str(e.value) == msg, engine.__name__


def test_the_strategies_reach_every_outcome():
    """The drawn configurations run, deadlock and stall on memory (the property is not vacuous)."""
    seen = {"ran": 0, "deadlock": 0, "memory": 0, "ring": 0}

    @settings(max_examples=40, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(cfg=configs(3), choice=TRACE_CHOICE)
    def run(cfg, choice):
        r = assert_engines_agree(trace(*choice), cfg)
        if isinstance(r, DeadlockError):
            seen["deadlock"] += 1
        elif not isinstance(r, MprtError):
            seen["ran"] += 1
            seen["memory"] += any(s["memory_stall"] for s in r.stages.values())
            seen["ring"] += cfg.ring is not None
    run()
    assert all(seen.values()), seen
