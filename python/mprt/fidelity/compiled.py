"""The compiled engine: the C replay (``mprt_replay_*`` in mprt.h) of the
machine model's configurations at levels 1 to 3 (the ideal network or the
ring, ideal memories or the modelled ones), with the SimPy model's result.

``replay(trace, config)`` takes what ``mprt.machine.simulate`` takes and
returns the same ``SimResult`` (same cycles, same per-stage processing,
communication and waiting, same FIFO, processor and PE figures), or raises
the same ``DeadlockError``.  It supports every configuration the SimPy model
models: any stages, mapping, replicas and their feeds, FIFO capacities, PEs,
DIS policy and window, on the ideal network or the ring (flit time, buffer
classes), with ideal memories or the memories of level 3 (caches, resident
memories, ICGM and SCGM with their ports; the per-key data from
``memdata.MemoryData``).  ``unsupported(config)`` is None for all of them; a
run refuses (ConfigError, before it starts) only caches whose arrays over all
PEs would exceed 2^28 entries (pes x entries per PE: a PE's sets x ways,
limited by the lines the trace's data can fill).

The costs per visit are the cost model's (``visit_costs`` on the
configuration's processors) or the arrays given, exactly as the SimPy model
takes them; on the ring also their ``flits`` and ``inject_flits``, and the
flits of the packets carrying the rays SC makes (``packet_flits("SC", "OS",
kind)``, the cost model's).  The figures are assembled by the machine model's own
``System._result`` and ``System._deadlock`` over views of the C replay's
counters, so a result cannot differ from SimPy's in how it is summed.
"""
from __future__ import annotations

import os
import time

import numpy as np

from .._lowlevel import binding
from ..errors import InvalidArgument
from ..machine.config import DIS_POLICIES, FEEDS, SUBTASKS, SystemConfig, builtin, check_config
from ..machine.errors import ConfigError
from ..trace import RAY_KINDS, TraceError
from ..trace.tracevalid import check_trace
from .memdata import MemoryData
from .views import SystemView

_LIB = binding("double")
_DIS = {name: i for i, name in enumerate(DIS_POLICIES)}     # blocks, interleaved, dynamic: mprt_dis order


THREADS_ENV = "MPRT_LOAD_THREADS"      # 1: the trace priced and loaded on one thread


def load_threads() -> int:
    """Threads pricing and loading a trace (``mprt_replay_load_priced_threads``: the visits priced
    on a second thread ahead of the loading, the same replay and errors): the cores, at most 2,
    or ``$MPRT_LOAD_THREADS``."""
    env = os.environ.get(THREADS_ENV, "").strip()
    if env.isdigit() and int(env) > 0:
        return int(env)
    return min(os.cpu_count() or 1, 2)


def unsupported(config: SystemConfig) -> str | None:
    """Why the compiled engine cannot replay a configuration (None: it can).  It replays
    every configuration the SimPy model models, so this is always None; the one thing a
    run still refuses depends on the trace too (caches whose arrays over all PEs exceed
    2^28 entries: a ConfigError from the run, before it starts)."""
    return None


def _cost_arrays(trace, costs):
    """(process, receive, send, inject_process, inject_send) as the SimPy model takes them."""
    arrays = tuple(np.asarray(getattr(costs, k)) for k in ("process", "receive", "send"))
    n = len(trace.visits)
    for k, a in zip(("process", "receive", "send"), arrays):
        if a.shape != (n,):
            raise ValueError(f"costs.{k} has shape {a.shape}, the trace has {n} visits")
    return arrays + (int(getattr(costs, "inject_process", 0)), int(getattr(costs, "inject_send", 0)))


def c_config(config: SystemConfig, gen_cycles: int) -> dict:
    """mprt_replay_config's fields for a machine configuration."""
    n = len(config.stages)
    pad = [0] * (3 - n)
    return {"nstages": n, "stage_of": [config.stage_of(t) for t in SUBTASKS],
            "replicas": [s.replicas for s in config.stages] + [1] * (3 - n),
            "receive_fifo": [s.receive_fifo or 0 for s in config.stages] + pad,
            "send_fifo": [s.send_fifo or 0 for s in config.stages] + pad,
            "feed": [FEEDS.index(s.feed) for s in config.stages] + pad,
            "pes": config.pes, "dis": _DIS[config.dis], "window": config.window, "gen_cycles": gen_cycles,
            # level 2: the ring
            "ring": int(config.ring is not None),
            "buffer_classes": config.ring.buffer_classes if config.ring is not None else 1,
            "flit_time": config.ring.flit_time if config.ring is not None else 1,
            **memory_config(config)}


