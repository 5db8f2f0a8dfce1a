/* replay.c: the compiled replay (level 1 of the fidelity ladder, see mprt.h).
 *
 * A discrete-event replay of a costed trace on PEs of stages joined by an
 * ideal network.  It follows the SimPy machine model's rules step for step
 * (python/mprt/machine: stage.py, network.py, pe.py; README.md there), so
 * that the two give the same cycle counts:
 *
 * - Each processor has at most one pending event: the end of its visit
 *   (key: cycle, rank) or its resumption after a block (key: cycle,
 *   processors + rank); ranks are 1, 2, ... over PEs, stages, replicas.
 *   Events run in key order, so simultaneous ends run in rank order.
 * - At a visit's end the processor sends the ray's packet to the stage of
 *   the ray's next visit (its own stage: to an idle replica or its local
 *   queue; another: the network), or retires the ray after sending the
 *   rays an SC visit made (in id order) to OS; a full send FIFO blocks it
 *   holding what it could not send.  Then it takes the next packet (local
 *   queue first, then the receive FIFO) or becomes idle.
 * - The network moves a packet straight into the destination (its lowest
 *   idle processor, else its receive FIFO) when nothing waits in the
 *   sender's send FIFO and there is room; otherwise the packet waits in the
 *   send FIFO, whose head moves when a slot frees (waiters first come,
 *   first served), and blocked processors then place their packets.
 * - DIS admits its PE's trees while fewer than `window` rays are live; a
 *   tree's primary goes to SC (which spends gen_cycles making it) or
 *   straight to OS; when there is no room it waits for a slot.
 *
 * Costs are the caller's (process, receive, send per visit).  Nothing
 * recurses and every loop either makes progress or ends, so a run ends; if
 * it ends with rays still in the machine, that is a deadlock. */
#include "mprt_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#else
#define INLINE static inline
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
} node;

typedef struct {
    int64_t cur, busy, blocked, since, visits;
    int64_t until;               /* when its last visit started ends */
    int64_t next;                /* that visit's next field (see vinfo) */
    int64_t px;                  /* blocked with one packet: its visit (pg: its stage) */
    int64_t pa, pb;              /* blocked with made rays: child[pa .. pb) still to send */
    int pg, single;
    int state, node, k, pe;
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
};

