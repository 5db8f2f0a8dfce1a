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
 * - A stage fed per replica (round-robin or shortest queue) gives each
 *   replica its own receive FIFO and local queue; a packet entering the
 *   stage is assigned one (assign()), and "room" is that replica's.
 * - DIS admits its PE's trees while fewer than `window` rays are live; a
 *   tree's primary goes to SC (which spends gen_cycles making it) or
 *   straight to OS; when there is no room it waits for a slot.
 *
 * Costs are the caller's (process, receive, send per visit).  Nothing
 * recurses and every loop either makes progress or ends, so a run ends; if
 * it ends with rays still in the machine, that is a deadlock. */
#include "replay.h"

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

/* Visit x's record, and its memory key at level 3, fetched ahead of its start. */
INLINE void prefetch_visit(const mprt_replay *r, int64_t x)
{
    PREFETCH(v_addr(r, x));
    if (r->mem_key) PREFETCH(&r->mem_key[x]);
    if (r->cfg.ring) PREFETCH(&r->pflits[x]);      /* its packet's size, read when it is injected */
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
        vinfo v = r->wide ? r->vi[j] : unpack_visit(r->vp[j]);
        d = v.dur;
        p->next = v.next;
        PREFETCH(v_addr(r, j + 4));
        if (r->mem_on && r->mem_key[j] != -1) {      /* level 3: the data it reads (replay_memory.c) */
            int64_t s = mprt__replay_stall(r, i, j);
            d += s;
            p->stall += s;
        }
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

/* ---- a per-replica feed (round-robin, shortest queue) ---- */

/* The replica the next packet for nd goes to, -1: none has room (an idle
 * replica or a free slot; need_room 0: any replica).  Round-robin: turn mod
 * replicas; shortest queue: the fewest queued, ties to the lowest.  take: the
 * assignment is made (the turn advances). */
static NOINLINE int assign(mprt_replay *r, node *nd, int take, int need_room)
{
    int k, best = -1;
    int64_t low = 0;
    if (nd->feed == 1) {
        k = (int)(nd->turn % nd->n);
        if (need_room && !copy_idle(r, nd, k) && !f_room(&nd->rfs[k])) return -1;
        if (take) nd->turn++;
        return k;
    }
    for (k = 0; k < nd->n; k++) {
        if (need_room && !copy_idle(r, nd, k) && !f_room(&nd->rfs[k])) continue;
        if (best < 0 || queued(r, nd, k) < low) {
            best = k;
            low = queued(r, nd, k);
        }
    }
    return best;
}

/* Packet x assigned to replica k of nd: started now if k is idle, else to the tail of
 * its local queue (local) or receive FIFO.  Kept out of line (as the other per-replica
 * paths): the shared feed's paths stay as small as they were. */
static NOINLINE void give_copy(mprt_replay *r, node *nd, int k, int64_t x, int local)
{
    if (copy_idle(r, nd, k))
        start(r, take_copy(nd, k), x);
    else if (local)
        q_push(r, &nd->locals[k], x);
    else
        f_put(r, &nd->rfs[k], x);
}

/* Room to enter nd: an idle replica or a free receive slot (per replica: for the one assigned). */
INLINE int node_room(mprt_replay *r, node *nd)
{
    if (nd->feed) return assign(r, nd, 0, 1) >= 0;
    return nd->nidle || f_room(&nd->rf);
}

/* A packet enters nd (there is room): its lowest idle processor, else its receive
 * FIFO; per replica: the replica assigned, idle or not. */
INLINE void accept(mprt_replay *r, node *nd, int64_t x)
{
    if (x >= 0) prefetch_visit(r, x);
    if (nd->feed)
        give_copy(r, nd, assign(r, nd, 1, 1), x, 0);
    else if (nd->nidle)
        start(r, take_idle(nd), x);
    else
        f_put(r, &nd->rf, x);
}

/* Packet x from src to stage g over the network (the ring's, or the ideal one
 * below); 0: src's send FIFO is full. */
INLINE int net_send(mprt_replay *r, node *src, int64_t x, int g)
{
    node *dst = sibling(src, g);
    prefetch_visit(r, x);
    if (r->cfg.ring) return mprt__ring_send(r, src, x, g);
    if (src->sf.q.len == 0) {
        if (dst->feed) {
            if (node_room(r, dst)) {
                accept(r, dst, x);
                return 1;
            }
        } else if (dst->nidle) {
            start(r, take_idle(dst), x);
            return 1;
        } else if (f_room(&dst->rf)) {
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
        prefetch_visit(r, x);
        if (src->feed)
            give_copy(r, src, assign(r, src, 1, 0), x, 1);
        else if (src->nidle)
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
        if (dst->feed) {
            if (!node_room(r, dst)) {
                q_push(r, &dst->rwait, src->stage);
                return;
            }
            f_get(r, &src->sf);
            accept(r, dst, x);
        } else if (dst->nidle) {
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
    if (r->mem_key) {            /* and their memory keys */
        int64_t j = r->tree_first[t], e = t + 1 < r->ntrees ? r->tree_first[t + 1] : (int64_t)r->nv;
        if (e - j > TREE_PREFETCH / 4) e = j + TREE_PREFETCH / 4;
        for (; j < e; j += 16) PREFETCH(&r->mem_key[j]);
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
        if (r->record_busy) mprt__replay_note_busy(r, t);
        e->live++;
        if (e->live > e->max_live) e->max_live = e->live;
        e->admitted++;
        if (node_room(r, dst)) {
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
    while (dst->rwait.len && (dst->feed ? node_room(r, dst) : f_room(&dst->rf))) {
        int64_t w = q_pop(&dst->rwait);
        if (w == DIS_WAITER)
            dis_release(r, dst->pe);
        else
            advance(r, sibling(dst, (int)w));
    }
    if (r->cfg.ring) ring_freed(r, dst->pe);     /* then the ring's headers may claim it */
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

/* Replica p (processor i) of a stage fed per replica takes its next packet: its local
 * queue's head, else its receive FIFO's (a slot freed), else it is idle. */
static NOINLINE void take_next_copy(mprt_replay *r, int i, proc *p, node *nd)
{
    int k = p->k;
    if (nd->locals[k].len) {
        start(r, i, q_pop(&nd->locals[k]));
    } else if (nd->rfs[k].q.len) {
        start(r, i, f_get(r, &nd->rfs[k]));
        freed(r, nd);
    } else {
        p->state = MPRT_PROC_IDLE;
        nd->idle[k / 64] |= (uint64_t)1 << (k % 64);
        nd->nidle++;
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
    if (nd->local.len) {         /* (fed per replica: local and rf stay empty) */
        start(r, i, q_pop(&nd->local));
    } else if (nd->rf.q.len) {
        start(r, i, f_get(r, &nd->rf));
        freed(r, nd);
    } else if (nd->feed) {
        take_next_copy(r, i, p, nd);
    } else {
        p->state = MPRT_PROC_IDLE;
        nd->idle[p->k / 64] |= (uint64_t)1 << (p->k % 64);
        nd->nidle++;
    }
}

/* ---- the run's events, and the ring's hooks --------------------------------------- */

void mprt__replay_loop(mprt_replay *r)
{
    int p;
    for (p = 0; p < r->cfg.pes && !r->oom; p++) dis_admit(r, p);
    if (!r->cfg.ring) {
        while (r->nheap && !r->oom) {
            int i = heap_pop(r, &r->now);
            handle(r, i);
        }
        return;
    }
    while (!r->oom) {    /* the first processor event, unless a ring event comes before it */
        int64_t t = INT64_MAX;
        int i = -1;
        if (r->nheap) {
            if (r->small) {
                if (r->pmin < 0) r->pmin = small_first(r);
                i = r->pmin;
                t = r->heap_t[i] >> SMALL_SHIFT;
            } else {
                i = 0;
                t = r->heap_t[0];
            }
        }
        if (r->rq_len && r->rq_t[r->rq_head] < t) {
            r->now = r->rq_t[r->rq_head];
            mprt__ring_event(r);
        } else if (i >= 0) {
            if (r->small) {
                r->heap_t[i] = INT64_MAX;
                r->nheap--;
                r->pmin = -1;
                r->now = t;
            } else {
                i = heap_pop(r, &r->now);
            }
            handle(r, i);
        } else {
            break;
        }
    }
}

void mprt__replay_start_on(mprt_replay *r, node *nd, int k, int64_t x)
{
    start(r, k < 0 ? take_idle(nd) : take_copy(nd, k), x);
}

void mprt__replay_send_freed(mprt_replay *r, node *src) { send_freed(r, src); }

