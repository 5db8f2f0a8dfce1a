"""The ideal network of models S and M: zero latency, unlimited bandwidth.

A packet goes from its sender's send FIFO into the destination's receive
FIFO (or straight to an idle processor there) at the moment it is sent, if
there is room and nothing is queued before it in the send FIFO; otherwise it
waits in the send FIFO, and the send FIFO's head moves as soon as the
receive FIFO it waits for frees a slot (send FIFOs waiting for the same
receive FIFO are served first come, first served).  With unbounded FIFOs
the send FIFO is never used.
"""
from __future__ import annotations


class Network:
    """What the ideal network and the ring share: the waiting list of a receive FIFO."""

    def __init__(self, pe):
        self.pe = pe
        self.stages = pe.stages

    def freed(self, dst) -> None:
        """A slot of dst's receive FIFO freed: the first waiting sender (the
        DIS, or a send FIFO's head) moves in, while there is room."""
        rf = dst.receive
        dis = self.pe.dis
        room = dst.room if dst.per_copy else rf.room
        while rf.waiters and room():
            w = rf.waiters.popleft()
            if w is dis:
                dis.release()
            else:
                self.advance(w)

    def advance(self, src) -> None:
        raise NotImplementedError


class IdealNetwork(Network):

    def send(self, src, x: int, g: int, f: int) -> bool:
        """Packet x from stage src to stage g; False when src's send FIFO is full."""
        dst = self.stages[g]
        sf = src.send
        if not sf.items:
            if dst.per_copy:
                if dst.room():
                    dst.accept(x)
                    return True
            elif dst.idle:
                dst.start(dst.idle.pop(0), x)
                return True
            else:
                rf = dst.receive
                if rf.capacity is None or len(rf.items) < rf.capacity:
                    rf.put(x)
                    return True
        if sf.capacity is None or len(sf.items) < sf.capacity:
            sf.put((x, dst))
            if len(sf.items) == 1:
                dst.receive.waiters.append(src)
            return True
        return False

    def advance(self, src) -> None:
        """Move src's send FIFO head packets on while their receive FIFOs have room."""
        sf = src.send
        while sf.items:
            x, dst = sf.items[0]
            if dst.per_copy:
                if dst.room():
                    sf.get()
                    dst.accept(x)
                else:
                    dst.receive.waiters.append(src)
                    return
            elif dst.idle:
                sf.get()
                dst.start(dst.idle.pop(0), x)
            elif dst.receive.room():
                sf.get()
                dst.receive.put(x)
            else:
                dst.receive.waiters.append(src)
                return
            src.send_freed()

    def state(self) -> dict:
        return {"network": "ideal"}

    def link_utilisation(self, end) -> list:
        return []
