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
    int64_t lim;                 /* room while fewer packets: cap - reserved (INT64_MAX: unbounded) */
    uint64_t sojourn;            /* packets' cycles in it so far: sum of gets' cycles - puts' (mod 2^64) */
    int64_t last, max, puts;
    int64_t reserved;            /* slots claimed by packets still on the ring */
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

/* ---- the ring (level 2; replay_ring.c) ---- */
#define RING_MAX 3               /* nodes of a ring: the stages of a PE */
enum { RING_HOP = 0, RING_CLAIM = 1, RING_BODY = 2 };
enum { RING_NONE = 0, RING_ARRIVE = 1, RING_BODY_DONE = 2 };

/* A packet in the network: at most one per source node (it stays in the send
 * FIFO until its tail has left), so kept by its source node. */
typedef struct {
    int64_t x;                   /* the visit it starts */
    int64_t flits;
    int src, dst, node, hops;    /* node: where its header is; hops: links it has crossed */
    unsigned path;               /* those links (bit n: link n) */
    int phase;                   /* RING_HOP, RING_CLAIM (header at its destination), RING_BODY */
    int copy;                    /* the replica whose receive slot it claimed (a per-replica feed) */
    int event;                   /* pending: RING_ARRIVE (a hop ends) or RING_BODY_DONE */
    int held[RING_MAX + 1];      /* the buffers it holds, by hop (node x RING_MAX + class) */
} ring_packet;

/* The ring of one PE. */
typedef struct {
    int id, K, C;                /* its PE; nodes, buffer classes */
    node *nd;                    /* the PE's stages: node n is nd[n] */
    unsigned busy;               /* links held (bit n: link n) */
    unsigned ready;              /* nodes whose send FIFO holds a packet not in the network */
    int64_t link_cycles[RING_MAX];
    int buf[RING_MAX * RING_MAX]; /* node x RING_MAX + class: the packet holding it (its source), -1 free */
    int nxt[RING_MAX];           /* the node after node n */
    int cls[RING_MAX + 1];       /* the buffer class a header takes after h hops */
    int injected[RING_MAX];      /* node n's packet is in the network */
    int writer[RING_MAX];        /* node n's receive FIFO is being written by this packet, -1 none */
    int waiting[RING_MAX];       /* packets waiting for a grant, in the order they began to wait */
    int nwaiting;
    int claiming;                /* waiting headers claiming their receive FIFO */
    int kicking, again;
    ring_packet pkt[RING_MAX];
} ring_t;

/* What the replay reads of a visit: its cycles and what follows it.  Packed
 * in 8 bytes when the trace allows (cycles below 2^24, fewer than 2^29 rays
 * made): bits 0-9 the next field's, 10-33 the cycles, 34-63 the next field's
 * child index (its bits 10-); else 16 bytes. */
typedef struct {
    int64_t dur, next;
} vinfo;

#define PACK_DUR_BITS 24
#define PACK_KID_LIMIT ((int64_t)1 << 29)

/* A packed visit unpacked. */
INLINE vinfo unpack_visit(uint64_t w)
{
    vinfo v;
    v.dur = (int64_t)((w >> 10) & (((uint64_t)1 << PACK_DUR_BITS) - 1));
    v.next = (int64_t)((w >> 34) << 10 | (w & 1023));
    return v;
}

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
    int pmin;                    /* ... with a ring: the first of them, -1 not known */
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
    int64_t loads;               /* traces loaded so far (a load makes tree_cp stale) */
    int64_t *tree_cp;            /* per tree: its critical path, the longest chain of visits' cycles
                                  * (mprt_replay_work_bound's; made for the load numbered cp_load) */
    size_t cap_tree_cp;
    int64_t cp_load;
    int64_t *tree_ex;            /* per tree and subtask: the visits' cycles it runs (made with tree_cp) */
    size_t cap_tree_ex;
    int64_t *tree_cx;            /* ... with the ring's and memories' least times, for a configuration */
    int64_t *tree_fl;            /* ... and the memories' least stalls per tree and stage */
    size_t cap_tree_cx, cap_tree_fl;
