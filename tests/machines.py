"""Random machines for the differential tests (the compiled replay against the SimPy model,
test_fidelity*.py, test_work_bound.py): one builder of each part, drawn from a random.Random,
so that a seed gives the same machines wherever it is drawn."""
import numpy as np

from mprt.cost import CostModel
from mprt.machine import SystemConfig, make_stage
from mprt.machine.config import FEEDS, CacheConfig, GlobalMemoryConfig, LocalMemoryConfig, RingConfig

CM = CostModel.default()

# the subtasks' mappings onto stages: every partition of OS, IC and SC, in several orders
MAPPINGS = [(("OS",), ("IC",), ("SC",)), (("OS", "SC"), ("IC",)), (("OS",), ("IC", "SC")), (("OS", "IC"), ("SC",)),
            (("OS", "IC", "SC"),), (("IC",), ("OS",), ("SC",)), (("SC",), ("IC", "OS"))]


def random_config(rng, feeds=False, ring=False):
    """A machine of 1 to 3 stages in any mapping (with ring: 2 or 3, joined by a ring of random
    flit time and 1 to K buffer classes), each with a random processor, 1 to 3 replicas (with
    feeds, or with ring: each stage's feed shared, round-robin or shortest-queue), FIFOs finite
    or not; 1 to 3 PEs, any DIS policy, windows of 1 to 256."""
    stages = []
    for subs in rng.choice([m for m in MAPPINGS if len(m) >= 2] if ring else MAPPINGS):
        finite = rng.random() < 0.6
        stages.append(make_stage(subs, rng.choice(["sequential", "paper:OS", "paper:IC", "paper:SC"]),
                                 replicas=rng.choice([1, 1, 2, 3]),
                                 send_fifo=rng.choice([None, 1, 2, 4]) if finite else None,
                                 receive_fifo=rng.choice([None, 1, 2, 3, 8]) if finite else None,
                                 feed=rng.choice(FEEDS) if feeds or ring else "shared"))
    return SystemConfig("random", tuple(stages), pes=rng.choice([1, 1, 2, 3]),
                        dis=rng.choice(["blocks", "interleaved", "dynamic"]), window=rng.choice([1, 2, 4, 16, 64, 256]),
                        ring=RingConfig(rng.choice([1, 1, 2, 3]), rng.randint(1, len(stages))) if ring else None)


def random_memory(rng):
    """A local memory (15%: none): resident 0 to 2^40 bytes and (80%) a cache of 1 to 64 sets
    (5%: 2^40 bytes, sets beyond the data never fill) of 1 to 8 ways and 1 to 64-byte lines."""
    if rng.random() < 0.15:
        return None
    resident = rng.choice([0, 0, 16, 64, 200, 1024, 1 << 40])
    cache = None
    if rng.random() < 0.8:
        line = rng.choice([1, 4, 8, 16, 32, 64])
        ways = rng.choice([1, 2, 3, 4, 8])
        sets = rng.choice([1, 2, 3, 4, 5, 8, 64])
        if rng.random() < 0.05:           # far more than the data: sets beyond it never fill
            sets = (1 << 40) // (line * ways)
        cache = CacheConfig(line * ways * sets, line, ways)
    return LocalMemoryConfig(resident, cache)


def random_gm(rng):
    """A global memory: latency, bandwidth, shared or per-PE ports."""
    return GlobalMemoryConfig(rng.choice([0, 1, 5, 20, 100]), rng.choice([1, 3, 8, 64]), rng.random() < 0.5)


def random_memories(cfg, rng, some=False):
    """cfg with random IC and SC memories (random_memory), each with its global memory; with
    some, at least one of the two."""
    ic, sc = random_memory(rng), random_memory(rng)
    if some and ic is None and sc is None:
        ic = random_memory(rng) or LocalMemoryConfig(0, CacheConfig(64, 16, 2))
    return cfg.replace(ic_memory=ic, sc_memory=sc, icgm=random_gm(rng) if ic else None,
                       scgm=random_gm(rng) if sc else None)


def logged_memories(cfg, rng):
    """cfg with memories small enough that short traces' event logs show their waits: IC 0 or
    64 B resident and a 2-way 128 B cache of 16 B lines, SC uncached; random global memories."""
    return cfg.replace(ic_memory=LocalMemoryConfig(rng.choice([0, 64]), CacheConfig(128, 16, 2)),
                       sc_memory=LocalMemoryConfig(0, None), icgm=random_gm(rng), scgm=random_gm(rng))


def random_machine(rng):
    """The whole machine: a random ring machine (random_config) with random memories, at
    least one."""
    return random_memories(random_config(rng, ring=True), rng, some=True)


def random_costs(t, cfg, rng, seed=None):
    """The cost model's visit costs for cfg, or (30%) with SC not making the primary rays; with
    seed (for the ring), 30% with random packet sizes of 0 to 6 flits drawn from seed."""
    vc = CM.visit_costs(t, cfg.processors())
    if rng.random() < 0.3:
        vc.inject_process = vc.inject_send = 0
    if seed is not None and rng.random() < 0.3:
        nr = np.random.default_rng(seed)
        vc.flits = nr.integers(0, 7, len(vc.flits)).astype(np.int32)
        vc.inject_flits = int(nr.integers(0, 4))
    return vc