def _line(mc) -> int:
    """The line size a local memory reads in (its cache's, else the SimPy model's 32 bytes)."""
    return mc.cache.line if mc.cache is not None else 32


def memory_config(config: SystemConfig) -> dict:
    """mprt_replay_config's level-3 fields (IC data, SC data)."""
    f = {k: [0, 0] for k in ("memory", "cache_size", "cache_line", "cache_ways", "gm_latency", "gm_bandwidth",
                            "gm_contention")}
    for t, (mc, gm) in enumerate(((config.ic_memory, config.icgm), (config.sc_memory, config.scgm))):
        if mc is None:
            continue
        f["memory"][t] = 1
        f["cache_line"][t] = _line(mc)
        if mc.cache is not None:
            f["cache_size"][t], f["cache_ways"][t] = mc.cache.size, mc.cache.ways
        f["gm_latency"][t], f["gm_bandwidth"][t], f["gm_contention"][t] = gm.latency, gm.bandwidth, int(gm.contention)
    return f


def _log(view, log, events):
    """The C replay's events as the SimPy model's log: (cycle, 'start'|'end', stage name, replica, visit)."""
    ev = log[:4 * events].reshape(-1, 4)
    names = view.names
    return [(int(t), "end" if w else "start", names[i][0], names[i][1], int(j)) for t, w, i, j in ev.tolist()]


