/* replay_ring.c: the ring of level 2 in the compiled replay (see replay.c).
 *
 * The SimPy model's Ring (python/mprt/machine/ring.py; README.md there, "The
 * ring (level 2)") step for step, so that the two agree to the cycle:
 *
 * - Node n of a PE's ring is its stage n; link n goes from node n to node
 *   n + 1 and carries a flit per flit_time.  Each node has buffer_classes
 *   one-header buffers.
 * - Injection: the head of a send FIFO enters the network when its node's
 *   class-0 buffer is free, and stays in the send FIFO until its tail has
 *   left (one packet in the network per node: kept by its source node).
 * - Hop: a header at node n moves on when link n is free and node n + 1's
 *   buffer of class min(hops + 1, classes - 1) is free, holding the link a
 *   flit time (an event).
 * - Delivery: at its destination the header claims the receive FIFO (room,
 *   and no other packet writing it), reserving a slot; then the other
 *   flits - 1 flits stream over the whole path when all its links are free
 *   (an event), and the packet goes to an idle processor or fills its slot;
 *   its buffers, the write access and the send FIFO slot are released.
 * - The arbiter (kick) grants requests first come first served: injections
 *   node by node, then the waiting packets in the order they began to wait,
 *   pass after pass while a packet completed during one.
 * - Ring events run after the processors' events of the same cycle, among
 *   themselves in the order they were scheduled (SimPy's priority
 *   2 x processors + 1 and its event ids): a list in time order beside the
 *   processors' events (replay.c's loop takes the first of the two).
 *
 * Nothing is allocated per packet or per event. */
#include "replay.h"


int mprt__ring_build(mprt_replay *r)
{
    int p, n, c;
    size_t cap = 4;
    while (cap < (size_t)r->cfg.pes * RING_MAX) cap *= 2;
    r->rings = calloc((size_t)r->cfg.pes, sizeof *r->rings);
    r->rq_t = malloc(cap * sizeof *r->rq_t);
    r->rq_s = malloc(cap * sizeof *r->rq_s);
    if (!r->rings || !r->rq_t || !r->rq_s) return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory");
    r->rq_head = r->rq_len = 0;
    r->rq_mask = cap - 1;
    for (p = 0; p < r->cfg.pes; p++) {
        ring_t *R = &r->rings[p];
        R->id = p;
        R->K = r->cfg.nstages;
        R->C = r->cfg.buffer_classes;
        R->nd = &r->nodes[p * r->cfg.nstages];
        for (n = 0; n < RING_MAX; n++) {
            R->writer[n] = -1;
            R->nxt[n] = n + 1 >= R->K ? 0 : n + 1;
            for (c = 0; c < RING_MAX; c++) R->buf[n * RING_MAX + c] = -1;
        }
        for (n = 0; n <= RING_MAX; n++) R->cls[n] = n < R->C - 1 ? n : R->C - 1;
    }
    return MPRT_OK;
}

/* Packet q of ring R has an event delay (> 0) cycles from now: after the pending
 * ones of its time or before, so the list stays in time order, simultaneous events in
 * the order they were scheduled (one per packet: the list never overflows). */
INLINE void ring_at(mprt_replay *r, ring_t *R, int q, int64_t delay, int what)
{
    int64_t t = r->now + delay, *rt = r->rq_t;
    int32_t *rs = r->rq_s;
    size_t m = r->rq_mask, h = r->rq_head, i = r->rq_len++;
    R->pkt[q].event = what;
    for (; i > 0 && rt[(h + i - 1) & m] > t; i--) {
        rt[(h + i) & m] = rt[(h + i - 1) & m];
        rs[(h + i) & m] = rs[(h + i - 1) & m];
    }
    rt[(h + i) & m] = t;
    rs[(h + i) & m] = R->id * 4 + q;
}

/* The replica of nd (fed per replica) a header claims a receive slot of, now
 * assigned (-1: none can be): round-robin's next, which must have a free
 * slot; shortest queue: the fewest queued among those with a free slot. */
static int claim_copy(mprt_replay *r, node *nd)
{
    int k, best = -1;
    int64_t low = 0;
    if (nd->feed == 1) {
        k = (int)(nd->turn % nd->n);
        if (!f_room(&nd->rfs[k])) return -1;
        nd->turn++;
        return k;
    }
    for (k = 0; k < nd->n; k++) {
        if (!f_room(&nd->rfs[k])) continue;
        if (best < 0 || queued(r, nd, k) < low) {
            best = k;
            low = queued(r, nd, k);
        }
    }
    return best;
}