#define CX_SIG 16
    int64_t cx_sig[CX_SIG];      /* what they were made for (cx_ok: they were, for the memory
                                  * data and packet sizes set since) */
    int cx_ok;
    /* the run */
    int64_t now, retired, t_end, shared_next;
    int64_t *log;
    size_t nlog;
    int oom, ran, deadlocked;
    /* level 2: the ring */
    ring_t *rings;               /* per PE */
    int64_t *rq_t;               /* pending ring events in the order they run (time, then first
                                  * scheduled first: after the processors' of the same time), */
    int32_t *rq_s;               /* ... their packets (PE x 4 + source node), */
    size_t rq_head, rq_len, rq_mask;  /* ... a circular list of rq_mask + 1 entries */
    uint16_t *pflits;            /* per visit: flits of the packet that starts it (mprt_replay_set_flits) */
    uint8_t *child_kind;         /* per child[] entry: the ray's kind (kept by the load for set_flits) */
    size_t cap_pflits, cap_child_kind, nchild;
    int64_t max_flits;
    int flits_set;
    /* level 3: the memories (replay_memory.c) */
    struct mprt__mem *mem;       /* the data of mprt_replay_set_memory, and a run's caches and ports */
    int mem_on;                  /* this run models a memory: start() adds stalls */
    const int32_t *mem_key;      /* ... then each visit's memory key (-1: it reads none), else NULL */
    int64_t mem_bound;           /* the most cycles this run's stalls can add */
};

/* The replay's internal functions are called only within the library: hidden, so
 * that calls between its files are direct (no PLT in a shared build). */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

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

/* Free what a run built (replay_run.c), and the loaded trace (replay_load.c). */
/* Level 3 (replay_memory.c): check the config's memory fields; make a run's caches and
 * ports (after the checks of mprt_replay_run; sets mem_on, mem_bound); the stall of visit
 * j starting now on processor i; free a run's caches, and the data. */
int mprt__replay_memory_check(mprt_replay *r, const mprt_replay_config *c);
int mprt__replay_memory_build(mprt_replay *r);
int64_t mprt__replay_stall(mprt_replay *r, int i, int64_t j);
void mprt__replay_memory_free_run(mprt_replay *r);
void mprt__replay_memory_free(mprt_replay *r);
/* mprt_replay_work_bound's part of level 3 (replay_bound.c): each memory's least cycles a line read (0: it
 * adds none; returns 0 when neither does), with a cache the fewest misses of each key worked
 * out for its shape; and visit j's least stall cycles at those. */
int mprt__replay_memory_each(mprt_replay *r, int64_t *each);
int64_t mprt__replay_memory_lines(const mprt_replay *r, int64_t j, const int64_t *each);


void mprt__replay_free_run(mprt_replay *r);
/* The trees a static DIS deals PE p (replay_run.c; first, first + step, ... before stop),
 * and what a run of the configuration set is refused for, its figures (the work bound,
 * replay_bound.c, refuses the same). */
void mprt__replay_deal(const mprt_replay *r, int p, int64_t *first, int64_t *stop, int64_t *step);
int mprt__replay_check_figures(mprt_replay *r);
void mprt__replay_free_trace(mprt_replay *r);

/* The machine (replay.c): admit each PE's first trees and run the events. */
void mprt__replay_loop(mprt_replay *r);
/* ... for the ring: start packet x on replica k of nd (k < 0: its lowest idle
 * processor; idle), offer a freed send slot of src to its blocked processors,
 */
void mprt__replay_start_on(mprt_replay *r, node *nd, int k, int64_t x);
/* The busy record (replay_run.c): each stage's busy cycles by now, at tree t's admission. */
void mprt__replay_note_busy(mprt_replay *r, int64_t t);
void mprt__replay_send_freed(mprt_replay *r, node *src);

/* The ring (replay_ring.c): made for a run, a packet sent (0: the send FIFO is
 * full), the arbiter, the first pending ring event run (r->now its time). */
int mprt__ring_build(mprt_replay *r);
int mprt__ring_send(mprt_replay *r, node *src, int64_t x, int g);
void mprt__ring_kick(mprt_replay *r, int pe);
/* A receive slot of a stage of PE pe freed: the arbiter, if a header waits to claim a
 * receive FIFO.  Else it would grant nothing: after an arbitration nothing can proceed,
 * and until the next one only a claim can become possible (room, a round-robin turn);
 * links, buffers and send FIFOs change only in the ring's events and sends, which
 * arbitrate. */