class Compiled:
    """A costed trace loaded into the C replay (8 or 16 bytes per visit), ready to
    run any configuration whose processors the costs are for (``memory``: the
    trace's MemoryData, to share it between loads).

    ``costs``: per-visit ``process``, ``receive``, ``send`` arrays (and
    ``inject_process``, ``inject_send`` for SC's making of primary rays), as
    the cost model's ``visit_costs`` gives them; for the ring also ``flits``
    (and ``inject_flits``), with ``packet_flits(src, dst, kind)`` sizing the
    packets of the rays SC makes (default: the default cost model's)."""

    def __init__(self, trace, costs, packet_flits=None, memory: MemoryData | None = None):
        from ..cost.fast import Priced

        check_trace(trace)          # a trace built in memory: its ranges before C reads it
        self.trace = trace
        self.memory = memory if memory is not None else MemoryData.of(trace)
        self._sent = None            # the memory data the C replay holds: ((tag, resident, line) | None) x 2
        self._residents = {}
        self.h = _LIB.replay_create({})
        rays, visits = np.asarray(trace.rays), np.asarray(trace.visits)
        try:
            if isinstance(costs, Priced):       # priced by C as it loads: no per-visit arrays
                self.gen_process, self.gen_send = costs.inject_process, costs.inject_send
                rec = costs.records
                out = costs.load_flits()       # (the ring's: made in the same pass when wanted)
                try:
                    _LIB.replay_load_priced(self.h, rays, visits, costs.table, rec.children, rec.prim_kind, out,
                                            threads=load_threads())
                except InvalidArgument:
                    costs._flits = None if out is not None else costs._flits
                    raise
            else:
                process, receive, send, self.gen_process, self.gen_send = _cost_arrays(trace, costs)
                _LIB.replay_load(self.h, rays, visits, process, receive, send)
        except InvalidArgument as e:
            msg = str(e)
            raise (TraceError(msg) if msg.startswith(("cannot replay this trace:", "cannot cost this trace:"))
                   else ValueError(msg)) from None
        self.info = _LIB.replay_get_info(self.h)
        self.flits = hasattr(type(costs), "flits") or hasattr(costs, "flits")
        self._flits = None       # the ring's packet sizes, handed to C with the first ring run
        if self.flits:      # the ring's packet sizes, as the SimPy model's Replay takes them (read then)
            self._flits = (costs, packet_flits, int(getattr(costs, "inject_flits", 0)))

    def _set_flits(self) -> None:
        """Hand the C replay the packets' sizes (once: levels 1 and 3 without a ring need none)."""
        costs, packet_flits, inject = self._flits
        flits = np.asarray(costs.flits)
        if flits.shape != (len(self.trace.visits),):
            raise ValueError(f"costs.flits has shape {flits.shape}, the trace has {len(self.trace.visits)} visits")
        if packet_flits is None:
            from ..cost import CostModel

            packet_flits = CostModel.default().packet_flits
        kids = [packet_flits("SC", "OS", k) for k in range(len(RAY_KINDS))]
        try:
            _LIB.replay_set_flits(self.h, flits, kids, inject)
        except InvalidArgument as e:
            raise ValueError(str(e)) from None
        self._flits = ()

    def _configure(self, config: SystemConfig) -> None:
        """Hand the C replay the configuration and the memory data it reads."""
        check_config(config)
        why = unsupported(config)
        if why:
            raise ConfigError(why)
        if config.ring is not None and not self.flits:
            raise ValueError("costs.flits: the ring needs each visit's packet size (the costs have no flits)")
        if config.ring is not None and self._flits:
            self._set_flits()
        where = f"{config.source}: " if config.source else ""
        try:
            _LIB.replay_set_config(self.h, c_config(config, self.gen_process + self.gen_send))
        except InvalidArgument as e:
            raise ConfigError(f"{where}{e}") from None
        self._set_memory(config)

    def _set_memory(self, config: SystemConfig) -> None:
        """Hand the C replay the memory data the configuration reads (once per resident and
        line size: cache sizes, ways, latencies and ports need none)."""
        mems = (config.ic_memory, config.sc_memory)
        if mems == (None, None):
            return
        want = tuple(None if mc is None else (tag, mc.resident, _line(mc)) for tag, mc in zip(("ic", "sc"), mems))
        got = [None if w is None else self.memory.get(*w) for w in want]
        self._residents = {w[0]: g[1] for w, g in zip(want, got) if w is not None}
        if want != self._sent:
            self._sent = None
            _LIB.replay_set_memory(self.h, self.memory.replay_keys, *(None if g is None else g[0] for g in got))
            self._sent = want

    def _run(self, config, log=None) -> bool:
        self._configure(config)
        try:
            return _LIB.replay_run(self.h, log)
        except InvalidArgument as e:
            where = f"{config.source}: " if config.source else ""
            raise ConfigError(f"{where}{e}") from None

    def _view(self, config: SystemConfig) -> SystemView:
        info = _LIB.replay_get_info(self.h)
        memory = None
        if config.ic_memory is not None or config.sc_memory is not None:
            figs, stall = _LIB.replay_get_memory(self.h, int(info["pes"]), int(info["processors"]))
            res = {tag: (self._residents[tag].used, mc.resident, mc.cache is not None)
                   for tag, mc in (("ic", config.ic_memory), ("sc", config.sc_memory)) if mc is not None}
            memory = (figs, stall, res)
        return SystemView(self.trace, config, max(int(info["cycles"]), 0), info["retired"],
                          _LIB.replay_get_pes(self.h, int(info["pes"])),
                          _LIB.replay_get_procs(self.h, int(info["processors"])),
                          _LIB.replay_get_nodes(self.h, int(info["nodes"])), self.gen_process, self.gen_send,
                          int(info["visits"]), int(info["rays"]), int(info["max_leaves"]),
                          lambda p, s, which: _LIB.replay_get_waiters(self.h, p, s, which), self._ring(config),
                          memory)

    def _ring(self, config: SystemConfig):
        """The ring's figures of the last run (None: the ideal network): each link's busy
        cycles per PE, and a PE's buffers and waiting packets (views.RingView's)."""
        if config.ring is None:
            return None
        K, C = len(config.stages), config.ring.buffer_classes
        return (_LIB.replay_get_links(self.h, config.pes, K),
                lambda p: _LIB.replay_get_ring(self.h, p, K, C))

    def work_bound(self, config: SystemConfig) -> int:
        """A lower bound of the configuration's cycles at any level, nothing run
        (``mprt_replay_work_bound``: each stage's work over its processors, PE by PE as the
        DIS deals the trees, and the trees' lifetimes over the window, with the reads no
        memory can spare, every line without a cache and the misses no state of a cache
        avoids; the ring and the memories' other stalls only add to a run)."""
        self._configure(config)
        try:
            return _LIB.replay_work_bound(self.h)
        except InvalidArgument as e:
            raise ConfigError(f"{config.source}: {e}" if config.source else str(e)) from None

    def cycles(self, config: SystemConfig) -> int:
        """The run's cycles (nothing else assembled); DeadlockError if it deadlocks."""
        if not self._run(config):
            raise self._view(config).deadlock()
        return int(_LIB.replay_get_info(self.h)["cycles"])

    def admissions(self) -> np.ndarray:
        """When each tree was admitted in the last run (int64 per tree, -1: never)."""
        return _LIB.replay_get_trees(self.h, int(self.info["trees"]))[1]

    def probe(self, config: SystemConfig):
        """Run with the busy record: (cycles, admitted int64[trees], busy int64[trees, stages]:
        each stage's busy cycles at each tree's admission, all its processors together);
        DeadlockError if it deadlocks."""
        _LIB.replay_record_busy(self.h, True)
        try:
            if not self._run(config):
                raise self._view(config).deadlock()
        finally:
            _LIB.replay_record_busy(self.h, False)
        cycles = int(_LIB.replay_get_info(self.h)["cycles"])
        return cycles, self.admissions(), _LIB.replay_get_tree_busy(self.h, int(self.info["trees"]),
                                                                      len(config.stages))

    def result(self, config: SystemConfig, record: bool = False):
        """The SimPy model's SimResult for the configuration (``record``: with its event log),
        or its DeadlockError."""
        t0 = time.perf_counter()
        log = np.zeros(8 * (int(self.info["visits"]) + int(self.info["trees"])), np.int64) if record else None
        finished = self._run(config, log)
        view = self._view(config)
        if record:
            view.log = _log(view, log, int(_LIB.replay_get_info(self.h)["events"]))
        if not finished:
            raise view.deadlock()
        res = view.result()
        res.wall_seconds = time.perf_counter() - t0
        return res


