"""The SimPy machine model's result from plain counters.

The compiled replay (and level 0) count what the SimPy model counts: per
processor its busy and blocked cycles and visits, per stage its FIFOs' figures
and local queue, per PE its DIS and the costs of the visits it ran.  Views
shaped like the model's parts hold those counters, and the model's own
``System._result`` and ``System._deadlock`` turn them into a ``SimResult`` or a
``DeadlockError``, so a result cannot differ from SimPy's in how it is summed
or worded.  The counters come as numpy records of the C library's
``mprt_replay_proc``, ``mprt_replay_node`` and ``mprt_replay_pe`` layouts.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .._lowlevel import REPLAY_NODE_DTYPE, REPLAY_PE_DTYPE, REPLAY_PROC_DTYPE
from ..machine.fifo import Fifo
from ..machine.pe import PE
from ..machine.ring import Ring
from ..machine.stage import Stage
from ..machine.system import System

__all__ = ["SystemView", "REPLAY_NODE_DTYPE", "REPLAY_PE_DTYPE", "REPLAY_PROC_DTYPE"]


class _FifoView:
    """A FIFO at the end of the run, as ``Fifo``'s own reports read it."""

    mean = Fifo.mean
    state = Fifo.state

    def __init__(self, name, capacity, occupancy, maximum, puts, area, end, waiters, reserved=0):
        self.name, self.capacity = name, capacity
        self.items = range(occupancy)
        self.reserved = reserved
        self.max, self.puts, self.area, self.last = maximum, puts, area, end
        self.waiters = waiters


class _Named:
    def __init__(self, name):
        self.name = name


class _StageView:
    state_of = Stage.state_of

    def __init__(self, name, cfg, procs, node, receive, send, stall=None):
        self.name, self.cfg, self.n = name, cfg, len(procs)
        self.busy = procs["busy"].tolist()
        self.blocked = procs["blocked"].tolist()
        self.visits = procs["visits"].tolist()
        self.state = procs["state"].tolist()
        self.cur = procs["visit"].tolist()
        self.pending = [range(p) for p in procs["pending"].tolist()]
        self.stall = [0] * self.n if stall is None else stall.tolist()
        self.generated = int(node["generated"])
        self.local = range(int(node["local_queue"]))
        self.receive, self.send = receive, send


class _IdealNet:
    def state(self):
        return {"network": "ideal"}

    def link_utilisation(self, end):
        return []


class _RingView:
    """A PE's ring at the end of the run, as ``Ring``'s own reports read it: the links'
    busy cycles, the buffers (source x 4 + destination stage of the packet holding each,
    -1 free) and the waiting packets (source, destination, node, phase)."""

    state = Ring.state
    link_utilisation = Ring.link_utilisation

    def __init__(self, stages, classes, link_cycles, buffers, waiting):
        self.stages, self.C, self.K = stages, classes, len(stages)
        self.link_cycles = [int(c) for c in link_cycles]

        def packet(src, dst, node=0, phase=0):
            return SimpleNamespace(src=int(src), dst=int(dst), node=int(node), phase=int(phase))
        self.buf = [[None if b < 0 else packet(b >> 2, b & 3) for b in row] for row in buffers.tolist()]
        self.waiting = [packet(*w) for w in waiting.tolist()]


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

    def __init__(self, pes, n_visits, n_rays, max_leaves):
        self.tree_process = np.stack([p["processing"] for p in pes]).astype(np.int64)
        self.tree_comm = np.stack([p["communication"] for p in pes]).astype(np.int64)
        self.tree_visits = np.stack([p["visits"] for p in pes]).astype(np.int64)
        self.n_visits, self.n_rays, self.max_leaves = n_visits, n_rays, max_leaves


def no_waiters(pe, stage, which):
    return []


def _memories(pes, figs, stall, residents):
    """``System.memories`` from the C replay's figures: figs[pe, memory] (REPLAY_MEMORY_DTYPE,
    memory 0 IC, 1 SC); residents: tag -> (bytes used, bytes, has a cache)."""
    out = {}
    for t, tag in enumerate(("ic", "sc")):
        if tag not in residents:
            continue
        used, size, cached = residents[tag]
        f = figs[:, t]

        def total(k, f=f):
            return int(f[k].sum())
        out[tag] = {"gm": SimpleNamespace(accesses=total("gm_accesses"), busy=total("gm_busy"),
                                          queued=total("gm_queued")),
                    "resident": SimpleNamespace(accesses=total("resident_accesses"), hits=total("resident_hits"),
                                                used=used, size=size),
                    "local": [SimpleNamespace(pe=p, stall_cycles=int(f["stall"][p]),
                                              cache=SimpleNamespace(accesses=int(f["cache_accesses"][p]),
                                                                    hits=int(f["cache_hits"][p])) if cached else None)
                              for p in range(pes)]}
    return out


class SystemView:
    """A finished (or deadlocked) machine as ``System`` reports it.

    ``end``: the run's time; ``pes``, ``procs``, ``nodes``: counter records
    (PE order; processors by PE, stage, replica; stages by PE, stage);
    ``waiters(pe, stage, which)``: who waits for a receive (0: stage indices,
    -1 the DIS) or send (1: replicas) FIFO slot; ``ring``: None (the ideal
    network) or (link busy cycles int64[pes, stages], ``state(pe)`` giving a
    PE's ring buffers and waiting packets, see ``_RingView``)."""

    _result = System._result
    _deadlock = System._deadlock

    def __init__(self, trace, config, end, retired, pes, procs, nodes, gen_process, gen_send, n_visits, n_rays,
                 max_leaves, waiters=no_waiters, ring=None, memory=None):
        self.trace, self.config, self.log = trace, config, None
        self.timeline = None
        self.memories = {} if memory is None else _memories(config.pes, *memory)
        stalls = None if memory is None else memory[1]
        self.gen_process, self.gen_send = gen_process, gen_send
        self.t_end = int(end)
        self.retired = int(retired)
        self.replay = _ReplayView(pes, n_visits, n_rays, max_leaves)
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
                         for w in waiters(p, s, 0)]
                recv = _FifoView(name + ".receive", sc.receive_fifo, int(nd["receive_occupancy"]),
                                 int(nd["receive_max"]), int(nd["receive_puts"]), int(nd["receive_area"]),
                                 self.t_end, rwait, int(nd["receive_reserved"]))
                send = _FifoView(name + ".send", sc.send_fifo, int(nd["send_occupancy"]), int(nd["send_max"]),
                                 int(nd["send_puts"]), int(nd["send_area"]), self.t_end, waiters(p, s, 1))
                stages.append(_StageView(name, sc, procs[first:first + sc.replicas], nd, recv, send,
                                         None if stalls is None else stalls[first:first + sc.replicas]))
                self.names += [(name, k) for k in range(sc.replicas)]
                first += sc.replicas
                n += 1
            self.pes.append(_PEView(p, stages, pes[p]))
            if ring is not None:
                self.pes[-1].net = _RingView(stages, config.ring.buffer_classes, ring[0][p], *ring[1](p))

    def result(self):
        return self._result()

    def deadlock(self):
        return self._deadlock()
