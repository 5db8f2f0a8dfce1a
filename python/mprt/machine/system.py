"""System: N PEs, DIS and COL; ``simulate`` replays a trace on a configuration."""
from __future__ import annotations

import time

import numpy as np
import simpy
from simpy.core import EmptySchedule

from ..trace import RAY_KINDS
from ..trace.tracevalid import check_trace
from .config import SUBTASKS, SystemConfig, check_config
from .errors import ConfigError, DeadlockError
from .memory import Cache, DataLayout, GlobalMemory, LocalMemory, StageMemory
from .pe import PE
from .replay import Costs, Replay, dis_orders
from .result import CATEGORIES, SimResult, Timeline


class System:
    """The machine built from a configuration, ready to replay one trace.

    ``costs``: per-visit cycle arrays (process, receive, send, flits), else
    ``cost_model`` (default: ``CostModel.default()``) costs the trace for the
    configuration's processors.  ``packet_flits(src, dst, kind)`` sizes the
    packets SC sends (for the ring; default: the cost model's)."""

    def __init__(self, trace, config: SystemConfig, cost_model=None, costs=None, packet_flits=None,
                 record: bool = False, timeline: bool = False):
        self.config = config = check_config(config)
        check_trace(trace)          # a trace built in memory: its ranges before the model reads it
        self.trace = trace
        self.env = simpy.Environment()
        self.log = [] if record else None
        self.timeline = Timeline() if timeline else None
        self.n_proc = config.pes * sum(s.replicas for s in config.stages)
        self.retired = 0
        self.t_end = 0
        if costs is None or (config.ring is not None and packet_flits is None):
            if cost_model is None:
                from ..cost import CostModel

                cost_model = CostModel.default()
            if packet_flits is None:
                packet_flits = cost_model.packet_flits
        source = costs if costs is not None else cost_model
        kid_flits = [packet_flits("SC", "OS", k) for k in range(len(RAY_KINDS))] if config.ring else None
        self.ring_flits = config.ring is not None
        self.replay = Replay(trace, Costs(trace, source, config.processors()),
                             [config.stage_of(t) for t in SUBTASKS], kid_flits, memory=config.level == 3)
        n_trees = self.replay.n_trees
        ip, isend, iflits = self.replay.costs.inject
        self.gen_process, self.gen_send = ip, isend
        self.gen_cycles, self.gen_flits = ip + isend, iflits
        if n_trees == 0:        # (more PEs than primary rays run: those that get none stay idle)
            where = f"{config.source}: " if config.source else ""
            raise ConfigError(f"{where}the trace has no primary rays: nothing to replay")
        self.tree_pe = np.full(n_trees, -1, dtype=np.int32)
        orders = dis_orders(n_trees, config.pes, config.dis)
        self.pes = []
        rank = 1
        for p in range(config.pes):
            pe = PE(self, p, orders[p], rank)
            rank = pe.next_rank
            self.pes.append(pe)
        self.memories = {}
        if config.level == 3:
            self._build_memory()

    def _build_memory(self):
        cfg = self.config
        layout = DataLayout(self.trace)
        for tag in ("ic", "sc"):
            mc = getattr(cfg, f"{tag}_memory")
            if mc is None:
                continue
            gm = GlobalMemory(f"{tag}gm", getattr(cfg, f"{tag}gm"), cfg.pes)
            resident = layout.ic_resident(mc.resident) if tag == "ic" else layout.sc_resident(mc.resident)
            self.memories[tag] = {"gm": gm, "resident": resident, "local": []}
            for pe in self.pes:
                cache = Cache(mc.cache) if mc.cache is not None else None
                self.memories[tag]["local"].append(LocalMemory(tag, layout, resident, cache, gm, pe.index))
        for pe in self.pes:
            for st in pe.stages:
                ic = self.memories["ic"]["local"][pe.index] if "IC" in st.cfg.subtasks and "ic" in self.memories \
                    else None
                sc = self.memories["sc"]["local"][pe.index] if "SC" in st.cfg.subtasks and "sc" in self.memories \
                    else None
                if ic is not None or sc is not None:
                    st.memory = StageMemory(ic, sc)

    # -- running --------------------------------------------------------------
    def run(self, progress: bool = False) -> SimResult:
        t0 = time.perf_counter()
        for pe in self.pes:
            pe.dis.admit()
        n_rays = self.replay.n_rays
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=n_rays, unit="ray", desc="simulate", leave=False)
            step = self.env.step
            done = 0
            try:
                while True:
                    for _ in range(1 << 14):
                        step()
                    bar.update(self.retired - done)
                    done = self.retired
            except EmptySchedule:
                pass
            finally:
                bar.close()
        else:
            self.env.run()
        if self.retired != n_rays:
            raise self._deadlock()
        res = self._result()
        res.wall_seconds = time.perf_counter() - t0
        return res

    def _deadlock(self) -> DeadlockError:
        state = {"rays_retired": self.retired, "rays": self.replay.n_rays,
                 "pes": {f"PE{pe.index}": pe.state() for pe in self.pes}}
        cfg, rp = self.config, self.replay
        lines = [f"deadlock: the machine stopped with {rp.n_rays - self.retired} of "
                 f"{rp.n_rays} rays still in it (no stage can proceed; no cycle count is given)"]
        cap = cfg.cycle_capacity
        if cap is not None and cfg.window * rp.max_leaves >= cap:
            lines.append(f"  the FIFOs can fill: window {cfg.window} x up to {rp.max_leaves} live rays per tree "
                         f">= {cap} packets (the fewest that fill two stages' FIFOs); a window below "
                         f"{-(-cap // rp.max_leaves)} rules this out")
        if cfg.ring is not None and cfg.ring.buffer_classes < len(cfg.stages):
            lines.append(f"  the ring has {cfg.ring.buffer_classes} buffer class(es) for {len(cfg.stages)} stages: "
                         f"headers can wait on each other in a cycle (the structured pool, "
                         f"buffer_classes = {len(cfg.stages)}, cannot)")
        for pe in self.pes:
            st = pe.state()
            lines.append(f"  PE{pe.index}: {st['live_rays']} live rays"
                         + (", DIS holds a primary ray waiting for a slot" if st["dis_holding_a_primary"] else ""))
            for name, s in st["stages"].items():
                procs = "; ".join(p["state"] + (f" with {p['packets_to_send']} packet(s) to send"
                                                if "packets_to_send" in p else "") for p in s["processors"])
                rf, sf = s["receive_fifo"], s["send_fifo"]
                lines.append(f"    {name}: {procs}; receive FIFO {rf['occupancy']}+{rf['reserved']} reserved of "
                             f"{rf['capacity']}; send FIFO {sf['occupancy']} of {sf['capacity']}; "
                             f"local queue {s['local_queue']}")
            net = st["network"]
            if net["network"] == "ring":
                for node, bufs in net["buffers"].items():
                    lines.append(f"    ring buffers at {node}: " + ", ".join(b or "free" for b in bufs))
                for w in net["waiting"]:
                    lines.append(f"    ring: {w}")
        return DeadlockError("\n".join(lines), state)

    def _result(self) -> SimResult:
        cfg, rp = self.config, self.replay
        T = self.t_end
        if self.timeline is not None:
            self.timeline.finish(T)
        # per tree sums -> per PE and subtask
        pe_of = self.tree_pe.astype(np.int64)
        npe = cfg.pes
        proc = np.zeros((npe, 3), dtype=np.int64)
        comm = np.zeros((npe, 3), dtype=np.int64)
        vis = np.zeros((npe, 3), dtype=np.int64)
        np.add.at(proc, pe_of, rp.tree_process)
        np.add.at(comm, pe_of, rp.tree_comm)
        np.add.at(vis, pe_of, rp.tree_visits)
        # memory stall per PE and subtask (IC data stalls IC visits, SC data SC visits)
        stall = np.zeros((npe, 3), dtype=np.int64)
        for tag, t in (("ic", 1), ("sc", 2)):
            if tag in self.memories:
                for m in self.memories[tag]["local"]:
                    stall[m.pe, t] += m.stall_cycles
        # SC's making of primary rays
        made = np.zeros(npe, dtype=np.int64)
        for pe in self.pes:
            made[pe.index] = sum(st.generated for st in pe.stages)
        proc[:, 2] += made * self.gen_process
        comm[:, 2] += made * self.gen_send
        proc_all = proc + stall
        processors, nodes, pes = [], {}, []
        sub_wait = np.zeros((npe, 3), dtype=np.int64)
        for pe in self.pes:
            pe_nodes = {}
            for st in pe.stages:
                subs = [SUBTASKS.index(t) for t in st.cfg.subtasks]
                busy, blocked = sum(st.busy), sum(st.blocked)
                total = T * st.n
                wait = total - busy
                # the processor's waiting, split over its subtasks by their busy cycles
                loads = [int(proc_all[pe.index, i] + comm[pe.index, i]) for i in subs]
                if sum(st.visits) - st.generated != int(vis[pe.index, subs].sum()) or sum(loads) != busy:
                    raise AssertionError(f"{st.name}: visits or busy cycles differ from the trace's")
                rest = wait
                for n, i in enumerate(subs):
                    share = rest if n == len(subs) - 1 else (wait * loads[n] // busy if busy else wait // len(subs))
                    sub_wait[pe.index, i] += share
                    rest -= share
                for k in range(st.n):
                    processors.append({"pe": pe.index, "stage": st.cfg.name, "replica": k, "visits": st.visits[k],
                                       "busy": st.busy[k], "blocked": st.blocked[k],
                                       "idle": T - st.busy[k] - st.blocked[k], "memory_stall": st.stall[k],
                                       "utilisation": st.busy[k] / T if T else 0.0})
                fig = {"subtasks": list(st.cfg.subtasks), "replicas": st.n,
                       "processing": int(proc_all[pe.index, subs].sum()),
                       "communication": int(comm[pe.index, subs].sum()), "waiting": wait, "busy": busy,
                       "blocked": blocked, "idle": wait - blocked, "visits": sum(st.visits),
                       "utilisation": busy / total if total else 0.0}
                pe_nodes[st.cfg.name] = fig
                summed = ("processing", "communication", "waiting", "busy", "blocked", "idle", "visits")
                agg = nodes.setdefault(st.cfg.name, {**fig, **dict.fromkeys(summed, 0)})
                for key in summed:
                    agg[key] += fig[key]
            pes.append({"pe": pe.index, "primaries": pe.dis.admitted, "rays": pe.retired, "end": pe.t_end,
                        "max_live_rays": pe.max_live,
                        "stages": pe_nodes})
        for agg in nodes.values():
            agg["utilisation"] = agg["busy"] / (T * agg["replicas"] * npe) if T else 0.0
        stages = {}
        for i, t in enumerate(SUBTASKS):
            d = {"processing": int(proc_all[:, i].sum()), "communication": int(comm[:, i].sum()),
                 "waiting": int(sub_wait[:, i].sum()), "rays_in": int(vis[:, i].sum()),
                 "memory_stall": int(stall[:, i].sum())}
            if t == "SC":
                d["primaries_made"] = int(made.sum())
            tot = sum(d[c] for c in CATEGORIES)
            d["share"] = {c: d[c] / tot if tot else 0.0 for c in CATEGORIES}
            d["utilisation"] = (d["processing"] + d["communication"]) / tot if tot else 0.0
            stages[t] = d
        fifos = {}
        for pe in self.pes:
            for st in pe.stages:
                for f in (st.receive, st.send):
                    fifos[f.name] = {"capacity": f.capacity, "mean": f.mean(T), "max": f.max, "packets": f.puts}
        links = {f"PE{pe.index}": pe.net.link_utilisation(T) for pe in self.pes if cfg.ring is not None}
        memory = {}
        for tag, m in self.memories.items():
            caches = [lm.cache for lm in m["local"] if lm.cache is not None]
            if caches:
                acc, hits = sum(c.accesses for c in caches), sum(c.hits for c in caches)
                memory[f"{tag}_cache"] = {"accesses": acc, "hits": hits, "hit_rate": hits / acc if acc else 1.0}
            r = m["resident"]
            memory[f"{tag}_resident"] = {"accesses": r.accesses, "hits": r.hits,
                                         "hit_rate": r.hits / r.accesses if r.accesses else 1.0,
                                         "bytes_used": r.used, "bytes": r.size}
            gm = m["gm"]
            memory[f"{tag}gm"] = {"accesses": gm.accesses, "busy": gm.busy, "queued": gm.queued}
        kinds = np.zeros(len(RAY_KINDS), dtype=np.int64)
        rays = self.trace.rays
        for a in range(0, len(rays), 1 << 22):
            kinds += np.bincount(np.asarray(rays[a:a + (1 << 22)]["kind"]), minlength=len(RAY_KINDS))
        cap = cfg.cycle_capacity
        bound = {"window": cfg.window, "max_leaves_per_tree": rp.max_leaves, "cycle_capacity": cap,
                 "fifos_cannot_deadlock": cap is None or cfg.window * rp.max_leaves < cap,
                 "max_live_rays": max(p.max_live for p in self.pes)}
        return SimResult(
            deadlock_bound=bound,
            cycles=int(T), model=cfg.name, level=cfg.level, config=cfg.to_dict(), stages=stages, nodes=nodes,
            processors=processors, pes=pes, fifos=fifos, links=links, memory=memory,
            rays={k: int(kinds[i]) for i, k in enumerate(RAY_KINDS)}, visits=rp.n_visits, log=self.log,
            timeline=self.timeline)


def simulate(trace, config: SystemConfig | str = "M", cost_model=None, costs=None, packet_flits=None,
             record: bool = False, timeline: bool = False, progress: bool = False) -> SimResult:
    """Replay a trace on a machine configuration (a SystemConfig or a
    built-in name: S, M, 3mppe); raises DeadlockError if the machine stops
    with rays still in it.  ``record`` keeps the event log (start/end of
    every visit), ``timeline`` the series for plots."""
    if isinstance(config, str):
        from .config import builtin

        config = builtin(config)
    return System(trace, config, cost_model=cost_model, costs=costs, packet_flits=packet_flits,
                  record=record, timeline=timeline).run(progress=progress)
