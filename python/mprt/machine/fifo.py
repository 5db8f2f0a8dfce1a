"""Fifo: a stage's send or receive FIFO of ray packets."""
from __future__ import annotations

from collections import deque


class Fifo:
    """Packets in arrival order, ``capacity`` of them at most (None:
    unbounded).  ``reserved`` counts slots promised to packets still on the
    ring.  ``waiters`` are those waiting for a slot, first come first served
    (a receive FIFO: send FIFOs whose head packet is for it, and the DIS; a
    send FIFO: its blocked processors).  Occupancy is integrated over time
    for its mean; ``timeline`` (optional) samples it for plots."""

    __slots__ = ("name", "capacity", "items", "reserved", "waiters", "env", "area", "max", "timeline",
                 "puts")

    def __init__(self, env, name: str, capacity: int | None, timeline=None):
        self.env = env
        self.name = name
        self.capacity = capacity
        self.items = deque()
        self.reserved = 0
        self.waiters = deque()
        self.area = 0           # integral of occupancy over time, less end x occupancy at the end
        self.max = 0
        self.timeline = timeline
        self.puts = 0

    def __len__(self):
        return len(self.items)

    def room(self) -> bool:
        return self.capacity is None or len(self.items) + self.reserved < self.capacity

    # Occupancy integrated over time by Little's law: a packet adds (leave -
    # enter) to the area, so each change adds or subtracts the time once.
    def put(self, item) -> None:
        self.items.append(item)
        self.area -= self.env._now
        self.puts += 1
        n = len(self.items) + self.reserved
        if n > self.max:
            self.max = n
        if self.timeline is not None:
            self.timeline.level(self.name, self.env._now, n)

    def get(self):
        self.area += self.env._now
        x = self.items.popleft()
        if self.timeline is not None:
            self.timeline.level(self.name, self.env._now, len(self.items) + self.reserved)
        return x

    def reserve(self) -> None:
        """A slot for a packet still on the ring."""
        self.reserved += 1
        self.area -= self.env._now
        n = len(self.items) + self.reserved
        if n > self.max:
            self.max = n
        if self.timeline is not None:
            self.timeline.level(self.name, self.env._now, n)

    def unreserve(self) -> None:
        """A reserved slot is not needed (the packet went to an idle processor)."""
        self.reserved -= 1
        self.area += self.env._now
        if self.timeline is not None:
            self.timeline.level(self.name, self.env._now, len(self.items) + self.reserved)

    def fill(self, item) -> None:
        """The packet for a reserved slot has arrived (the slot stays occupied)."""
        self.reserved -= 1
        self.items.append(item)
        self.puts += 1

    def mean(self, end) -> float:
        area = self.area + (len(self.items) + self.reserved) * end
        return area / end if end else 0.0

    def state(self) -> dict:
        return {"occupancy": len(self.items), "reserved": self.reserved,
                "capacity": "unbounded" if self.capacity is None else self.capacity,
                "waiting_for_a_slot": [getattr(w, "name", str(w)) for w in self.waiters]}


class CopyFifos:
    """The receive FIFOs of a stage whose copies are fed one each (feed
    round-robin or shortest-queue), seen as one for the figures: occupancy,
    packets and mean summed over the copies, max the largest copy's;
    ``waiters`` is the stage's one waiting list (who waits for room to enter
    the stage)."""

    def __init__(self, name: str, fifos):
        self.name = name
        self.fifos = fifos
        self.capacity = fifos[0].capacity
        self.waiters = deque()

    @property
    def max(self) -> int:
        return max(f.max for f in self.fifos)

    @property
    def puts(self) -> int:
        return sum(f.puts for f in self.fifos)

    def mean(self, end) -> float:
        area = sum(f.area + (len(f.items) + f.reserved) * end for f in self.fifos)
        return area / end if end else 0.0

    def state(self) -> dict:
        return {"occupancy": sum(len(f.items) for f in self.fifos), "reserved": sum(f.reserved for f in self.fifos),
                "capacity": "unbounded" if self.capacity is None else self.capacity,
                "waiting_for_a_slot": [getattr(w, "name", str(w)) for w in self.waiters]}
