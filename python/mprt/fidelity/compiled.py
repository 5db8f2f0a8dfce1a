"""The compiled engine: the C replay (``mprt_replay_*`` in mprt.h) of the
machine model's ideal-network configurations, with the SimPy model's result.

``replay(trace, config)`` takes what ``mprt.machine.simulate`` takes and
returns the same ``SimResult`` (same cycles, same per-stage processing,
communication and waiting, same FIFO, processor and PE figures), or raises
the same ``DeadlockError``.  It supports every configuration without a ring
(level 2) and without modelled memories (level 3): any stages, mapping,
replicas, FIFO capacities, PEs, DIS policy and window.  ``unsupported(config)``
says why a configuration is not one of those.

The costs per visit are the cost model's (``visit_costs`` on the
configuration's processors) or the arrays given, exactly as the SimPy model
takes them.  The figures are assembled by the machine model's own
``System._result`` and ``System._deadlock`` over views of the C replay's
counters, so a result cannot differ from SimPy's in how it is summed.
"""
from __future__ import annotations

import time

import numpy as np

from .._lowlevel import binding
from ..errors import InvalidArgument
from ..machine.config import DIS_POLICIES, SUBTASKS, SystemConfig, builtin
from ..machine.errors import ConfigError
from ..machine.fifo import Fifo
from ..machine.pe import PE
from ..machine.stage import Stage
from ..machine.system import System
from ..trace import TraceError

_LIB = binding("double")
_DIS = {name: i for i, name in enumerate(DIS_POLICIES)}     # blocks, interleaved, dynamic: mprt_dis order


def unsupported(config: SystemConfig) -> str | None:
    """Why the compiled engine cannot replay a configuration (None: it can)."""
    parts = []
    if config.ring is not None:
        parts.append("a ring network (level 2)")
    if config.ic_memory is not None or config.sc_memory is not None:
        parts.append("modelled memories (level 3)")
    if not parts:
        return None
    return (f"configuration {config.name!r} has {' and '.join(parts)}; the compiled engine replays ideal-network, "
            "ideal-memory machines only (use the SimPy engine, or --level 1)")


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
            "pes": config.pes, "dis": _DIS[config.dis], "window": config.window, "gen_cycles": gen_cycles}


# ---- views of the C replay's counters, shaped as the SimPy model's parts ------------------

class _FifoView:
    """A FIFO at the end of the run, as ``Fifo``'s own reports read it."""

    mean = Fifo.mean
    state = Fifo.state

    def __init__(self, name, capacity, occupancy, maximum, puts, area, end, waiters):
        self.name, self.capacity = name, capacity
        self.items = range(occupancy)
        self.reserved = 0
        self.max, self.puts, self.area, self.last = maximum, puts, area, end
        self.waiters = waiters


class _Named:
    def __init__(self, name):
        self.name = name


class _StageView:
    state_of = Stage.state_of

    def __init__(self, name, cfg, procs, node, receive, send):
        self.name, self.cfg, self.n = name, cfg, len(procs)
        self.busy = procs["busy"].tolist()
        self.blocked = procs["blocked"].tolist()
        self.visits = procs["visits"].tolist()
        self.state = procs["state"].tolist()
        self.cur = procs["visit"].tolist()
        self.pending = [range(p) for p in procs["pending"].tolist()]
        self.stall = [0] * self.n
        self.generated = int(node["generated"])
        self.local = range(int(node["local_queue"]))
        self.receive, self.send = receive, send


class _IdealNet:
    def state(self):
        return {"network": "ideal"}

    def link_utilisation(self, end):
        return []


class _PEView:
    state = PE.state

    def __init__(self, index, stages, pe):
        self.index, self.stages = index, stages
        self.live, self.max_live = int(pe["live"]), int(pe["max_live"])
        self.retired, self.t_end = int(pe["retired"]), int(pe["end"])
        self.dis = _Named(f"PE{index}.DIS")
        self.dis.admitted = int(pe["admitted"])
        self.dis.pending = 0 if pe["dis_holding"] else None
        self.net = _IdealNet()


class _ReplayView:
    """Per-PE sums standing for the SimPy replay's per-tree sums (one 'tree' per PE)."""

    def __init__(self, pes, info):
        self.tree_process = np.stack([p["processing"] for p in pes]).astype(np.int64)
        self.tree_comm = np.stack([p["communication"] for p in pes]).astype(np.int64)
        self.tree_visits = np.stack([p["visits"] for p in pes]).astype(np.int64)
        self.n_visits, self.n_rays, self.max_leaves = int(info["visits"]), int(info["rays"]), int(info["max_leaves"])