/* Packet q is in its receive FIFO (or on an idle processor): its buffers, the
 * FIFO's write access and its send FIFO slot are released. */
static void complete(mprt_replay *r, int pe, int q)
{
    ring_t *R = &r->rings[pe];
    ring_packet *k = &R->pkt[q];
    node *d = &R->nd[k->dst], *s = &R->nd[k->src];
    int i;
    for (i = 0; i <= k->hops; i++) R->buf[k->held[i]] = -1;
    R->writer[k->dst] = -1;
    if (d->feed) {
        if (copy_idle(r, d, k->copy)) {
            f_unreserve(r, &d->rfs[k->copy]);
            mprt__replay_start_on(r, d, k->copy, k->x);
        } else {
            f_fill(r, &d->rfs[k->copy], k->x);
        }
    } else if (d->nidle) {
        f_unreserve(r, &d->rf);
        mprt__replay_start_on(r, d, -1, k->x);
    } else {
        f_fill(r, &d->rf, k->x);
    }
    f_get(r, &s->sf);
    R->injected[k->src] = 0;
    if (s->sf.q.len) R->ready |= 1u << k->src;
    if (s->swait.len) mprt__replay_send_freed(r, s);   /* (may inject the node's next packet: k is
                                                          * not read after) */
    mprt__ring_kick(r, pe);
}

/* Node n's send FIFO head enters the network (its class-0 buffer is free). */
INLINE void inject(mprt_replay *r, ring_t *R, int n)
{
    const queue *sf = &R->nd[n].sf.q;
    int64_t e = sf->buf[sf->head];
    ring_packet *k = &R->pkt[n];
    k->x = e >> 2;
    k->dst = (int)(e & 3);
    k->src = k->node = n;
    k->hops = 0;
    k->path = 0;
    k->phase = RING_HOP;
    k->copy = -1;
    k->event = RING_NONE;
    k->flits = r->pflits[k->x];
    R->buf[n * RING_MAX] = n;
    k->held[0] = n * RING_MAX;
    R->injected[n] = 1;
    R->ready &= ~(1u << n);
}

/* Packet q's delivery, at its destination: its claim of the receive FIFO, then its
 * body over the whole path; 1 when granted. */
static NOINLINE int deliver(mprt_replay *r, ring_t *R, int q)
{
    ring_packet *k = &R->pkt[q];
    int64_t ft = r->cfg.flit_time, body;
    if (k->phase == RING_CLAIM) {
        node *d = &R->nd[k->dst];
        if (R->writer[k->dst] >= 0) return 0;
        if (d->feed) {
            int c = claim_copy(r, d);
            if (c < 0) return 0;
            k->copy = c;
            R->writer[k->dst] = q;
            f_reserve(r, &d->rfs[c]);
        } else {
            if (!f_room(&d->rf)) return 0;
            R->writer[k->dst] = q;
            f_reserve(r, &d->rf);
        }
        k->phase = RING_BODY;
        R->claiming--;
    }
    /* the body: the rest of the packet over the whole path */
    body = k->flits - 1;
    if (body <= 0) {
        complete(r, R->id, q);
        return 1;
    }
    if (R->busy & k->path) return 0;
    R->busy |= k->path;
    {
        unsigned m;
        for (m = k->path; m; m &= m - 1) R->link_cycles[ctz64(m)] += body * ft;
    }
    ring_at(r, R, q, body * ft, RING_BODY_DONE);
    return 1;
}

/* Try packet q's next step (a hop here, else its delivery); 1 when it was granted. */
INLINE int step(mprt_replay *r, ring_t *R, int q)
{
    ring_packet *k = &R->pkt[q];
    if (k->phase == RING_HOP) {
        int64_t ft = r->cfg.flit_time;
        int n = k->node, b = R->nxt[n] * RING_MAX + R->cls[k->hops + 1];
        if ((R->busy >> n & 1) || R->buf[b] >= 0) return 0;
        R->busy |= 1u << n;
        R->link_cycles[n] += ft;
        R->buf[b] = q;
        k->held[k->hops + 1] = b;
        ring_at(r, R, q, ft, RING_ARRIVE);
        return 1;
    }
    return deliver(r, R, q);
}

