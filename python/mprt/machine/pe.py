"""PE: one processing element (its stages, network, memories) and its share
of DIS, the load distributor that admits primary rays under a window."""
from __future__ import annotations

from .stage import Stage


class DIS:
    """Admits this PE's primary rays (in its order) while fewer than
    ``window`` rays are live in the PE.  An admitted primary is work for the
    stage running SC, which makes the ray and sends it to OS (the paper's SC
    makes the primary rays); when the cost model gives that work no cycles,
    the primary goes straight to the stage running OS instead.  The work
    goes into that stage's receive FIFO (or to an idle processor there);
    when the FIFO is full the DIS waits for a slot, holding it."""

    def __init__(self, pe, order, window: int):
        self.pe = pe
        self.name = f"PE{pe.index}.DIS"
        self.order = iter(order)
        self.window = window
        self.pending = None
        self.admitted = 0

    def admit(self) -> None:
        if self.pending is not None:
            return
        pe = self.pe
        system = pe.system
        gen = system.gen_cycles > 0
        dst = pe.stages[pe.sc_stage if gen else pe.os_stage]
        while pe.live < self.window:
            k = next(self.order, None)
            if k is None:
                return
            x = system.replay.ensure_tree(k)
            if gen:
                x = ~k
            system.tree_pe[k] = pe.index
            pe.live += 1
            if pe.live > pe.max_live:
                pe.max_live = pe.live
            self.admitted += 1
            if dst.room():
                dst.accept(x)
            else:
                self.pending = x
                dst.receive.waiters.append(self)
                return

    def release(self) -> None:
        """A slot of the OS receive FIFO is ours: the held primary goes in."""
        x, self.pending = self.pending, None
        self.pe.stages[self.pe.os_stage if x >= 0 else self.pe.sc_stage].accept(x)
        self.admit()


class PE:
    """A processing element: stages in ring order, their network (ideal or
    ring), local memories, and its DIS."""

    def __init__(self, system, index: int, order, first_rank: int):
        cfg = system.config
        self.system = system
        self.index = index
        self.live = 0
        self.max_live = 0
        self.retired = 0
        self.t_end = 0
        self.stages = []
        rank = first_rank
        for i, sc in enumerate(cfg.stages):
            self.stages.append(Stage(system, self, i, sc, rank))
            rank += sc.replicas
        self.next_rank = rank
        self.os_stage = cfg.stage_of("OS")
        self.sc_stage = cfg.stage_of("SC")
        if cfg.ring is not None:
            from .ring import Ring
            self.net = Ring(system, self, cfg.ring)
        else:
            from .network import IdealNetwork
            self.net = IdealNetwork(self)
        for s in self.stages:
            s.net = self.net
        self.dis = DIS(self, order, cfg.window)

    def retire(self) -> None:
        """A ray has ended: COL takes its pixel value; the DIS may admit more."""
        self.live -= 1
        self.retired += 1
        system = self.system
        system.retired += 1
        system.t_end = self.t_end = system.env._now
        if self.live < self.dis.window:
            self.dis.admit()

    def state(self) -> dict:
        return {"live_rays": self.live, "dis_holding_a_primary": self.dis.pending is not None,
                "stages": {s.name: s.state_of() for s in self.stages}, "network": self.net.state()}
