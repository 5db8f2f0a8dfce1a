"""The compiled replay's C calls (replay*.c): a machine's configuration, the trace loaded
(priced as it loads, or with its costs), the ring's packets, a run, its figures and state, and
level 3's memories."""
from __future__ import annotations

import numpy as np

from ..errors import InvalidArgument
from .core import (RAY_DTYPE, REPLAY_MEMORY_DTYPE, REPLAY_NODE_DTYPE, REPLAY_PE_DTYPE, REPLAY_PROC_DTYPE, VISIT_DTYPE,
                   Calls, Status, _plain, _struct_dict, error_class)


class ReplayCalls(Calls):
    """Replay handles: mprt_replay_*."""

    def _replay_config(self, config: dict):
        return self._struct("mprt_replay_config", self.lib.mprt_replay_config_init, config,
                            "replay configuration")

    def replay_create(self, config: dict):
        """A compiled replay of a machine: ``config`` holds mprt_replay_config's fields by name
        (the others keep mprt_replay_config_init's values); a bad field raises InvalidArgument
        with the library's message naming it."""
        ffi, lib = self.ffi, self.lib
        c = self._replay_config(config)
        out = ffi.new("mprt_replay **")
        rc = lib.mprt_replay_create(c, out)
        if out[0] == ffi.NULL:
            raise MemoryError("mprt_replay_create: out of memory")
        h = ffi.gc(out[0], lib.mprt_replay_destroy)
        self._check(rc, lib.mprt_replay_errmsg, h)
        return h

    def replay_set_config(self, h, config: dict) -> None:
        """Another configuration for the replay (the loaded trace stays)."""
        self._check(self.lib.mprt_replay_set_config(h, self._replay_config(config)), self.lib.mprt_replay_errmsg, h)

    def replay_load_priced(self, h, rays: np.ndarray, visits: np.ndarray, table: dict, children: np.ndarray,
                           prim_kind: np.ndarray, flits: np.ndarray | None = None, threads: int = 1) -> None:
        """Load the records, each visit priced as it loads with ``table`` (mprt_cost_table's fields
        by name, lights included) and ``children`` (as cost_children gives it), as ``replay_load``
        of the arrays ``cost_visits`` would make; ``flits`` (int64 per visit, as replay_set_flits
        takes them, or int32) receives their flits.  ``threads`` 2 or more: priced on a thread of
        their own ahead of the loading (the same replay, flits and errors)."""
        rays, visits = self._records("rays", rays, RAY_DTYPE), self._records("visits", visits, VISIT_DTYPE)
        if children.shape != (len(rays), 4) or children.dtype != np.int64 or not children.flags.c_contiguous:
            raise InvalidArgument(f"replay_load_priced: children must be int64[{len(rays)}, 4] as cost_children "
                                  "makes it")
        pk = _plain(prim_kind, np.int32)
        out = flits
        if flits is not None and getattr(flits, "dtype", None) != np.int64:
            out = np.zeros(len(visits), np.int64)       # (narrowed into flits after)
        try:
            self._load_priced(h, rays, visits, table, children, pk, out, threads)
        finally:
            if out is not flits:
                np.copyto(flits[:len(visits)], out, casting="unsafe")

    def _load_priced(self, h, rays, visits, table, children, pk, flits, threads) -> None:
        self._check(self.lib.mprt_replay_load_priced_threads(
            h, self._in("mprt_trace_ray", np.ascontiguousarray(rays), len(rays)), len(rays),
            self._in("mprt_trace_visit", np.ascontiguousarray(visits), len(visits)), len(visits),
            self.ffi.new("mprt_cost_table *", table), self._in("int64_t", children, 4 * len(rays)),
            self._in("int32_t", pk, len(pk)), len(pk),
            self.ffi.NULL if flits is None else self._out("int64_t", flits, len(visits)), max(1, int(threads))),
            self.lib.mprt_replay_errmsg, h)

    def replay_load(self, h, rays: np.ndarray, visits: np.ndarray, process: np.ndarray, receive: np.ndarray,
                    send: np.ndarray) -> None:
        """Load the records (RAY_DTYPE, VISIT_DTYPE) with int64 costs per visit (copied)."""
        rays, visits = self._records("rays", rays, RAY_DTYPE), self._records("visits", visits, VISIT_DTYPE)
        costs = [_plain(a, np.int64) for a in (process, receive, send)]
        for name, a in zip(("process", "receive", "send"), costs):
            if a.shape != (len(visits),):
                raise InvalidArgument(f"costs.{name} has shape {a.shape}, the trace has {len(visits)} visits")
        self._check(self.lib.mprt_replay_load(h, self._in("mprt_trace_ray", np.ascontiguousarray(rays), len(rays)),
                                              len(rays),
                                              self._in("mprt_trace_visit", np.ascontiguousarray(visits), len(visits)),
                                              len(visits), *(self._in("int64_t", a, len(visits)) for a in costs)),
                    self.lib.mprt_replay_errmsg, h)

    def replay_set_flits(self, h, flits: np.ndarray, kid_flits, inject_flits: int) -> None:
        """The packets' sizes for the ring: flits per visit (of the packet it sends on), per ray
        kind of a ray SC made, and of a primary ray SC made (copied)."""
        f = np.asarray(flits)
        if f.dtype != np.int64 or not f.flags.c_contiguous:   # widened into 4 KiB pages (cost.fast.fresh's reason)
            import mmap

            f = np.frombuffer(mmap.mmap(-1, max(8 * f.size, 1)), dtype=np.int64, count=f.size).reshape(f.shape)
            np.copyto(f, flits, casting="same_kind")
        k = _plain(kid_flits, np.int64)
        self._check(self.lib.mprt_replay_set_flits(h, self._in("int64_t", f), f.size, self._in("int64_t", k), k.size,
                                                   int(inject_flits)), self.lib.mprt_replay_errmsg, h)

    def replay_run(self, h, log: np.ndarray | None = None) -> bool:
        """Replay the loaded trace; ``log`` (int64, 8 * (visits + primary rays) entries)
        receives the events.  False when the machine deadlocked (its state stays readable
        by the getters)."""
        lib = self.lib
        rc = lib.mprt_replay_run(h, self.ffi.NULL if log is None else self._out("int64_t", log, log.size),
                                 0 if log is None else log.size)
        if rc == Status.ERR_STATE and self.replay_get_info(h)["deadlocked"]:
            return False
        self._check(rc, lib.mprt_replay_errmsg, h)
        return True

    def replay_work_bound(self, h) -> int:
        """mprt_replay_work_bound: a lower bound of the cycles of a run of the configuration set
        (the stages' work shared among their processors), at any level; nothing is run."""
        out = self.ffi.new("int64_t *")
        self._check(self.lib.mprt_replay_work_bound(h, out), self.lib.mprt_replay_errmsg, h)
        return int(out[0])

    def replay_get_info(self, h) -> dict:
        """mprt_replay_info of the last run, by field."""
        i = self.ffi.new("mprt_replay_info *")
        self._got(self.lib.mprt_replay_get_info(h, i), "info")
        return _struct_dict(self.ffi, i, "mprt_replay_info")

    def _got(self, rc: int, what: str) -> None:
        """A getter's status (its failures are the caller's: a run missing, a buffer too small)."""
        if rc != Status.OK:
            raise error_class(rc)(f"mprt_replay_get_{what}: {self.status_str(rc)}")

    def replay_get_procs(self, h, n: int) -> np.ndarray:
        """mprt_replay_proc per processor (REPLAY_PROC_DTYPE[n])."""
        out = np.zeros(n, dtype=REPLAY_PROC_DTYPE)
        self._got(self.lib.mprt_replay_get_procs(h, self._out("mprt_replay_proc", out, n), n), "procs")
        return out

    def replay_get_nodes(self, h, n: int) -> np.ndarray:
        """mprt_replay_node per stage of each PE (REPLAY_NODE_DTYPE[n])."""
        out = np.zeros(n, dtype=REPLAY_NODE_DTYPE)
        self._got(self.lib.mprt_replay_get_nodes(h, self._out("mprt_replay_node", out, n), n), "nodes")
        return out

    def replay_get_pes(self, h, n: int) -> np.ndarray:
        """mprt_replay_pe per PE (REPLAY_PE_DTYPE[n])."""
        out = np.zeros(n, dtype=REPLAY_PE_DTYPE)
        self._got(self.lib.mprt_replay_get_pes(h, self._out("mprt_replay_pe", out, n), n), "pes")
        return out

    def replay_get_trees(self, h, n: int):
        """Per primary ray (tree): (PE that admitted it int32[n], when int64[n]); -1: never."""
        pe, when = np.zeros(n, dtype=np.int32), np.zeros(n, dtype=np.int64)
        self._got(self.lib.mprt_replay_get_trees(h, self._out("int32_t", pe, n), self._out("int64_t", when, n), n), "trees")
        return pe, when

    def replay_record_busy(self, h, on: bool) -> None:
        """Record, in later runs, each stage's busy cycles at every tree's admission."""
        self._check(self.lib.mprt_replay_record_busy(h, int(bool(on))), self.lib.mprt_replay_errmsg, h)

    def replay_get_tree_busy(self, h, trees: int, stages: int) -> np.ndarray:
        """Per tree and stage (int64[trees, stages]): the busy cycles at its admission; -1: not
        admitted or not recorded."""
        out = np.zeros((trees, stages), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_tree_busy(h, self._out("int64_t", out), out.size), "tree_busy")
        return out

    def replay_get_links(self, h, pes: int, stages: int) -> np.ndarray:
        """Each ring link's busy cycles (int64[pes, stages]: link n from stage n to n + 1)."""
        out = np.zeros((pes, stages), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_links(h, self._out("int64_t", out), out.size), "links")
        return out

    def replay_get_ring(self, h, pe: int, stages: int, classes: int):
        """PE pe's ring at the end: (buffers int64[stages, classes]: source x 4 + destination
        stage of the packet holding each, -1 free; waiting packets int64[n, 4]: source,
        destination, node, phase, in the order they began to wait)."""
        n = self.ffi.new("size_t *")
        buffers = np.zeros((stages, classes), dtype=np.int64)
        waiting = np.zeros((4 * 3, ), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_ring(h, pe, self._out("int64_t", buffers), buffers.size,
                                                self._out("int64_t", waiting), waiting.size, n), "ring")
        return buffers, waiting[: 4 * n[0]].reshape(-1, 4)

    def replay_get_waiters(self, h, pe: int, stage: int, which: int) -> list:
        """Who waits for a slot in a stage's receive FIFO (which 0: sending stages, -1 the DIS)
        or send FIFO (which 1: replicas), in order."""
        n = self.ffi.new("size_t *")
        self.lib.mprt_replay_get_waiters(h, pe, stage, which, self.ffi.NULL, 0, n)
        out = np.zeros(max(n[0], 1), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_waiters(h, pe, stage, which, self._out("int64_t", out), out.size, n),
                  "waiters")
        return out[: n[0]].tolist()

    # -- replay: level 3, the memories ---------------------------------------------------
    def replay_set_memory(self, h, key: np.ndarray, ic: dict | None, sc: dict | None) -> None:
        """Give the loaded trace its memory data (copied): ``key`` int32 per visit (>= 0 an IC
        key, <= -2 SC key -2 - key, -1 none); ``ic``, ``sc``: None or dicts of ``line`` (bytes)
        and per key ``items``, ``resident`` (int32), ``line_start`` (int64, keys + 1), ``lines``
        (int64 line numbers)."""
        ffi = self.ffi
        keep = []

        def data(d):
            if d is None:
                return ffi.NULL
            c = ffi.new("mprt_replay_memory_data *")
            arrs = {k: _plain(d[k], t) for k, t in
                    (("items", np.int32), ("resident", np.int32), ("line_start", np.int64), ("lines", np.int64))}
            n = len(arrs["items"])
            if len(arrs["resident"]) != n or len(arrs["line_start"]) != n + 1:
                raise InvalidArgument("memory data: items, resident and line_start (keys + 1) differ in length")
            if len(arrs["lines"]) < (int(arrs["line_start"][-1]) if n + 1 else 0):
                raise InvalidArgument("memory data: fewer lines than line_start says")
            keep.append(arrs)
            c.nkeys, c.line = n, int(d["line"])
            c.items, c.resident = self._in("int32_t", arrs["items"]), self._in("int32_t", arrs["resident"])
            c.line_start, c.lines = self._in("int64_t", arrs["line_start"]), self._in("int64_t", arrs["lines"])
            keep.append(c)
            return c

        k = _plain(key, np.int32)
        self._check(self.lib.mprt_replay_set_memory(h, self._in("int32_t", k), len(k), data(ic), data(sc)),
                    self.lib.mprt_replay_errmsg, h)

    def replay_get_memory(self, h, pes: int, processors: int):
        """The last run's memory figures: (REPLAY_MEMORY_DTYPE[pes, 2] per PE and memory (IC, SC),
        int64[processors] memory stall per processor)."""
        out = np.zeros(2 * pes, dtype=REPLAY_MEMORY_DTYPE)
        stall = np.zeros(max(processors, 1), dtype=np.int64)
        self._got(self.lib.mprt_replay_get_memory(h, self._out("mprt_replay_memory", out), out.size,
                                                  self._out("int64_t", stall), processors), "memory")
        return out.reshape(pes, 2), stall[:processors]