/* An arbitration (kick) of a ring where no packet waits, outside an arbitration, when
 * packet q's step is all it can grant: when no other ready node can inject (its class-0
 * buffer is taken) and q's step completes no packet (a hop; a claim with a body to
 * stream), the kick's pass would step q alone and end (a grant only takes resources;
 * only a completion releases any, and asks for another pass).  So q steps here, and
 * waits if refused: the same grants in the same order, without the kick's set-up.
 * fast_ok: those conditions for a step that completes nothing, q's node's own ready
 * bit aside (self: it injects q). */
INLINE int fast_ok(const ring_t *R, unsigned self)
{
    unsigned m;
    if (R->nwaiting || R->kicking) return 0;
    for (m = R->ready & ~self; m; m &= m - 1)
        if (R->buf[ctz64(m) * RING_MAX] < 0) return 0;
    return 1;
}

INLINE void step_or_wait(mprt_replay *r, ring_t *R, int q)
{
    if (!step(r, R, q)) R->waiting[R->nwaiting++] = q;
}

int mprt__ring_send(mprt_replay *r, node *src, int64_t x, int g)
{
    ring_t *R = &r->rings[src->pe];
    int n = src->stage;
    if (!f_room(&src->sf)) return 0;
    f_put(r, &src->sf, x * 4 + g);
    if (R->injected[n]) return 1;       /* it waits its turn */
    R->ready |= 1u << n;
    if (R->buf[n * RING_MAX] >= 0) return 1;
    if (fast_ok(R, 1u << n)) {          /* (a packet's first step is a hop: it completes nothing) */
        inject(r, R, n);
        step_or_wait(r, R, n);
    } else {
        mprt__ring_kick(r, src->pe);
    }
    return 1;
}

void mprt__ring_kick(mprt_replay *r, int pe)
{
    ring_t *R = &r->rings[pe];
    int n, i, cnt, keep;
    if (R->kicking) {
        R->again = 1;
        return;
    }
    R->kicking = 1;
    do {
        unsigned m;
        R->again = 0;
        for (m = R->ready; m; m &= m - 1) {         /* node by node */
            n = ctz64(m);
            if (R->buf[n * RING_MAX] < 0) {
                inject(r, R, n);
                R->waiting[R->nwaiting++] = n;
            }
        }
        /* the waiting packets in order; those not granted keep their places */
        cnt = R->nwaiting;
        for (i = keep = 0; i < cnt; i++) {
            int q = R->waiting[i];
            if (!step(r, R, q)) R->waiting[keep++] = q;
        }
        R->nwaiting = keep;
    } while (R->again);
    R->kicking = 0;
}

void mprt__ring_event(mprt_replay *r)
{
    int slot = r->rq_s[r->rq_head], pe = slot >> 2, q = slot & 3;
    ring_t *R = &r->rings[pe];
    ring_packet *k = &R->pkt[q];
    r->rq_head = (r->rq_head + 1) & r->rq_mask;
    r->rq_len--;
    if (k->event == RING_ARRIVE) {          /* the header crossed link n */
        int n = k->node;
        R->busy &= ~(1u << n);
        k->path |= 1u << n;
        k->node = R->nxt[n];
        k->hops++;
        k->phase = k->node == k->dst ? RING_CLAIM : RING_HOP;
        R->claiming += k->phase == RING_CLAIM;
        k->event = RING_NONE;
        if ((k->phase == RING_HOP || k->flits > 1) && fast_ok(R, 0)) {
            step_or_wait(r, R, q);
        } else {
            R->waiting[R->nwaiting++] = q;
            mprt__ring_kick(r, pe);
        }
    } else {                                /* the body has streamed: the path is free */
        R->busy &= ~k->path;
        k->event = RING_NONE;
        complete(r, pe, q);                 /* and its arbitration (the model's second one then
                                             * grants nothing: a pass only takes resources) */
    }
}

/* ---- packet sizes and the ring's figures ---------------------------------------------- */

#define MAX_FLITS 65535