INLINE void ring_freed(mprt_replay *r, int pe)
{
    if (r->rings[pe].claiming) mprt__ring_kick(r, pe);
}
void mprt__ring_event(mprt_replay *r);

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

/* ---- queues and FIFOs (the replay's and the ring's) ---------------------------- */

static inline int q_grow(queue *q)
{
    size_t ncap = q->cap ? 2 * q->cap : 8, i;
    int64_t *b;
    if (ncap > SIZE_MAX / (2 * sizeof *b)) return -1;
    b = malloc(ncap * sizeof *b);
    if (!b) return -1;
    for (i = 0; i < q->len; i++) b[i] = q->buf[(q->head + i) & (q->cap - 1)];
    free(q->buf);
    q->buf = b;
    q->cap = ncap;
    q->head = 0;
    return 0;
}

INLINE void q_push(mprt_replay *r, queue *q, int64_t x)
{
    if (q->len == q->cap && q_grow(q)) {
        r->oom = 1;
        return;
    }
    q->buf[(q->head + q->len) & (q->cap - 1)] = x;
    q->len++;
}

INLINE int64_t q_pop(queue *q)
{
    int64_t x = q->buf[q->head];
    q->head = (q->head + 1) & (q->cap - 1);
    q->len--;
    return x;
}

static inline void q_free(queue *q)
{
    free(q->buf);
    memset(q, 0, sizeof *q);
}

INLINE int f_room(const fifo *f) { return (int64_t)f->q.len < f->lim; }

/* A FIFO of capacity cap (0: unbounded), empty. */
INLINE void f_init(fifo *f, int64_t cap)
{
    f->cap = cap;
    f->lim = cap ? cap : INT64_MAX;
}

/* The occupancy integrated over time is the packets' time in the FIFO: each
 * put subtracts its cycle, each get adds its cycle, and packets still in it
 * count to the end (f_area). */
INLINE void f_put(mprt_replay *r, fifo *f, int64_t x)
{
    f->sojourn -= (uint64_t)r->now;
    f->last = r->now;
    q_push(r, &f->q, x);
    f->puts++;
    if ((int64_t)f->q.len + f->reserved > f->max) f->max = (int64_t)f->q.len + f->reserved;
}

INLINE int64_t f_get(mprt_replay *r, fifo *f)
{
    f->sojourn += (uint64_t)r->now;
    f->last = r->now;
    return q_pop(&f->q);
}

/* The ring's slots (level 2): reserved for a packet still on the ring when its
 * header claims the FIFO; given back when the packet goes to an idle processor,
 * filled when it goes in (the slot stays occupied, counted since the claim). */
INLINE void f_reserve(mprt_replay *r, fifo *f)
{
    f->reserved++;
    if (f->cap) f->lim--;
    f->sojourn -= (uint64_t)r->now;
    f->last = r->now;
    if ((int64_t)f->q.len + f->reserved > f->max) f->max = (int64_t)f->q.len + f->reserved;
}

INLINE void f_unreserve(mprt_replay *r, fifo *f)
{
    f->reserved--;
    if (f->cap) f->lim++;
    f->sojourn += (uint64_t)r->now;
    f->last = r->now;
}

INLINE void f_fill(mprt_replay *r, fifo *f, int64_t x)
{
    f->reserved--;
    if (f->cap) f->lim++;
    q_push(r, &f->q, x);
    f->puts++;
}

/* With few processors (and times that leave room) the pending events sit by
 * processor as one key, time << SMALL_SHIFT | priority (INT64_MAX: none; a
 * processor has at most one), and the first is found by a scan. */
#define SMALL_PROCS 8    /* (small_first compares 8 keys) */
#define SMALL_SHIFT 5    /* priorities are below 2 x SMALL_PROCS + 2 <= 32 */

/* ---- the processors' events (replay.c) ---------------------------------------- */

/* The event heap: parallel arrays (time, priority, processor), written and
 * read field by field. */
INLINE int ev_before(int64_t t1, int64_t p1, int64_t t2, int64_t p2) { return t1 < t2 || (t1 == t2 && p1 < p2); }

