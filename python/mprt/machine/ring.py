"""Ring: the unidirectional ring joining a PE's stages (OS -> IC -> SC -> OS).

Packet-level wormhole routing over K nodes (the stages in ring order), link
n from node n to node n+1 carrying one flit per ``flit_time`` cycles.  Each
node has ``buffer_classes`` flit buffers; a buffer holds one packet's header.

* Injection: the head packet of a node's send FIFO enters the network when
  the node's class-1 buffer is free (its header moves into it).  It stays
  in the send FIFO until its tail has left, so a node has one packet in
  the network at a time.
* Hop: a header in a buffer at node n moves to node n+1 when link n is
  free and node n+1's buffer of class min(hops made + 1, classes) is free
  (the structured buffer pool: forwarding moves a header up one class; with
  one class every packet competes for the same buffer).  The header holds
  the link for one flit time.
* Delivery: a header in a buffer at its destination claims the receive
  FIFO (exclusive write access and a free slot, reserved now) when it has
  room and no other packet is writing it; until then it waits in its
  buffer and holds no link ("the link is released for the time being").
* Body: once the slot is claimed, the f - 1 flits after the header stream
  over every link of the path (wormhole: the path is held from header to
  tail) when all those links are free, for (f - 1) flit times; then the
  packet is in the receive FIFO, and the path's buffers, the receive FIFO's
  write access and the send FIFO slot are released.

So an uncontended packet of f flits over h links takes (h + f - 1) flit
times.  Requests are granted first come, first served among those that can
proceed, re-examined whenever a resource is released.  A slot freed in a
receive FIFO goes to a waiting DIS first, then to the ring.
"""
from __future__ import annotations

from simpy.events import Event

from .network import Network
from .stage import IDLE

HOP, CLAIM, BODY = 0, 1, 2
PHASES = ("header waiting for link/buffer", "header waiting for the receive FIFO", "body waiting for the path")


class _Packet:
    __slots__ = ("x", "src", "dst", "flits", "node", "hops", "held", "phase", "copy")

    def __init__(self, x, src, dst, flits):
        self.x, self.src, self.dst, self.flits = x, src, dst, flits
        self.node, self.hops, self.held, self.phase = src, 0, [], HOP


