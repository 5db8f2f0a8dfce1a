/* replay.h: the compiled replay's internals, shared by replay.c (the machine and its
 * run), replay_config.c (configurations, making and destroying a replay),
 * replay_load.c (checking and packing a trace) and replay_result.c (the figures). */
#ifndef MPRT_REPLAY_H
#define MPRT_REPLAY_H

#include "mprt_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#define NOINLINE __attribute__((noinline))
#else
#define INLINE static inline
#define NOINLINE
#endif

#define RETIRE (-1)
#define CHILDREN (-2)
/* what follows a visit (vinfo.next bits 0-1) */
#define NEXT_VISIT 0     /* bits 2-3: the next visit's subtask */
#define NEXT_RETIRE 1
#define NEXT_CHILDREN 2  /* bits 2-9: rays made; bits 10-: their first in child[] */
#define DIS_WAITER (-1)
#define MAX_PES (1 << 20)
#define MAX_PROCS (1 << 24)

/* A growable ring buffer of int64 (capacity a power of two). */
typedef struct {
    int64_t *buf;
    size_t cap, head, len;
} queue;

/* A FIFO of packets with its occupancy statistics. */
typedef struct {
    queue q;
    int64_t cap;                 /* 0: unbounded */
    uint64_t sojourn;            /* packets' cycles in it so far: sum of gets' cycles - puts' (mod 2^64) */
    int64_t last, max, puts;
} fifo;

typedef struct {
    fifo rf, sf;                 /* receive FIFO (visits); send FIFO (visit * 4 + stage) */
    queue local;                 /* packets to itself */
    queue rwait;                 /* waiting for a receive slot: sending stage, or DIS_WAITER */
    queue swait;                 /* blocked replicas waiting for a send slot */
    uint64_t *idle;              /* bit k: replica k idle */
    int nidle;
    int stage, pe, first, n;     /* stage index, PE, first processor, replicas */
    int64_t generated;
    int feed;                    /* 0 shared; 1 round-robin, 2 shortest queue: then per replica */
    fifo *rfs;                   /* ... its receive FIFO (rf unused) */
    queue *locals;               /* ... its local queue (local unused) */
    int64_t turn;                /* round-robin: packets assigned so far */
} node;

typedef struct {
    int64_t cur, busy, blocked, since, visits;
    int64_t until;               /* when its last visit started ends */
    int64_t next;                /* that visit's next field (see vinfo) */
    int64_t px;                  /* blocked with one packet: its visit (pg: its stage) */
    int64_t pa, pb;              /* blocked with made rays: child[pa .. pb) still to send */
    int pg, single;
    int state, node, k, pe;
    int64_t stall;               /* level 3: memory stall cycles (in busy) */
} proc;

typedef struct {
    int64_t live, max_live, retired, end, admitted;
    int holding;
    int64_t hold;
    int64_t next, step, stop;    /* static DIS order */
    int64_t cost[9];             /* by subtask: process, communication cycles, visits */
} pe_t;

/* What the replay reads of a visit: its cycles and what follows it.  Packed
 * in 8 bytes when the trace allows (cycles below 2^24, fewer than 2^29 rays
 * made): bits 0-9 the next field's, 10-33 the cycles, 34-63 the next field's
 * child index (its bits 10-); else 16 bytes. */
typedef struct {
    int64_t dur, next;
} vinfo;

#define PACK_DUR_BITS 24
#define PACK_KID_LIMIT ((int64_t)1 << 29)

struct mprt_replay {
    mprt_replay_config cfg;
    char errmsg[1024];
    int nproc, nnode;
    proc *procs;
    node *nodes;
    pe_t *pes;
    int64_t *heap_t, *heap_p;    /* pending events: time, priority (rank, or processors + rank) */
    int32_t *heap_i;             /* ... and processor */
    int nheap;
    int small;                   /* at most SMALL_PROCS processors: pending events by processor, no heap */
    /* the trace (buffers kept from run to run; cap_*: their capacities) */
    size_t nv, nr;
    vinfo *vi;                   /* per visit (wide) */
    uint64_t *vp;                /* per visit (packed) */
    int wide;
    int64_t *ray_first;          /* per ray: its first visit */
    int64_t *child_start;        /* per ray + 1: its children are child[child_start[r] .. child_start[r+1]) */
    int64_t *tree_of;            /* per ray: its tree */
    int64_t *child;              /* rays made, by parent, in id order: ray ids, then their first visits */
    int64_t *tree_first;         /* per tree: its first visit */
    int64_t *tree_cost;          /* per tree: process, communication cycles, visits by subtask */
    int32_t *tree_pe;            /* per tree: the PE that admitted it */
    int64_t *tree_admit;         /* per tree: when it was admitted */
    int64_t *tree_busy;          /* record_busy: per tree and stage, busy cycles at its admission */
    size_t cap_tree_busy;
    int record_busy, busy_recorded;   /* asked for; done in the last run */
    size_t cap_vi, cap_ray, cap_ray2, cap_ray3, cap_child, cap_tree, cap_tree9, cap_tree_pe, cap_tree_admit, cap_vp;
    int64_t ntrees, max_leaves;
    int64_t total;               /* the visits' cycles in all */
    int loaded;
    /* the run */
    int64_t now, retired, t_end, shared_next;
    int64_t *log;
    size_t nlog;
    int oom, ran, deadlocked;
    /* level 3: the memories (replay_memory.c) */
    struct mprt__mem *mem;       /* the data of mprt_replay_set_memory, and a run's caches and ports */
    int mem_on;                  /* this run models a memory: start() adds stalls */
    int64_t mem_bound;           /* the most cycles this run's stalls can add */
};

/* Set r's message (printf-style) and return status. */
int mprt__replay_fail(mprt_replay *r, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
#define fail mprt__replay_fail

/* Make room for n elements of size bytes in *p (capacity *cap, kept between runs). */
int mprt__replay_reserve(void **p, size_t *cap, size_t n, size_t size);
#define RESERVE(r, field, capfield, n) \
    mprt__replay_reserve((void **)&(r)->field, &(r)->capfield, (n), sizeof *(r)->field)

/* Level 3 (replay_memory.c): check the config's memory fields; make a run's caches and
 * ports (after the checks of mprt_replay_run; sets mem_on, mem_bound); the stall of visit
 * j starting now on processor i; free a run's caches, and the data. */
int mprt__replay_memory_check(mprt_replay *r, const mprt_replay_config *c);
int mprt__replay_memory_build(mprt_replay *r);
int64_t mprt__replay_stall(mprt_replay *r, int i, int64_t j);
void mprt__replay_memory_free_run(mprt_replay *r);
void mprt__replay_memory_free(mprt_replay *r);

/* Free what a run built (replay.c), and the loaded trace (replay_load.c). */
void mprt__replay_free_run(mprt_replay *r);
void mprt__replay_free_trace(mprt_replay *r);

#endif
