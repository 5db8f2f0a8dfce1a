"""Stage: processors running one or more of the subtasks OS, IC, SC.

Each processor of a stage is one SimPy process with at most one pending
event: the end of its current visit (key: time, rank), or its resumption
after being blocked on a full send FIFO (key: time, NP + rank, NP being the
number of processors in the system).  The event semantics are written out in
``python/mprt/machine/README.md``.
"""
from __future__ import annotations

from bisect import insort
from collections import deque

from simpy.events import Event

from .fifo import CopyFifos, Fifo
from .replay import CHILDREN, PAGE_BITS, PAGE_MASK

IDLE, BUSY, BLOCKED, RESUME = 0, 1, 2, 3
STATE_NAMES = ("idle (receive FIFO empty)", "busy", "blocked (send FIFO full)", "resuming")


class _Locals(list):
    """The copies' local queues (a per-copy feed); its length is all their packets."""

    def __len__(self):
        return sum(map(len, self.__iter__()))


class Stage:
    """A ring node of a PE: ``replicas`` processors of one configuration that
    share a send FIFO and, with feed "shared", a receive FIFO and a local
    queue (packets a stage sends to itself, e.g. IC to OS when one processor
    runs both: no FIFO, served first); with a per-copy feed each copy has a
    receive FIFO and a local queue of its own, and a packet handed to the
    stage is assigned to a copy (round-robin or the shortest queue)."""

    def __init__(self, system, pe, index: int, cfg, first_rank: int):
        env = system.env
        self.system, self.env, self.pe, self.index, self.cfg = system, env, pe, index, cfg
        self.name = f"PE{pe.index}.{cfg.name}"
        n = cfg.replicas
        self.n = n
        tl = system.timeline
        self.send = Fifo(env, self.name + ".send", cfg.send_fifo, tl)
        self.per_copy = cfg.feed != "shared" and n > 1     # one copy: every feed is the shared one
        if self.per_copy:
            self.rfs = [Fifo(env, f"{self.name}.receive{k}", cfg.receive_fifo, tl) for k in range(n)]
            self.receive = CopyFifos(self.name + ".receive", self.rfs)
            self.locals = [deque() for _ in range(n)]
            self.local = _Locals(self.locals)
            self.shortest = cfg.feed == "shortest-queue"
            self.turn = 0                     # round-robin: packets assigned so far
        else:
            self.receive = Fifo(env, self.name + ".receive", cfg.receive_fifo, tl)
            self.local = deque()
        self.net = None                       # set by the PE
        self.memory = None                    # LocalMemory of the subtask's data (level 3)
        self.idle = list(range(n))            # idle processors, lowest first
        self.state = [IDLE] * n
        self.cur = [-1] * n
        self.rank = [first_rank + k for k in range(n)]
        self.busy = [0] * n                   # cycles in visits (processing + communication + memory)
        self.blocked = [0] * n                # cycles blocked on a full send FIFO
        self.since = [0] * n                  # when the current block began
        self.stall = [0] * n                  # memory stall cycles (part of processing)
        self.visits = [0] * n
        self.pending = [None] * n             # packets a blocked processor still has to send
        self.generated = 0                    # primary rays made (SC)
        replay = system.replay
        self._dur, self._memk = replay.dur, replay.memk
        self._schedule = env.schedule
        self._watch = system.log is not None or system.timeline is not None
        self.ideal = system.config.ring is None
        self.ev = []
        for k in range(n):
            ev = Event(env)
            ev._ok, ev._value = True, None
            self.ev.append(ev)
            env.process(self._run(k))

    # -- starting a visit -------------------------------------------------------
    def start(self, k: int, j: int) -> None:
        """Processor k begins visit j now; its end is scheduled."""
        if j >= 0:
            d = self._dur[j >> PAGE_BITS][j & PAGE_MASK]
            if self.memory is not None:
                key = self._memk[j >> PAGE_BITS][j & PAGE_MASK]
                if key != -1:
                    s = self.memory.stall(key, self.env._now)
                    d += s
                    self.stall[k] += s
        else:                       # SC makes primary ray ~j
            d = self.system.gen_cycles
            self.generated += 1
        self.cur[k] = j
        self.state[k] = BUSY
        self.busy[k] += d
        self.visits[k] += 1
        if self._watch:
            sysm = self.system
            if sysm.log is not None:
                sysm.log.append((self.env._now, "start", self.name, k, j))
            if sysm.timeline is not None:
                sysm.timeline.busy(self.name, k, self.env._now, d)
        self._schedule(self.ev[k], self.rank[k], d)

    def accept(self, x: int) -> None:
        """A packet for this stage from the DIS or the network: to an idle
        processor if there is one (the lowest), else into the receive FIFO
        (the caller has checked for room).  Per-copy feed: to the copy it is
        assigned, idle or not."""
        if self.per_copy:
            k = self.assign(True)
            self.give(k, x, self.rfs[k].put)
        elif self.idle:
            self.start(self.idle.pop(0), x)
        else:
            self.receive.put(x)

    def room(self) -> bool:
        if self.per_copy:
            return self.assign(False, True) >= 0
        return bool(self.idle) or self.receive.room()

    # -- per-copy feed -----------------------------------------------------------
    def queued(self, k: int) -> int:
        """Copy k's packets: its receive FIFO (slots reserved too) and local
        queue, and the one it holds unless idle."""
        f = self.rfs[k]
        return len(f.items) + f.reserved + len(self.locals[k]) + (self.state[k] != IDLE)

    def assign(self, take: bool, need_room: bool = True, idle_ok: bool = True) -> int:
        """The copy the next packet goes to (-1: none has room).  Round-robin:
        copy (packets assigned so far) mod copies, if it has room; shortest
        queue: the copy with the fewest ``queued`` among those with room,
        ties to the lowest.  Room: idle (when ``idle_ok``) or a free slot in
        its receive FIFO; without ``need_room`` every copy qualifies (a
        local queue has no capacity).  ``take``: the assignment is made
        (round-robin's count advances)."""
        def fits(k):
            return not need_room or (idle_ok and self.state[k] == IDLE) or self.rfs[k].room()
        if not self.shortest:
            k = self.turn % self.n
            if not fits(k):
                return -1
            if take:
                self.turn += 1
            return k
        best, low = -1, 0
        for k in range(self.n):
            if fits(k):
                q = self.queued(k)
                if best < 0 or q < low:
                    best, low = k, q
        return best

    def give(self, k: int, x: int, queue) -> None:
        """Packet x assigned to copy k: started now if k is idle, else queued (``queue``)."""
        if self.state[k] == IDLE:
            self.idle.remove(k)
            self.start(k, x)
        else:
            queue(x)

    def take_next(self, k: int) -> None:
        """Copy k (per-copy feed) takes its next packet: its local queue's
        head, else its receive FIFO's (then the stage's waiters may enter),
        else it is idle."""
        local, rf = self.locals[k], self.rfs[k]
        if local:
            self.start(k, local.popleft())
        elif rf.items:
            self.start(k, rf.get())
            if self.receive.waiters or not self.ideal:
                self.net.freed(self)
        else:
            self.state[k] = IDLE
            insort(self.idle, k)

    # -- a processor --------------------------------------------------------------
    def _run(self, k: int):
        ev = self.ev[k]
        state = self.state
        local, rf = self.local, self.receive
        replay = self.system.replay
        dest_pages, kid_pages, flit_pages, left = replay.dest, replay.kids, replay.flits, replay.left
        ring = self.system.ring_flits
        pe = self.pe
        log = self.system.log
        output = self.output
        tree_first = replay.tree_first
        gen_flits = self.system.gen_flits
        while True:
            yield ev
            ev.callbacks = []
            if state[k] == BUSY:
                j = self.cur[k]
                if log is not None:
                    log.append((self.env._now, "end", self.name, k, j))
                if j < 0:               # SC made primary ray ~j: to OS
                    x = tree_first[~j]
                    if not output(x, pe.os_stage, gen_flits):
                        self._block(k, [(x, pe.os_stage, gen_flits)])
                        continue
                else:
                    p, o = j >> PAGE_BITS, j & PAGE_MASK
                    g = dest_pages[p][o]
                    ok = True
                    if g >= 0:              # the ray goes on at stage g
                        f = flit_pages[p][0][o] if ring else 0
                        if not output(j + 1, g, f):
                            self._block(k, [(j + 1, g, f)])
                            ok = False
                        left[p] -= 1
                        if not left[p]:
                            replay.drop(p)
                    else:                   # the ray ends, maybe with children (to OS)
                        if g == CHILDREN:
                            kids = kid_pages[p][o]
                            kf = flit_pages[p][1][o] if ring else (0,) * len(kids)
                            os_stage = pe.os_stage
                            pe.live += len(kids)
                            if pe.live > pe.max_live:
                                pe.max_live = pe.live
                            for i, c in enumerate(kids):
                                if not output(c, os_stage, kf[i]):
                                    self._block(k, [(kids[m], os_stage, kf[m]) for m in range(i, len(kids))])
                                    ok = False
                                    break
                        left[p] -= 1
                        if not left[p]:
                            replay.drop(p)
                        pe.retire()
                    if not ok:
                        continue
            # take the next packet: local queue first, then the receive FIFO
            if self.per_copy:
                self.take_next(k)
            elif local:
                self.start(k, local.popleft())
            elif rf.items:
                self.start(k, rf.get())
                if rf.waiters or not self.ideal:
                    self.net.freed(self)
            else:
                state[k] = IDLE
                insort(self.idle, k)

    def output(self, x: int, g: int, f: int) -> bool:
        """Send packet x (the visit it starts) of f flits to stage g; False if
        the send FIFO is full (the processor then keeps it)."""
        if g == self.index:
            if self.per_copy:
                k = self.assign(True, False)
                self.give(k, x, self.locals[k].append)
            elif self.idle:
                self.start(self.idle.pop(0), x)
            else:
                self.local.append(x)
            return True
        if self.ideal and not self.send.items:      # the ideal network's common case, inline
            dst = self.pe.stages[g]
            if dst.per_copy:
                if dst.room():
                    dst.accept(x)
                    return True
            else:
                if dst.idle:
                    dst.start(dst.idle.pop(0), x)
                    return True
                rf = dst.receive
                if rf.capacity is None:
                    rf.put(x)
                    return True
        return self.net.send(self, x, g, f)

    def _block(self, k, packets):
        self.state[k] = BLOCKED
        self.since[k] = self.env._now
        self.pending[k] = deque(packets)
        self.send.waiters.append(k)

    def send_freed(self) -> None:
        """A slot of the send FIFO freed: blocked processors, first come
        first served, place their packets; one that has placed all resumes
        now (after the visit ends due at this time)."""
        w = self.send.waiters
        while w:
            k = w[0]
            q = self.pending[k]
            while q:
                x, g, f = q[0]
                if not self.net.send(self, x, g, f):
                    return
                q.popleft()
            w.popleft()
            self.pending[k] = None
            self.state[k] = RESUME
            self.blocked[k] += self.env._now - self.since[k]
            self.env.schedule(self.ev[k], self.system.n_proc + self.rank[k], 0)

    def state_of(self) -> dict:
        procs = []
        for k in range(self.n):
            s = {"state": STATE_NAMES[self.state[k]]}
            if self.state[k] in (BUSY, BLOCKED):
                s["visit"] = self.cur[k]
            if self.state[k] == BLOCKED:
                s["packets_to_send"] = len(self.pending[k])
            procs.append(s)
        return {"processors": procs, "local_queue": len(self.local), "receive_fifo": self.receive.state(),
                "send_fifo": self.send.state()}