class Ring(Network):
    def __init__(self, system, pe, cfg):
        super().__init__(pe)
        self.env = system.env
        self.K = len(pe.stages)
        self.ft = cfg.flit_time
        self.C = cfg.buffer_classes
        self.link_busy = [False] * self.K
        self.link_cycles = [0] * self.K
        self.buf = [[None] * self.C for _ in range(self.K)]
        self.injected = [None] * self.K
        self.writer = [None] * self.K
        self.waiting = []
        self.prio = 2 * system.n_proc + 1
        self.packets = 0
        self._kicking = False
        self._again = False

    # -- interface of a network ---------------------------------------------
    def send(self, src, x: int, g: int, f: int) -> bool:
        sf = src.send
        if sf.capacity is None or len(sf.items) < sf.capacity:
            sf.put((x, g, f))
            n = src.index
            if self.injected[n] is None and self.buf[n][0] is None:    # else it waits its turn
                self.kick()
            return True
        return False

    def freed(self, dst) -> None:
        super().freed(dst)          # only a DIS waits in a receive FIFO's list here
        self.kick()

    # -- the arbiter ------------------------------------------------------------
    def kick(self) -> None:
        """Grant what can proceed: injections node by node, then the waiting
        packets in the order they began to wait.  A grant only takes resources,
        so one pass grants all it can, unless a packet completed during it
        (a one-flit packet), which frees some: then another pass."""
        if self._kicking:
            self._again = True
            return
        self._kicking = True
        try:
            while True:
                self._again = False
                for n in range(self.K):
                    sf = self.stages[n].send
                    if self.injected[n] is None and sf.items and self.buf[n][0] is None:
                        x, g, f = sf.items[0]
                        pkt = _Packet(x, n, g, f)
                        self.buf[n][0] = pkt
                        pkt.held.append((n, 0))
                        self.injected[n] = pkt
                        self.waiting.append(pkt)
                        self.packets += 1
                waiting, self.waiting = self.waiting, []
                keep = [pkt for pkt in waiting if not self._step(pkt)]
                self.waiting = keep + self.waiting
                if not self._again:
                    break
        finally:
            self._kicking = False

    def _at(self, delay, fn, pkt, *args):
        ev = Event(self.env)
        ev._ok, ev._value = True, None
        ev.callbacks.append(lambda _e: fn(pkt, *args))
        self.env.schedule(ev, self.prio, delay)

    def _step(self, pkt) -> bool:
        """Try the packet's next step; True when it was granted."""
        K = self.K
        if pkt.phase == HOP:
            n = pkt.node
            m = (n + 1) % K
            if self.link_busy[n]:
                return False
            c = min(pkt.hops + 1, self.C - 1)
            if self.buf[m][c] is not None:
                return False
            self.link_busy[n] = True
            self.link_cycles[n] += self.ft
            self.buf[m][c] = pkt
            pkt.held.append((m, c))
            self._at(self.ft, self._arrive, pkt, n, m)
            return True
        if pkt.phase == CLAIM:
            d = pkt.dst
            st = self.stages[d]
            if st.per_copy:     # the copy is assigned now: its FIFO must have a free slot
                if self.writer[d] is not None:
                    return False
                k = st.assign(True, True, False)     # made only when a copy has room
                if k < 0:
                    return False
                pkt.copy = k
                self.writer[d] = pkt
                st.rfs[k].reserve()
            else:
                if self.writer[d] is not None or not st.receive.room():
                    return False
                self.writer[d] = pkt
                st.receive.reserve()
            pkt.phase = BODY
        # BODY: the rest of the packet over the whole path
        body = pkt.flits - 1
        if body <= 0:
            self._complete(pkt)
            return True
        links = [(pkt.src + i) % K for i in range(pkt.hops)]
        if any(self.link_busy[n] for n in links):
            return False
        for n in links:
            self.link_busy[n] = True
            self.link_cycles[n] += body * self.ft
        self._at(body * self.ft, self._body_done, pkt, links)
        return True

    def _arrive(self, pkt, n, m) -> None:
        self.link_busy[n] = False
        pkt.node = m
        pkt.hops += 1
        pkt.phase = CLAIM if m == pkt.dst else HOP
        self.waiting.append(pkt)
        self.kick()

    def _body_done(self, pkt, links) -> None:
        for n in links:
            self.link_busy[n] = False
        self._complete(pkt)
        self.kick()

    def _complete(self, pkt) -> None:
        for n, c in pkt.held:
            self.buf[n][c] = None
        d = pkt.dst
        self.writer[d] = None
        st = self.stages[d]
        if st.per_copy:
            k = pkt.copy
            if st.state[k] == IDLE:
                st.rfs[k].unreserve()
                st.idle.remove(k)
                st.start(k, pkt.x)
            else:
                st.rfs[k].fill(pkt.x)
        elif st.idle:
            st.receive.unreserve()
            st.start(st.idle.pop(0), pkt.x)
        else:
            st.receive.fill(pkt.x)
        src = self.stages[pkt.src]
        src.send.get()
        self.injected[pkt.src] = None
        src.send_freed()
        self.kick()

    # -- reports ---------------------------------------------------------------
    def state(self) -> dict:
        return {
            "network": "ring",
            "buffer_classes": self.C,
            "buffers": {self.stages[n].name: [None if b is None else f"packet {self.stages[b.src].cfg.name}->"
                                              f"{self.stages[b.dst].cfg.name}" for b in self.buf[n]]
                        for n in range(self.K)},
            "waiting": [f"{self.stages[p.src].cfg.name}->{self.stages[p.dst].cfg.name} at "
                        f"{self.stages[p.node].cfg.name}: {PHASES[p.phase]}" for p in self.waiting],
        }

    def link_utilisation(self, end) -> list:
        return [c / end if end else 0.0 for c in self.link_cycles]