INLINE void heap_push(mprt_replay *r, int64_t t, int64_t prio, int i)
{
    int c = r->nheap++;
    if (r->small) {
        r->heap_t[i] = t << SMALL_SHIFT | prio;
        if (r->pmin >= 0 && r->heap_t[i] < r->heap_t[r->pmin]) r->pmin = i;
        return;
    }
    int64_t *ht = r->heap_t, *hp = r->heap_p;
    int32_t *hi = r->heap_i;
    while (c > 0) {
        int p = (c - 1) / 2;
        if (!ev_before(t, prio, ht[p], hp[p])) break;
        ht[c] = ht[p];
        hp[c] = hp[p];
        hi[c] = hi[p];
        c = p;
    }
    ht[c] = t;
    hp[c] = prio;
    hi[c] = i;
}

/* With few processors: the one whose event is first (there is one).  The least key
 * names it: its priority is the processor's rank, or processors + rank. */
INLINE int64_t min64(int64_t a, int64_t b) { return a < b ? a : b; }

INLINE int small_first(const mprt_replay *r)
{
    const int64_t *h = r->heap_t;     /* (SMALL_PROCS keys: INT64_MAX past the processors) */
    int64_t low = min64(min64(min64(h[0], h[1]), min64(h[2], h[3])), min64(min64(h[4], h[5]), min64(h[6], h[7])));
    int n = r->nproc, prio = (int)(low & ((1 << SMALL_SHIFT) - 1));
    return prio <= n ? prio - 1 : prio - n - 1;
}

/* Take the first event: its processor (its time in *t). */
INLINE int heap_pop(mprt_replay *r, int64_t *t)
{
    int64_t *ht = r->heap_t, *hp = r->heap_p;
    int32_t *hi = r->heap_i;
    int n = --r->nheap, c = 0, top;
    int64_t lt, lp;
    int32_t li;
    if (r->small) {
        int m = small_first(r);
        *t = ht[m] >> SMALL_SHIFT;
        ht[m] = INT64_MAX;
        return m;
    }
    top = hi[0];
    lt = ht[n];
    lp = hp[n];
    li = hi[n];
    *t = ht[0];
    for (;;) {
        int a = 2 * c + 1, m;
        if (a >= n) break;
        m = (a + 1 < n && ev_before(ht[a + 1], hp[a + 1], ht[a], hp[a])) ? a + 1 : a;
        if (!ev_before(ht[m], hp[m], lt, lp)) break;
        ht[c] = ht[m];
        hp[c] = hp[m];
        hi[c] = hi[m];
        c = m;
    }
    if (n > 0) {
        ht[c] = lt;
        hp[c] = lp;
        hi[c] = li;
    }
    return top;
}

INLINE const void *v_addr(const mprt_replay *r, int64_t j)
{
    return r->wide ? (const void *)&r->vi[j] : (const void *)&r->vp[j];
}

/* ---- idle processors and replicas ---- */

static inline int ctz64(uint64_t x)
{
#if defined(__GNUC__)
    return __builtin_ctzll(x);
#else
    int n = 0;
    while (!(x & 1)) {
        x >>= 1;
        n++;
    }
    return n;
#endif
}

/* The lowest idle processor of a stage (there is one), now taken. */
INLINE int take_idle(node *nd)
{
    int w = 0, k;
    while (!nd->idle[w]) w++;
    k = 64 * w + ctz64(nd->idle[w]);
    nd->idle[w] &= nd->idle[w] - 1;
    nd->nidle--;
    return nd->first + k;
}

/* Replica k of nd (idle) is taken. */
INLINE int take_copy(node *nd, int k)
{
    nd->idle[k / 64] &= ~((uint64_t)1 << (k % 64));
    nd->nidle--;
    return nd->first + k;
}

INLINE int copy_idle(const mprt_replay *r, const node *nd, int k)
{
    return r->procs[nd->first + k].state == MPRT_PROC_IDLE;
}

/* Replica k's packets: its receive FIFO and local queue, and the one it holds unless idle. */
INLINE int64_t queued(const mprt_replay *r, const node *nd, int k)
{
    return (int64_t)nd->rfs[k].q.len + nd->rfs[k].reserved + (int64_t)nd->locals[k].len + !copy_idle(r, nd, k);
}

#endif