class _SystemView:
    _result = System._result
    _deadlock = System._deadlock

    def __init__(self, trace, config, h, info, gen_process, gen_send):
        self.trace, self.config, self.log = trace, config, None
        self.timeline = None
        self.memories = {}
        self.gen_process, self.gen_send = gen_process, gen_send
        self.t_end = max(int(info["cycles"]), 0)
        self.retired = int(info["retired"])
        pes = _LIB.replay_get_pes(h, int(info["pes"]))
        procs = _LIB.replay_get_procs(h, int(info["processors"]))
        nodes = _LIB.replay_get_nodes(h, int(info["nodes"]))
        self.replay = _ReplayView(pes, info)
        self.tree_pe = np.arange(config.pes, dtype=np.int32)
        self.names = []
        self.pes = []
        first, n = 0, 0
        for p in range(config.pes):
            stages = []
            for s, sc in enumerate(config.stages):
                name = f"PE{p}.{sc.name}"
                nd = nodes[n]
                rwait = [_Named(f"PE{p}.DIS") if w < 0 else _Named(f"PE{p}.{config.stages[w].name}")
                         for w in _LIB.replay_get_waiters(h, p, s, 0)]
                swait = _LIB.replay_get_waiters(h, p, s, 1)
                recv = _FifoView(name + ".receive", sc.receive_fifo, int(nd["receive_occupancy"]),
                                 int(nd["receive_max"]), int(nd["receive_puts"]), int(nd["receive_area"]),
                                 self.t_end, rwait)
                send = _FifoView(name + ".send", sc.send_fifo, int(nd["send_occupancy"]), int(nd["send_max"]),
                                 int(nd["send_puts"]), int(nd["send_area"]), self.t_end, swait)
                stages.append(_StageView(name, sc, procs[first:first + sc.replicas], nd, recv, send))
                self.names += [(name, k) for k in range(sc.replicas)]
                first += sc.replicas
                n += 1
            self.pes.append(_PEView(p, stages, pes[p]))


def _log(view, log, events):
    """The C replay's events as the SimPy model's log: (cycle, 'start'|'end', stage name, replica, visit)."""
    ev = log[:4 * events].reshape(-1, 4)
    names = view.names
    return [(int(t), "end" if w else "start", names[i][0], names[i][1], int(j)) for t, w, i, j in ev.tolist()]


class Compiled:
    """A costed trace loaded into the C replay (16 bytes per visit), ready to
    run any ideal-network configuration whose processors the costs are for.

    ``costs``: per-visit ``process``, ``receive``, ``send`` arrays (and
    ``inject_process``, ``inject_send`` for SC's making of primary rays), as
    the cost model's ``visit_costs`` gives them."""

    def __init__(self, trace, costs):
        process, receive, send, self.gen_process, self.gen_send = _cost_arrays(trace, costs)
        self.trace = trace
        self.h = _LIB.replay_create({})
        try:
            _LIB.replay_load(self.h, np.asarray(trace.rays), np.asarray(trace.visits), process, receive, send)
        except InvalidArgument as e:
            msg = str(e)
            raise (TraceError(msg) if msg.startswith("cannot replay this trace:") else ValueError(msg)) from None
        self.info = _LIB.replay_get_info(self.h)

    def _configure(self, config: SystemConfig) -> None:
        why = unsupported(config)
        if why:
            raise ConfigError(why)
        where = f"{config.source}: " if config.source else ""
        try:
            _LIB.replay_set_config(self.h, c_config(config, self.gen_process + self.gen_send))
        except InvalidArgument as e:
            raise ConfigError(f"{where}{e}") from None

    def _run(self, config, log=None) -> bool:
        self._configure(config)
        try:
            return _LIB.replay_run(self.h, log)
        except InvalidArgument as e:
            where = f"{config.source}: " if config.source else ""
            raise ConfigError(f"{where}{e}") from None

    def cycles(self, config: SystemConfig) -> int:
        """The run's cycles (nothing else assembled); DeadlockError if it deadlocks."""
        if not self._run(config):
            raise _SystemView(self.trace, config, self.h, _LIB.replay_get_info(self.h), self.gen_process,
                              self.gen_send)._deadlock()
        return int(_LIB.replay_get_info(self.h)["cycles"])

    def result(self, config: SystemConfig, record: bool = False):
        """The SimPy model's SimResult for the configuration (``record``: with its event log),
        or its DeadlockError."""
        t0 = time.perf_counter()
        log = np.zeros(8 * (int(self.info["visits"]) + int(self.info["trees"])), np.int64) if record else None
        finished = self._run(config, log)
        info = _LIB.replay_get_info(self.h)
        view = _SystemView(self.trace, config, self.h, info, self.gen_process, self.gen_send)
        if record:
            view.log = _log(view, log, int(info["events"]))
        if not finished:
            raise view._deadlock()
        res = view._result()
        res.wall_seconds = time.perf_counter() - t0
        return res


def costs_for(trace, config: SystemConfig, cost_model=None):
    """The cost model's visit costs for a configuration's processors (default model)."""
    if cost_model is None:
        from ..cost import CostModel

        cost_model = CostModel.default()
    return cost_model.visit_costs(trace, config.processors())


def replay(trace, config: SystemConfig | str = "M", cost_model=None, costs=None, record: bool = False):
    """Replay a trace on an ideal-network configuration with the compiled
    engine: what ``mprt.machine.simulate`` returns (``record``: with its event
    log), or raises (DeadlockError, ConfigError for a configuration the
    compiled engine does not support, see ``unsupported``)."""
    if isinstance(config, str):
        config = builtin(config)
    why = unsupported(config)
    if why:
        raise ConfigError(why)
    t0 = time.perf_counter()
    res = Compiled(trace, costs if costs is not None else costs_for(trace, config, cost_model)).result(config, record)
    res.wall_seconds = time.perf_counter() - t0
    return res
