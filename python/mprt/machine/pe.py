"""PE: one processing element (its stages, network, memories) and its share
of DIS, the load distributor that admits primary rays under a window."""
from __future__ import annotations

from .stage import Stage


class DIS:
    """Admits this PE's primary rays (in its order) while fewer than
    ``window`` rays are live in the PE.  A primary goes into the receive
    FIFO of the stage running OS (or to an idle processor there); when that
    FIFO is full the DIS waits for a slot, holding the primary."""

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
        os = pe.stages[pe.os_stage]
        while pe.live < self.window:
            k = next(self.order, None)
            if k is None:
                return
            x = system.replay.ensure_tree(k)
            system.tree_pe[k] = pe.index
            pe.live += 1
            self.admitted += 1
            if os.room():
                os.accept(x)
            else:
                self.pending = x
                os.receive.waiters.append(self)
                return

    def release(self) -> None:
        """A slot of the OS receive FIFO is ours: the held primary goes in."""
        x, self.pending = self.pending, None
        self.pe.stages[self.pe.os_stage].accept(x)
        self.admit()


class PE:
    """A processing element: stages in ring order, their network (ideal or
    ring), local memories, and its DIS."""

    def __init__(self, system, index: int, order, first_rank: int):
        cfg = system.config
        self.system = system
        self.index = index
        self.live = 0
        self.retired = 0
        self.stages = []
        rank = first_rank
        for i, sc in enumerate(cfg.stages):
            self.stages.append(Stage(system, self, i, sc, rank))
            rank += sc.replicas
        self.next_rank = rank
        self.os_stage = cfg.stage_of("OS")
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
        system.t_end = system.env._now
        if self.live < self.dis.window:
            self.dis.admit()

    def state(self) -> dict:
        return {"live_rays": self.live, "dis_holding_a_primary": self.dis.pending is not None,
                "stages": {s.name: s.state_of() for s in self.stages}, "network": self.net.state()}