int mprt_replay_set_flits(mprt_replay *r, const int64_t *flits, size_t nvisits, const int64_t *kid_flits,
                          size_t nkinds, int64_t inject_flits)
{
    size_t j, c;
    int64_t most = inject_flits;
    if (!r) return MPRT_ERR_INVALID_ARG;
    r->errmsg[0] = '\0';
    r->flits_set = 0;
    if (!r->loaded) return fail(r, MPRT_ERR_STATE, "no trace loaded (mprt_replay_load)");
    if (nvisits != r->nv) return fail(r, MPRT_ERR_INVALID_ARG, "flits: %zu entries for %zu visits", nvisits, r->nv);
    if ((nvisits && !flits) || !kid_flits) return fail(r, MPRT_ERR_INVALID_ARG, "flits: missing array");
    if (nkinds != MPRT_RAY_SHADOW + 1)
        return fail(r, MPRT_ERR_INVALID_ARG, "kid_flits: %zu entries, one per ray kind (%d) needed", nkinds,
                    MPRT_RAY_SHADOW + 1);
    if (inject_flits < 0 || inject_flits > MAX_FLITS)
        return fail(r, MPRT_ERR_INVALID_ARG, "inject_flits: must be 0..%d, not %lld", MAX_FLITS,
                    (long long)inject_flits);
    for (c = 0; c < nkinds; c++) {
        if (kid_flits[c] < 0 || kid_flits[c] > MAX_FLITS)
            return fail(r, MPRT_ERR_INVALID_ARG, "kid_flits[%zu]: must be 0..%d, not %lld", c, MAX_FLITS,
                        (long long)kid_flits[c]);
        most = kid_flits[c] > most ? kid_flits[c] : most;
    }
    for (j = 0; j < nvisits; j++) {
        if (flits[j] < 0 || flits[j] > MAX_FLITS)
            return fail(r, MPRT_ERR_INVALID_ARG, "flits[%zu]: visit %zu's packet must be 0..%d flits, not %lld", j, j,
                        MAX_FLITS, (long long)flits[j]);
        most = flits[j] > most ? flits[j] : most;
    }
    if (RESERVE(r, pflits, cap_pflits, r->nv + 1)) return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for flits");
    /* a visit's packet is sent by the ray's visit before it; a ray's first by SC */
    for (j = 1; j < r->nv; j++) r->pflits[j] = (uint16_t)flits[j - 1];
    for (j = 0; j < (size_t)r->ntrees; j++) r->pflits[r->tree_first[j]] = (uint16_t)inject_flits;
    for (c = 0; c < r->nchild; c++) r->pflits[r->child[c]] = (uint16_t)kid_flits[r->child_kind[c]];
    r->max_flits = most;
    r->flits_set = 1;
    r->cx_ok = 0;               /* (the work bound's chains were for the sizes before) */
    return MPRT_OK;
}

int mprt_replay_get_links(const mprt_replay *r, int64_t *out, size_t cap)
{
    int p, n;
    if (!r || !r->ran || !r->cfg.ring) return MPRT_ERR_STATE;
    if (cap < (size_t)r->cfg.pes * (size_t)r->cfg.nstages) return MPRT_ERR_CAPACITY;
    if (!out) return MPRT_ERR_INVALID_ARG;
    for (p = 0; p < r->cfg.pes; p++)
        for (n = 0; n < r->cfg.nstages; n++) out[p * r->cfg.nstages + n] = r->rings[p].link_cycles[n];
    return MPRT_OK;
}

int mprt_replay_get_ring(const mprt_replay *r, int pe, int64_t *buffers, size_t cap_buffers, int64_t *waiting,
                         size_t cap_waiting, size_t *nwaiting)
{
    const ring_t *R;
    int n, c, i;
    if (!r || !r->ran || !r->cfg.ring) return MPRT_ERR_STATE;
    if (pe < 0 || pe >= r->cfg.pes || !nwaiting) return MPRT_ERR_INVALID_ARG;
    R = &r->rings[pe];
    *nwaiting = (size_t)R->nwaiting;
    if (cap_buffers < (size_t)(R->K * R->C) || cap_waiting < 4 * (size_t)R->nwaiting) return MPRT_ERR_CAPACITY;
    if (!buffers || (R->nwaiting && !waiting)) return MPRT_ERR_INVALID_ARG;
    for (n = 0; n < R->K; n++)
        for (c = 0; c < R->C; c++) {
            int q = R->buf[n * RING_MAX + c];
            buffers[n * R->C + c] = q < 0 ? -1 : R->pkt[q].src * 4 + R->pkt[q].dst;
        }
    for (i = 0; i < R->nwaiting; i++) {
        const ring_packet *k = &R->pkt[R->waiting[i]];
        waiting[4 * i] = k->src;
        waiting[4 * i + 1] = k->dst;
        waiting[4 * i + 2] = k->node;
        waiting[4 * i + 3] = k->phase;
    }
    return MPRT_OK;
}