static int fail(mprt_replay *r, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static int fail(mprt_replay *r, int status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    mprt__vformat(r->errmsg, sizeof r->errmsg, fmt, ap);
    va_end(ap);
    return status;
}

/* ---- queues ---------------------------------------------------------------- */

static int q_grow(queue *q)
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

static void q_free(queue *q)
{
    free(q->buf);
    memset(q, 0, sizeof *q);
}

INLINE int f_room(const fifo *f) { return f->cap == 0 || (int64_t)f->q.len < f->cap; }

/* The occupancy integrated over time is the packets' time in the FIFO: each
 * put subtracts its cycle, each get adds its cycle, and packets still in it
 * count to the end (f_area). */
INLINE void f_put(mprt_replay *r, fifo *f, int64_t x)
{
    f->sojourn -= (uint64_t)r->now;
    f->last = r->now;
    q_push(r, &f->q, x);
    f->puts++;
    if ((int64_t)f->q.len > f->max) f->max = (int64_t)f->q.len;
}

INLINE int64_t f_get(mprt_replay *r, fifo *f)
{
    f->sojourn += (uint64_t)r->now;
    f->last = r->now;
    return q_pop(&f->q);
}

/* Occupancy integrated over [0, max(end, last change)]. */
static int64_t f_area(const fifo *f, int64_t end)
{
    int64_t t = end > f->last ? end : f->last;
    return (int64_t)(f->sojourn + (uint64_t)f->q.len * (uint64_t)t);
}

/* ---- events ---------------------------------------------------------------- */

/* The event heap: parallel arrays (time, priority, processor), written and
 * read field by field. */
INLINE int ev_before(int64_t t1, int64_t p1, int64_t t2, int64_t p2) { return t1 < t2 || (t1 == t2 && p1 < p2); }

/* With few processors (and times that leave room) the pending events sit by
 * processor as one key, time << SMALL_SHIFT | priority (INT64_MAX: none; a
 * processor has at most one), and the first is found by a scan. */
#define SMALL_PROCS 8
#define SMALL_SHIFT 5    /* priorities are below 2 x SMALL_PROCS + 2 <= 32 */

INLINE void heap_push(mprt_replay *r, int64_t t, int64_t prio, int i)
{
    int c = r->nheap++;
    if (r->small) {
        r->heap_t[i] = t << SMALL_SHIFT | prio;
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

/* Take the first event: its processor (its time in *t). */
INLINE int heap_pop(mprt_replay *r, int64_t *t)
{
    int64_t *ht = r->heap_t, *hp = r->heap_p;
    int32_t *hi = r->heap_i;
    int n = --r->nheap, c = 0, top;
    int64_t lt, lp;
    int32_t li;
    if (r->small) {
        int k, m = 0;
        for (k = 1; k < r->nproc; k++) m = ht[k] < ht[m] ? k : m;
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

/* ---- the machine ------------------------------------------------------------- */

#ifndef TREE_PREFETCH
#define TREE_PREFETCH 4096   /* bytes of a tree's visits fetched ahead */
#endif

/* A hint to fetch memory soon needed (a tree's later visits are read later). */
#if defined(__GNUC__)
#define PREFETCH(p) __builtin_prefetch(p)
#else
#define PREFETCH(p) ((void)(p))
#endif

static int ctz64(uint64_t x)
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

INLINE node *node_of(mprt_replay *r, int pe, int stage) { return &r->nodes[pe * r->cfg.nstages + stage]; }

/* Stage g of nd's PE (a PE's stages are contiguous). */
INLINE node *sibling(node *nd, int g) { return nd - nd->stage + g; }

INLINE void logev(mprt_replay *r, int what, int i, int64_t j)
{
    if (r->log) {
        int64_t *e = r->log + 4 * r->nlog++;
        e[0] = r->now;
        e[1] = what;
        e[2] = i;
        e[3] = j;
    }
}

/* Processor i begins visit j (j < 0: making primary ray ~j) now. */
INLINE void start(mprt_replay *r, int i, int64_t j)
{
    proc *p = &r->procs[i];
    int64_t d;
    if (j >= 0) {
        if (r->wide) {
            d = r->vi[j].dur;
            p->next = r->vi[j].next;
        } else {
            uint64_t w = r->vp[j];
            d = (int64_t)((w >> 10) & (((uint64_t)1 << PACK_DUR_BITS) - 1));
            p->next = (int64_t)((w >> 34) << 10 | (w & 1023));
        }
        PREFETCH(v_addr(r, j + 4));
    } else {
        d = r->cfg.gen_cycles;
        r->nodes[p->node].generated++;
    }
    p->cur = j;
    p->state = MPRT_PROC_BUSY;
    p->busy += d;
    p->until = r->now + d;
    p->visits++;
    logev(r, 0, i, j);
    heap_push(r, r->now + d, i + 1, i);
}

INLINE void accept(mprt_replay *r, node *nd, int64_t x)
{
    if (x >= 0) PREFETCH(v_addr(r, x));
    if (nd->nidle)
        start(r, take_idle(nd), x);
    else
        f_put(r, &nd->rf, x);
}

INLINE int net_send(mprt_replay *r, node *src, int64_t x, int g)
{
    node *dst = sibling(src, g);
    PREFETCH(v_addr(r, x));
    if (src->sf.q.len == 0) {
        if (dst->nidle) {
            start(r, take_idle(dst), x);
            return 1;
        }
        if (f_room(&dst->rf)) {
            f_put(r, &dst->rf, x);
            return 1;
        }
    }
    if (f_room(&src->sf)) {
        f_put(r, &src->sf, x * 4 + g);
        if (src->sf.q.len == 1) q_push(r, &dst->rwait, src->stage);
        return 1;
    }
    return 0;
}

INLINE int output(mprt_replay *r, node *src, int64_t x, int g)
{
    if (g == src->stage) {
        PREFETCH(v_addr(r, x));
        if (src->nidle)
            start(r, take_idle(src), x);
        else
            q_push(r, &src->local, x);
        return 1;
    }
    return net_send(r, src, x, g);
}

/* A send slot of src freed: blocked processors place their packets, first
 * come first served; one that placed all resumes now. */
static void send_freed(mprt_replay *r, node *src)
{
    int os = r->cfg.stage_of[0];
    while (src->swait.len) {
        int i = src->first + (int)src->swait.buf[src->swait.head];
        proc *p = &r->procs[i];
        if (p->single) {
            if (!net_send(r, src, p->px, p->pg)) return;
            p->single = 0;
        } else {
            while (p->pa < p->pb) {
                if (!net_send(r, src, r->child[p->pa], os)) return;
                p->pa++;
            }
        }
        q_pop(&src->swait);
        p->state = MPRT_PROC_RESUMING;
        p->blocked += r->now - p->since;
        heap_push(r, r->now, r->nproc + i + 1, i);
    }
}

/* Move src's send FIFO head packets on while their receivers have room. */
static void advance(mprt_replay *r, node *src)
{
    while (src->sf.q.len) {
        int64_t e = src->sf.q.buf[src->sf.q.head], x = e >> 2;
        node *dst = sibling(src, (int)(e & 3));
        if (dst->nidle) {
            f_get(r, &src->sf);
            start(r, take_idle(dst), x);
        } else if (f_room(&dst->rf)) {
            f_get(r, &src->sf);
            f_put(r, &dst->rf, x);
        } else {
            q_push(r, &dst->rwait, src->stage);
            return;
        }
        send_freed(r, src);
    }
}

static int64_t next_tree(mprt_replay *r, pe_t *e)
{
    if (r->cfg.dis == MPRT_DIS_DYNAMIC) return r->shared_next < r->ntrees ? r->shared_next++ : -1;
    if (e->next < e->stop) {
        int64_t t = e->next;
        e->next += e->step;
        return t;
    }
    return -1;
}

/* Fetch a tree's visits ahead of their use (its rays jump about in them). */
static void prefetch_tree(const mprt_replay *r, int64_t t)
{
    const char *a, *b;
    if (t >= r->ntrees) return;
    a = (const char *)v_addr(r, r->tree_first[t]);
    b = (const char *)v_addr(r, t + 1 < r->ntrees ? r->tree_first[t + 1] : (int64_t)r->nv);
    if (b - a > TREE_PREFETCH) b = a + TREE_PREFETCH;
    for (; a < b; a += 64) PREFETCH(a);
}

/* Each stage's busy cycles by now, at tree t's admission. */
static void note_busy(mprt_replay *r, int64_t t)
{
    int64_t *b = r->tree_busy + t * r->cfg.nstages;
    int i;
    memset(b, 0, (size_t)r->cfg.nstages * sizeof *b);
    for (i = 0; i < r->nproc; i++) {
        const proc *p = &r->procs[i];
        b[r->nodes[p->node].stage] += p->busy - (p->until > r->now ? p->until - r->now : 0);
    }
}

static void dis_admit(mprt_replay *r, int pe)
{
    pe_t *e = &r->pes[pe];
    int gen = r->cfg.gen_cycles > 0;
    node *dst = node_of(r, pe, r->cfg.stage_of[gen ? 2 : 0]);
    if (e->holding) return;
    while (e->live < r->cfg.window) {
        int64_t t = next_tree(r, e), x;
        if (t < 0) return;
        x = gen ? ~t : r->tree_first[t];
        /* this tree's visits were fetched with the previous one's admission; the next's now */
        if (e->admitted == 0) prefetch_tree(r, t);
        prefetch_tree(r, r->cfg.dis == MPRT_DIS_DYNAMIC ? r->shared_next : e->next);
        r->tree_pe[t] = pe;
        r->tree_admit[t] = r->now;
        if (r->record_busy) note_busy(r, t);
        e->live++;
        if (e->live > e->max_live) e->max_live = e->live;
        e->admitted++;
        if (dst->nidle || f_room(&dst->rf)) {
            accept(r, dst, x);
        } else {
            e->holding = 1;
            e->hold = x;
            q_push(r, &dst->rwait, DIS_WAITER);
            return;
        }
    }
}

static void dis_release(mprt_replay *r, int pe)
{
    pe_t *e = &r->pes[pe];
    int64_t x = e->hold;
    e->holding = 0;
    accept(r, node_of(r, pe, r->cfg.stage_of[x >= 0 ? 0 : 2]), x);
    dis_admit(r, pe);
}

/* A receive slot of dst freed: the first waiting sender (or DIS) moves in. */
static void freed(mprt_replay *r, node *dst)
{
    while (dst->rwait.len && f_room(&dst->rf)) {
        int64_t w = q_pop(&dst->rwait);
        if (w == DIS_WAITER)
            dis_release(r, dst->pe);
        else
            advance(r, sibling(dst, (int)w));
    }
}

static void retire(mprt_replay *r, int pe)
{
    pe_t *e = &r->pes[pe];
    e->live--;
    e->retired++;
    r->retired++;
    r->t_end = e->end = r->now;
    if (e->live < r->cfg.window) dis_admit(r, pe);
}

static void block(mprt_replay *r, proc *p, node *nd)
{
    p->state = MPRT_PROC_BLOCKED;
    p->since = r->now;
    q_push(r, &nd->swait, p->k);
}

/* Where a visit's ray goes after it (a: its next field): a stage, RETIRE or CHILDREN. */
INLINE int dest(const mprt_replay *r, int64_t a)
{
    switch (a & 3) {
    case NEXT_VISIT: return r->cfg.stage_of[(a >> 2) & 3];
    case NEXT_RETIRE: return RETIRE;
    default: return CHILDREN;
    }
}

/* Processor i's event: its visit ended, or it resumes after a block. */
static void handle(mprt_replay *r, int i)
{
    proc *p = &r->procs[i];
    node *nd = &r->nodes[p->node];
    int os = r->cfg.stage_of[0];
    if (p->state == MPRT_PROC_BUSY) {
        int64_t j = p->cur;
        logev(r, 1, i, j);
        if (j < 0) {
            int64_t x = r->tree_first[~j];
            if (!output(r, nd, x, os)) {
                p->single = 1;
                p->px = x;
                p->pg = os;
                block(r, p, nd);
                return;
            }
        } else {
            int g = dest(r, p->next), ok = 1;
            if (g >= 0) {
                if (!output(r, nd, j + 1, g)) {
                    p->single = 1;
                    p->px = j + 1;
                    p->pg = g;
                    block(r, p, nd);
                    ok = 0;
                }
            } else {
                if (g == CHILDREN) {
                    pe_t *e = &r->pes[p->pe];
                    int64_t nx = p->next, a = nx >> 10, b = a + ((nx >> 2) & 255), c;
                    e->live += b - a;
                    if (e->live > e->max_live) e->max_live = e->live;
                    for (c = a; c < b; c++) {
                        if (!output(r, nd, r->child[c], os)) {
                            p->single = 0;
                            p->pa = c;
                            p->pb = b;
                            block(r, p, nd);
                            ok = 0;
                            break;
                        }
                    }
                }
                retire(r, p->pe);
            }
            if (!ok) return;
        }
    }
    if (nd->local.len) {
        start(r, i, q_pop(&nd->local));
    } else if (nd->rf.q.len) {
        start(r, i, f_get(r, &nd->rf));
        freed(r, nd);
    } else {
        p->state = MPRT_PROC_IDLE;
        nd->idle[p->k / 64] |= (uint64_t)1 << (p->k % 64);
        nd->nidle++;
    }
}

/* ---- configuration -------------------------------------------------------------- */

void mprt_replay_config_init(mprt_replay_config *c)
{
    int s;
    memset(c, 0, sizeof *c);
    c->nstages = 3;
    for (s = 0; s < 3; s++) {
        c->stage_of[s] = s;
        c->replicas[s] = 1;
    }
    c->pes = 1;
    c->dis = MPRT_DIS_DYNAMIC;
    c->window = 256;
}

static int check_config(mprt_replay *r, const mprt_replay_config *c)
{
    static const char *sub[3] = {"OS", "IC", "SC"};
    int s, t, total = 0;
    if (c->nstages < 1 || c->nstages > 3)
        return fail(r, MPRT_ERR_INVALID_ARG, "nstages: must be 1, 2 or 3, not %d", c->nstages);
    for (t = 0; t < 3; t++)
        if (c->stage_of[t] < 0 || c->stage_of[t] >= c->nstages)
            return fail(r, MPRT_ERR_INVALID_ARG, "stage_of[%d]: the stage running %s must be 0..%d, not %d", t,
                        sub[t], c->nstages - 1, c->stage_of[t]);
    for (s = 0; s < c->nstages; s++) {
        if (c->stage_of[0] != s && c->stage_of[1] != s && c->stage_of[2] != s)
            return fail(r, MPRT_ERR_INVALID_ARG, "stage_of: stage %d runs no subtask", s);
        if (c->replicas[s] < 1 || c->replicas[s] > MAX_PROCS)
            return fail(r, MPRT_ERR_INVALID_ARG, "replicas[%d]: must be 1..%d, not %d", s, MAX_PROCS,
                        c->replicas[s]);
        if (c->receive_fifo[s] < 0)
            return fail(r, MPRT_ERR_INVALID_ARG, "receive_fifo[%d]: must be >= 0 (0: unbounded), not %lld", s,
                        (long long)c->receive_fifo[s]);
        if (c->send_fifo[s] < 0)
            return fail(r, MPRT_ERR_INVALID_ARG, "send_fifo[%d]: must be >= 0 (0: unbounded), not %lld", s,
                        (long long)c->send_fifo[s]);
        total += c->replicas[s];
        if (total > MAX_PROCS)
            return fail(r, MPRT_ERR_INVALID_ARG, "replicas: at most %d processors per PE", MAX_PROCS);
    }
    if (c->pes < 1 || c->pes > MAX_PES)
        return fail(r, MPRT_ERR_INVALID_ARG, "pes: must be 1..%d, not %d", MAX_PES, c->pes);
    if ((int64_t)c->pes * total > MAX_PROCS)
        return fail(r, MPRT_ERR_INVALID_ARG, "pes: %d PEs of %d processors exceed %d processors", c->pes, total,
                    MAX_PROCS);
    if (c->dis != MPRT_DIS_BLOCKS && c->dis != MPRT_DIS_INTERLEAVED && c->dis != MPRT_DIS_DYNAMIC)
        return fail(r, MPRT_ERR_INVALID_ARG, "dis: must be blocks (0), interleaved (1) or dynamic (2), not %d",
                    c->dis);
    if (c->window < 1)
        return fail(r, MPRT_ERR_INVALID_ARG, "window: must be >= 1, not %lld", (long long)c->window);
    if (c->gen_cycles < 0)
        return fail(r, MPRT_ERR_INVALID_ARG, "gen_cycles: must be >= 0, not %lld", (long long)c->gen_cycles);
    return MPRT_OK;
}

static void free_run(mprt_replay *r)
{
    int n;
    for (n = 0; r->nodes && n < r->nnode; n++) {
        node *nd = &r->nodes[n];
        q_free(&nd->rf.q);
        q_free(&nd->sf.q);
        q_free(&nd->local);
        q_free(&nd->rwait);
        q_free(&nd->swait);
        free(nd->idle);
    }
    free(r->nodes);
    free(r->procs);
    free(r->pes);
    free(r->heap_t);
    free(r->heap_p);
    free(r->heap_i);
    r->nodes = NULL;
    r->procs = NULL;
    r->pes = NULL;
    r->heap_t = r->heap_p = NULL;
    r->heap_i = NULL;
    r->nnode = r->nproc = r->nheap = 0;
    r->ran = 0;
}

static void free_trace(mprt_replay *r)
{
    free(r->vi);
    free(r->vp);
    r->vp = NULL;
    free(r->ray_first);
    free(r->child_start);
    free(r->tree_of);
    free(r->child);
    free(r->tree_first);
    free(r->tree_cost);
    free(r->tree_pe);
    free(r->tree_admit);
    r->tree_admit = NULL;
    free(r->tree_busy);
    r->tree_busy = NULL;
    r->cap_tree_busy = 0;
    r->vi = NULL;
    r->ray_first = r->child_start = r->tree_of = r->child = r->tree_first = r->tree_cost = NULL;
    r->tree_pe = NULL;
    r->cap_vi = r->cap_ray = r->cap_ray2 = r->cap_ray3 = r->cap_child = r->cap_tree = r->cap_tree9 = r->cap_tree_pe = r->cap_tree_admit = r->cap_vp = 0;
    r->loaded = 0;
}

/* The per-ray arrays are needed while loading only. */
static void free_ray_arrays(mprt_replay *r)
{
    free(r->ray_first);
    free(r->child_start);
    free(r->tree_of);
    r->ray_first = r->child_start = r->tree_of = NULL;
    r->cap_ray = r->cap_ray2 = r->cap_ray3 = 0;
}

int mprt_replay_create(const mprt_replay_config *cfg, mprt_replay **out)
{
    mprt_replay *r;
    int rc;
    if (!out) return MPRT_ERR_INVALID_ARG;
    *out = NULL;
    r = calloc(1, sizeof *r);
    if (!r) return MPRT_ERR_OUT_OF_MEMORY;
    *out = r;
    if (!cfg) return fail(r, MPRT_ERR_INVALID_ARG, "no configuration");
    rc = check_config(r, cfg);
    if (rc != MPRT_OK) return rc;
    r->cfg = *cfg;
    return MPRT_OK;
}

int mprt_replay_set_config(mprt_replay *r, const mprt_replay_config *cfg)
{
    int rc;
    if (!r) return MPRT_ERR_INVALID_ARG;
    if (!cfg) return fail(r, MPRT_ERR_INVALID_ARG, "no configuration");
    rc = check_config(r, cfg);
    if (rc != MPRT_OK) return rc;
    free_run(r);
    r->cfg = *cfg;
    return MPRT_OK;
}

void mprt_replay_destroy(mprt_replay *r)
{
    if (!r) return;
    free_run(r);
    free_trace(r);
    free(r);
}

const char *mprt_replay_errmsg(const mprt_replay *r) { return r ? r->errmsg : "no replay"; }

/* ---- the trace ---------------------------------------------------------------- */

#define TRACE_FAIL(r, ...) fail((r), MPRT_ERR_INVALID_ARG, "cannot replay this trace: " __VA_ARGS__)

/* Make room for n elements of size bytes in *p (capacity *cap, kept between runs). */
static int reserve(void **p, size_t *cap, size_t n, size_t size)
{
    void *b;
    if (n <= *cap && *p) return 0;
    if (n > SIZE_MAX / size / 2) return -1;
    b = malloc(n * size);
    if (!b) return -1;
    free(*p);
    *p = b;
    *cap = n;
    return 0;
}

#define RESERVE(r, field, capfield, n) reserve((void **)&(r)->field, &(r)->capfield, (n), sizeof *(r)->field)

/* The rays: ids in order, known kinds, each tree's rays after its primary,
 * each parent before its children and in their tree; children listed by
 * parent, in id order. */
static int prepare_rays(mprt_replay *r, const mprt_trace_ray *rays, size_t nr)
{
    size_t i;
    int64_t t = -1, root = -1, leaves = 0, *cs;
    if (RESERVE(r, ray_first, cap_ray, nr + 2) || RESERVE(r, child_start, cap_ray2, nr + 2) ||
        RESERVE(r, tree_of, cap_ray3, nr + 2))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %zu rays", nr);
    cs = r->child_start;
    memset(cs, 0, (nr + 2) * sizeof *cs);
    for (i = 0; i < nr; i++) {
        const mprt_trace_ray *y = &rays[i];
        if (y->id != (int64_t)i) return TRACE_FAIL(r, "ray ids are not 0..n-1 in order");
        if (y->kind > MPRT_RAY_SHADOW) return TRACE_FAIL(r, "ray %zu: kind %d is not a ray kind", i, y->kind);
        if (y->kind == MPRT_RAY_PRIMARY) {
            t++;
            root = (int64_t)i;
        } else if (i == 0) {
            return TRACE_FAIL(r, "the first ray is not a primary ray");
        } else if (y->parent < root || y->parent >= (int64_t)i) {
            return TRACE_FAIL(r, "ray %zu is not stored after its parent within its primary's tree (traces made by "
                                 "mprt are)", i);
        } else {
            cs[y->parent + 2]++;
        }
        r->tree_of[i] = t;
        r->ray_first[i] = -1;
    }
    r->ntrees = t + 1;
    /* cs[p + 2] counts p's children; after the sums cs[p + 1] is where they go */
    for (i = 2; i < nr + 2; i++) cs[i] += cs[i - 1];
    if (RESERVE(r, child, cap_child, (size_t)cs[nr + 1] + 1))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %zu rays", nr);
    for (i = 0; i < nr; i++)
        if (rays[i].kind != MPRT_RAY_PRIMARY) r->child[cs[rays[i].parent + 1]++] = (int64_t)i;
    /* now cs[p] .. cs[p + 1] are p's children; the most leaves of any tree */
    r->max_leaves = 0;
    for (i = 0; i <= nr; i++) {
        if (i == nr || rays[i].kind == MPRT_RAY_PRIMARY) {
            if (leaves > r->max_leaves) r->max_leaves = leaves;
            leaves = 0;
        }
        if (i < nr && cs[i + 1] == cs[i]) leaves++;
    }
    return MPRT_OK;
}

/* Pack the visit infos in 8 bytes each when they fit (half the memory the
 * replay walks). */
static void pack(mprt_replay *r, int64_t maxdur)
{
    size_t j;
    r->wide = 1;
    if (maxdur >= ((int64_t)1 << PACK_DUR_BITS) || r->child_start[r->nr] >= PACK_KID_LIMIT ||
        RESERVE(r, vp, cap_vp, r->nv + 1))
        return;
    for (j = 0; j < r->nv; j++) {
        uint64_t nx = (uint64_t)r->vi[j].next;
        r->vp[j] = (nx >> 10) << 34 | (uint64_t)r->vi[j].dur << 10 | (nx & 1023);
    }
    r->vp[r->nv] = 0;
    r->wide = 0;
}

/* The visits, in one pass: each tree's visits contiguous and in order,
 * starting with its primary's; each ray's contiguous; known stages; costs
 * of at least one cycle; an SC visit that ends its ray made as many rays as
 * have it as parent.  Fills the visit infos and the trees' costs. */
static int prepare_visits(mprt_replay *r, const mprt_trace_ray *rays, const mprt_trace_visit *v, size_t nv,
                          const int64_t *process, const int64_t *receive, const int64_t *send)
{
    size_t j, nt = (size_t)r->ntrees;
    int64_t prev_t = -1, total = 0, maxdur = 0, *tc = NULL;
    const int64_t *cs = r->child_start;
    if (nv && (!process || !receive || !send)) return fail(r, MPRT_ERR_INVALID_ARG, "costs: missing array");
    if (RESERVE(r, vi, cap_vi, nv + 1) || RESERVE(r, tree_first, cap_tree, nt + 1) ||
        RESERVE(r, tree_cost, cap_tree9, 9 * nt + 1) || RESERVE(r, tree_pe, cap_tree_pe, nt + 1) ||
        RESERVE(r, tree_admit, cap_tree_admit, nt + 1))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %zu visits", nv);
    memset(r->tree_cost, 0, (9 * nt + 1) * sizeof *r->tree_cost);
    for (j = 0; j < nv; j++) {
        const mprt_trace_visit *a = &v[j];
        int64_t ray = a->ray, t, p = process[j], x = receive[j], y = send[j], c, next;
        int st = a->stage;
        if (ray < 0 || ray >= (int64_t)r->nr) return TRACE_FAIL(r, "a visit names a ray that does not exist");
        t = r->tree_of[ray];
        if (t != prev_t) {
            if (t != prev_t + 1)
                return TRACE_FAIL(r, "the visits of each primary ray's tree are not contiguous, in the primaries' "
                                     "order (traces made by mprt are)");
            if (rays[ray].kind != MPRT_RAY_PRIMARY) return TRACE_FAIL(r, "a tree's first visit is not its primary ray's");
            r->tree_first[t] = (int64_t)j;
            tc = r->tree_cost + 9 * t;
            prev_t = t;
        }
        if (j == 0 || a[-1].ray != ray) {
            if (r->ray_first[ray] >= 0)
                return TRACE_FAIL(r, "the visits of ray %lld are not contiguous", (long long)ray);
            r->ray_first[ray] = (int64_t)j;
        }
        if (st > MPRT_STAGE_SC) return TRACE_FAIL(r, "visit %zu: stage %d is not OS, IC or SC", j, st);
        if ((y > 0 && x > INT64_MAX - y) || (y < 0 && x < INT64_MIN - y))
            return fail(r, MPRT_ERR_INVALID_ARG, "visit %zu: receive + send cycles overflow", j);
        c = x + y;
        if (p < 0 || c < 0 || (c > 0 && p > INT64_MAX - c) || p + c < 1)
            return fail(r, MPRT_ERR_INVALID_ARG,
                        "visit %zu: costs must be >= 0 and a visit must last at least 1 cycle (process %lld, "
                        "communication %lld)", j, (long long)p, (long long)c);
        if (p + c > INT64_MAX / 2 - total)
            return fail(r, MPRT_ERR_INVALID_ARG, "costs: the visits' cycles add up to more than 2^62");
        total += p + c;
        if (j + 1 < nv && a[1].ray == ray) {
            next = NEXT_VISIT | (int64_t)(a[1].stage & 3) << 2;
        } else if (st == MPRT_STAGE_SC && a->made > 0) {
            int64_t k = cs[ray + 1] - cs[ray];
            if (k != a->made)
                return TRACE_FAIL(r, "visit %zu made %d rays but %lld have it as parent", j, a->made, (long long)k);
            next = NEXT_CHILDREN | (int64_t)a->made << 2 | cs[ray] << 10;
        } else {
            next = NEXT_RETIRE;
        }
        r->vi[j].dur = p + c;
        r->vi[j].next = next;
        if (p + c > maxdur) maxdur = p + c;
        tc[st] += p;
        tc[3 + st] += c;
        tc[6 + st]++;
    }
    if (prev_t != r->ntrees - 1) return TRACE_FAIL(r, "some primary rays have no visits");
    for (j = 0; j < r->nr; j++)
        if (r->ray_first[j] < 0) return TRACE_FAIL(r, "ray %zu has no visits", j);
    r->total = total;
    pack(r, maxdur);
    /* the rays made, as their first visits */
    for (j = 0; j < (size_t)cs[r->nr]; j++) r->child[j] = r->ray_first[r->child[j]];
    return MPRT_OK;
}

/* ---- running -------------------------------------------------------------------- */

static int build(mprt_replay *r)
{
    const mprt_replay_config *c = &r->cfg;
    int p, s, k, i = 0, n = 0;
    int per = 0;
    for (s = 0; s < c->nstages; s++) per += c->replicas[s];
    r->nproc = c->pes * per;
    r->nnode = c->pes * c->nstages;
    r->procs = calloc((size_t)r->nproc, sizeof *r->procs);
    r->nodes = calloc((size_t)r->nnode, sizeof *r->nodes);
    r->pes = calloc((size_t)c->pes, sizeof *r->pes);
    r->heap_t = malloc((size_t)r->nproc * sizeof *r->heap_t);
    r->heap_p = malloc((size_t)r->nproc * sizeof *r->heap_p);
    r->heap_i = malloc((size_t)r->nproc * sizeof *r->heap_i);
    if (!r->procs || !r->nodes || !r->pes || !r->heap_t || !r->heap_p || !r->heap_i)
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory");
    /* every event falls within the visits' cycles and the primaries' making */
    r->small = r->nproc <= SMALL_PROCS && r->total + c->gen_cycles * r->ntrees < (INT64_MAX >> SMALL_SHIFT) - 1;
    for (i = 0; r->small && i < r->nproc; i++) r->heap_t[i] = INT64_MAX;
    i = 0;
    for (p = 0; p < c->pes; p++) {
        pe_t *e = &r->pes[p];
        if (c->dis == MPRT_DIS_BLOCKS) {
            e->next = p * r->ntrees / c->pes;
            e->stop = (p + 1) * r->ntrees / c->pes;
            e->step = 1;
        } else {
            e->next = p;
            e->stop = r->ntrees;
            e->step = c->pes;
        }
        for (s = 0; s < c->nstages; s++, n++) {
            node *nd = &r->nodes[n];
            int words = (c->replicas[s] + 63) / 64;
            nd->rf.cap = c->receive_fifo[s];
            nd->sf.cap = c->send_fifo[s];
            nd->stage = s;
            nd->pe = p;
            nd->first = i;
            nd->n = c->replicas[s];
            nd->nidle = c->replicas[s];
            nd->idle = calloc((size_t)words, sizeof *nd->idle);
            if (!nd->idle) return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory");
            for (k = 0; k < c->replicas[s]; k++, i++) {
                proc *q = &r->procs[i];
                nd->idle[k / 64] |= (uint64_t)1 << (k % 64);
                q->node = n;
                q->k = k;
                q->pe = p;
                q->cur = -1;
                q->state = MPRT_PROC_IDLE;
            }
        }
    }
    return MPRT_OK;
}

int mprt_replay_load(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits,
                     size_t nvisits, const int64_t *process, const int64_t *receive, const int64_t *send)
{
    int rc;
    if (!r) return MPRT_ERR_INVALID_ARG;
    free_run(r);
    r->errmsg[0] = '\0';
    r->loaded = 0;
    r->ntrees = r->max_leaves = r->total = 0;
    if ((nrays && !rays) || (nvisits && !visits)) return fail(r, MPRT_ERR_INVALID_ARG, "rays or visits: missing");
    r->nv = nvisits;
    r->nr = nrays;
    rc = prepare_rays(r, rays, nrays);
    if (rc == MPRT_OK) rc = prepare_visits(r, rays, visits, nvisits, process, receive, send);
    free_ray_arrays(r);
    if (rc != MPRT_OK) return rc;
    r->loaded = 1;
    return MPRT_OK;
}

int mprt_replay_run(mprt_replay *r, int64_t *log, size_t log_cap)
{
    int rc, p, k;
    int64_t t, g;
    if (!r) return MPRT_ERR_INVALID_ARG;
    free_run(r);
    r->errmsg[0] = '\0';
    if (!r->loaded) return fail(r, MPRT_ERR_STATE, "no trace loaded (mprt_replay_load)");
    g = r->cfg.gen_cycles;
    if (r->cfg.pes > r->ntrees)
        return fail(r, MPRT_ERR_INVALID_ARG, "pes: %d PEs but the trace has only %lld primary rays (one per pixel "
                    "sample)", r->cfg.pes, (long long)r->ntrees);
    if (g > 0 && r->ntrees > (INT64_MAX / 2 - r->total) / g)
        return fail(r, MPRT_ERR_INVALID_ARG, "gen_cycles: with the visits' cycles, more than 2^62 cycles in all");
    if (log && log_cap < 8 * (r->nv + (size_t)r->ntrees))
        return fail(r, MPRT_ERR_INVALID_ARG, "log: room for %zu entries needed, %zu given",
                    8 * (r->nv + (size_t)r->ntrees), log_cap);
    r->now = r->retired = r->t_end = r->shared_next = 0;
    r->nlog = 0;
    r->oom = r->deadlocked = 0;
    rc = build(r);
    if (rc != MPRT_OK) {
        free_run(r);
        return rc;
    }
    r->busy_recorded = r->record_busy;
    if (r->record_busy) {
        size_t nb = (size_t)r->ntrees * (size_t)r->cfg.nstages;
        if (RESERVE(r, tree_busy, cap_tree_busy, nb + 1)) {
            free_run(r);
            return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the busy record");
        }
        for (t = 0; t < (int64_t)nb; t++) r->tree_busy[t] = -1;
    }
    for (t = 0; t < r->ntrees; t++) {
        r->tree_pe[t] = -1;
        r->tree_admit[t] = -1;
    }
    r->log = log;
    r->ran = 1;
    for (p = 0; p < r->cfg.pes && !r->oom; p++) dis_admit(r, p);
    while (r->nheap && !r->oom) {
        int i = heap_pop(r, &r->now);
        handle(r, i);
    }
    r->log = NULL;
    if (r->oom) {
        free_run(r);
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory during the replay");
    }
    for (t = 0; t < r->ntrees; t++)
        if (r->tree_pe[t] >= 0)
            for (k = 0; k < 9; k++) r->pes[r->tree_pe[t]].cost[k] += r->tree_cost[9 * t + k];
    if (r->retired != (int64_t)r->nr) {
        r->deadlocked = 1;
        return fail(r, MPRT_ERR_STATE, "deadlock: the machine stopped with %lld of %zu rays still in it",
                    (long long)((int64_t)r->nr - r->retired), r->nr);
    }
    return MPRT_OK;
}

/* ---- results ---------------------------------------------------------------------- */

static int need_run(const mprt_replay *r, const void *out, size_t cap, size_t n)
{
    if (!r || !r->ran) return MPRT_ERR_STATE;
    if (!out && n) return MPRT_ERR_INVALID_ARG;
    if (cap < n) return MPRT_ERR_CAPACITY;
    return MPRT_OK;
}

int mprt_replay_get_info(const mprt_replay *r, mprt_replay_info *info)
{
    if (!r || !info) return MPRT_ERR_INVALID_ARG;
    if (!r->loaded) return MPRT_ERR_STATE;
    memset(info, 0, sizeof *info);
    info->cycles = r->ran && !r->deadlocked ? r->t_end : -1;
    info->deadlocked = r->deadlocked;
    info->rays = (int64_t)r->nr;
    info->visits = (int64_t)r->nv;
    info->trees = r->ntrees;
    info->retired = r->retired;
    info->max_leaves = r->max_leaves;
    info->events = (int64_t)r->nlog;
    info->processors = r->nproc;
    info->nodes = r->nnode;
    info->pes = r->ran ? r->cfg.pes : 0;
    return MPRT_OK;
}

int mprt_replay_get_procs(const mprt_replay *r, mprt_replay_proc *out, size_t cap)
{
    int rc = need_run(r, out, cap, r ? (size_t)r->nproc : 0), i;
    if (rc != MPRT_OK) return rc;
    for (i = 0; i < r->nproc; i++) {
        const proc *p = &r->procs[i];
        mprt_replay_proc *o = &out[i];
        o->busy = p->busy;
        o->blocked = p->blocked;
        o->visits = p->visits;
        o->state = p->state;
        o->visit = (p->state == MPRT_PROC_BUSY || p->state == MPRT_PROC_BLOCKED) ? p->cur : -1;
        o->pending = p->state != MPRT_PROC_BLOCKED ? 0 : p->single ? 1 : p->pb - p->pa;
    }
    return MPRT_OK;
}

int mprt_replay_get_nodes(const mprt_replay *r, mprt_replay_node *out, size_t cap)
{
    int rc = need_run(r, out, cap, r ? (size_t)r->nnode : 0), n;
    if (rc != MPRT_OK) return rc;
    for (n = 0; n < r->nnode; n++) {
        const node *nd = &r->nodes[n];
        mprt_replay_node *o = &out[n];
        int64_t end = r->t_end;
        o->receive_occupancy = (int64_t)nd->rf.q.len;
        o->receive_max = nd->rf.max;
        o->receive_puts = nd->rf.puts;
        o->receive_area = f_area(&nd->rf, end);
        o->send_occupancy = (int64_t)nd->sf.q.len;
        o->send_max = nd->sf.max;
        o->send_puts = nd->sf.puts;
        o->send_area = f_area(&nd->sf, end);
        o->local_queue = (int64_t)nd->local.len;
        o->generated = nd->generated;
    }
    return MPRT_OK;
}

int mprt_replay_get_pes(const mprt_replay *r, mprt_replay_pe *out, size_t cap)
{
    int rc = need_run(r, out, cap, r ? (size_t)r->cfg.pes : 0), p, s;
    if (rc != MPRT_OK) return rc;
    for (p = 0; p < r->cfg.pes; p++) {
        const pe_t *e = &r->pes[p];
        mprt_replay_pe *o = &out[p];
        o->admitted = e->admitted;
        o->retired = e->retired;
        o->end = e->end;
        o->live = e->live;
        o->max_live = e->max_live;
        o->dis_holding = e->holding;
        for (s = 0; s < 3; s++) {
            o->processing[s] = e->cost[s];
            o->communication[s] = e->cost[3 + s];
            o->visits[s] = e->cost[6 + s];
        }
    }
    return MPRT_OK;
}

int mprt_replay_get_trees(const mprt_replay *r, int32_t *pe, int64_t *admitted, size_t cap)
{
    int rc = need_run(r, pe ? (const void *)pe : (const void *)admitted, cap, r ? (size_t)r->ntrees : 0);
    if (rc != MPRT_OK) return rc;
    if (pe && r->ntrees) memcpy(pe, r->tree_pe, (size_t)r->ntrees * sizeof *pe);
    if (admitted && r->ntrees) memcpy(admitted, r->tree_admit, (size_t)r->ntrees * sizeof *admitted);
    return MPRT_OK;
}

int mprt_replay_record_busy(mprt_replay *r, int on)
{
    if (!r) return MPRT_ERR_INVALID_ARG;
    r->record_busy = on != 0;
    return MPRT_OK;
}

int mprt_replay_get_tree_busy(const mprt_replay *r, int64_t *out, size_t cap)
{
    size_t n = r ? (size_t)r->ntrees * (size_t)r->cfg.nstages : 0;
    int rc = need_run(r, out, cap, n);
    if (rc != MPRT_OK) return rc;
    if (!r->busy_recorded || !r->tree_busy) {
        size_t i;
        for (i = 0; i < n; i++) out[i] = -1;
    } else if (n) {
        memcpy(out, r->tree_busy, n * sizeof *out);
    }
    return MPRT_OK;
}

int mprt_replay_get_waiters(const mprt_replay *r, int pe, int stage, int which, int64_t *out, size_t cap,
                            size_t *n)
{
    const queue *q;
    size_t i;
    if (!r || !r->ran) return MPRT_ERR_STATE;
    if (pe < 0 || pe >= r->cfg.pes || stage < 0 || stage >= r->cfg.nstages || (which != 0 && which != 1) || !n)
        return MPRT_ERR_INVALID_ARG;
    q = which == 0 ? &r->nodes[pe * r->cfg.nstages + stage].rwait : &r->nodes[pe * r->cfg.nstages + stage].swait;
    *n = q->len;
    if (cap < q->len) return MPRT_ERR_CAPACITY;
    if (q->len && !out) return MPRT_ERR_INVALID_ARG;
    for (i = 0; i < q->len; i++) out[i] = q->buf[(q->head + i) & (q->cap - 1)];
    return MPRT_OK;
}