def priced_for(trace, config: SystemConfig, cost_model=None):
    """The visit costs for a configuration's processors left for C to compute as ``Compiled``
    loads the trace (``cost.fast.Priced``: the default arithmetic, no per-visit arrays), or None
    where only arrays serve (another cost model, records not in the C layout): ``costs_for``."""
    from ..cost import CostModel
    from ..cost import fast
    from ..cost.counts import CountedCostModel

    if cost_model is None:
        cost_model = CostModel.default()
    # (a counted model prices with the same constants and arithmetic: its arrays are the same)
    if type(cost_model) not in (CostModel, CountedCostModel) or not fast.usable(trace):
        return None
    check_trace(trace)
    return fast.Priced(cost_model, trace, config.processors(), flits=config.ring is not None)


def costs_for(trace, config: SystemConfig, cost_model=None):
    """The cost model's visit costs for a configuration's processors (default model)."""
    check_trace(trace)              # a trace built in memory: its ranges before it is priced
    if cost_model is None:
        from ..cost import CostModel

        cost_model = CostModel.default()
    return cost_model.visit_costs(trace, config.processors())


def replay(trace, config: SystemConfig | str = "M", cost_model=None, costs=None, record: bool = False,
           packet_flits=None):
    """Replay a trace on a configuration with the compiled engine (any level: the
    ring, the memories): what ``mprt.machine.simulate`` returns (``record``: with
    its event log), or raises (DeadlockError, ConfigError for a configuration
    the compiled engine refuses, see ``unsupported``).
    ``packet_flits``: as ``simulate``'s (default: the cost model's)."""
    if isinstance(config, str):
        config = builtin(config)
    why = unsupported(check_config(config))
    if why:
        raise ConfigError(why)
    t0 = time.perf_counter()
    if packet_flits is None and cost_model is not None:
        packet_flits = cost_model.packet_flits
    res = Compiled(trace, costs if costs is not None else costs_for(trace, config, cost_model),
                   packet_flits).result(config, record)
    res.wall_seconds = time.perf_counter() - t0
    return res

