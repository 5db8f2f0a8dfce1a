/* replay_run.c: making the machine for a run, running it, and taking it down
 * (the machine's rules and its events are replay.c's, the ring's replay_ring.c's). */
#include "replay.h"

void mprt__replay_free_run(mprt_replay *r)
{
    int n, k;
    for (n = 0; r->nodes && n < r->nnode; n++) {
        node *nd = &r->nodes[n];
        q_free(&nd->rf.q);
        q_free(&nd->sf.q);
        q_free(&nd->local);
        q_free(&nd->rwait);
        q_free(&nd->swait);
        for (k = 0; nd->rfs && k < nd->n; k++) q_free(&nd->rfs[k].q);
        for (k = 0; nd->locals && k < nd->n; k++) q_free(&nd->locals[k]);
        free(nd->rfs);
        free(nd->locals);
        free(nd->idle);
    }
    mprt__replay_memory_free_run(r);
    free(r->nodes);
    free(r->procs);
    free(r->pes);
    free(r->heap_t);
    free(r->heap_p);
    free(r->heap_i);
    free(r->rings);
    free(r->rq_t);
    free(r->rq_s);
    r->rings = NULL;
    r->rq_t = NULL;
    r->rq_s = NULL;
    r->rq_len = r->rq_head = r->rq_mask = 0;
    r->nodes = NULL;
    r->procs = NULL;
    r->pes = NULL;
    r->heap_t = r->heap_p = NULL;
    r->heap_i = NULL;
    r->nnode = r->nproc = r->nheap = 0;
    r->ran = 0;
}

/* ---- running -------------------------------------------------------------------- */

/* Each stage's busy cycles by now, at tree t's admission. */
void mprt__replay_note_busy(mprt_replay *r, int64_t t)
{
    int64_t *b = r->tree_busy + t * r->cfg.nstages;
    int i;
    memset(b, 0, (size_t)r->cfg.nstages * sizeof *b);
    for (i = 0; i < r->nproc; i++) {
        const proc *p = &r->procs[i];
        b[r->nodes[p->node].stage] += p->busy - (p->until > r->now ? p->until - r->now : 0);
    }
}


/* The trees a static DIS deals PE p: first, first + step, ... before stop (blocks: a
 * contiguous share; interleaved: every pes-th).  The dynamic DIS draws from one shared
 * sequence instead (its per-PE fields go unused). */
static void deal(const mprt_replay *r, int p, int64_t *first, int64_t *stop, int64_t *step)
{
    const mprt_replay_config *c = &r->cfg;
    if (c->dis == MPRT_DIS_BLOCKS) {
        *first = p * r->ntrees / c->pes;
        *stop = (p + 1) * r->ntrees / c->pes;
        *step = 1;
    } else {
        *first = p;
        *stop = r->ntrees;
        *step = c->pes;
    }
}

static int build(mprt_replay *r)
{
    const mprt_replay_config *c = &r->cfg;
    int p, s, k, i = 0, n = 0;
    int per = 0;
    int64_t last;
    for (s = 0; s < c->nstages; s++) per += c->replicas[s];
    r->nproc = c->pes * per;
    r->nnode = c->pes * c->nstages;
    r->procs = calloc((size_t)r->nproc, sizeof *r->procs);
    r->nodes = calloc((size_t)r->nnode, sizeof *r->nodes);
    r->pes = calloc((size_t)c->pes, sizeof *r->pes);
    r->heap_t = malloc((size_t)(r->nproc > SMALL_PROCS ? r->nproc : SMALL_PROCS) * sizeof *r->heap_t);
    r->heap_p = malloc((size_t)r->nproc * sizeof *r->heap_p);
    r->heap_i = malloc((size_t)r->nproc * sizeof *r->heap_i);
    if (!r->procs || !r->nodes || !r->pes || !r->heap_t || !r->heap_p || !r->heap_i)
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory");
    /* every event falls within the visits' cycles, the primaries' making, the memory stalls
     * (mem_bound) and (until the last event, something is always under way) the links'
     * transfers: at most h + f - 1 flit times a packet (mprt_replay_run checked this sum) */
    last = r->total + c->gen_cycles * r->ntrees + r->mem_bound;
    if (c->ring) last += (int64_t)(r->nv + (size_t)r->ntrees) * (RING_MAX + r->max_flits) * c->flit_time;
    r->small = r->nproc <= SMALL_PROCS && last < (INT64_MAX >> SMALL_SHIFT) - 1;
    r->pmin = -1;
    for (i = 0; r->small && i < SMALL_PROCS; i++) r->heap_t[i] = INT64_MAX;   /* (small_first reads them all) */
    i = 0;
    for (p = 0; p < c->pes; p++) {
        pe_t *e = &r->pes[p];
        deal(r, p, &e->next, &e->stop, &e->step);
        for (s = 0; s < c->nstages; s++, n++) {
            node *nd = &r->nodes[n];
            int words = (c->replicas[s] + 63) / 64;
            f_init(&nd->rf, c->receive_fifo[s]);
            f_init(&nd->sf, c->send_fifo[s]);
            nd->stage = s;
            nd->pe = p;
            nd->first = i;
            nd->n = c->replicas[s];
            nd->nidle = c->replicas[s];
            nd->idle = calloc((size_t)words, sizeof *nd->idle);
            if (!nd->idle) return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory");
            nd->feed = c->replicas[s] > 1 ? c->feed[s] : 0;   /* one replica: every feed is the shared one */
            if (nd->feed) {
                nd->rfs = calloc((size_t)nd->n, sizeof *nd->rfs);
                nd->locals = calloc((size_t)nd->n, sizeof *nd->locals);
                if (!nd->rfs || !nd->locals) return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory");
                for (k = 0; k < nd->n; k++) f_init(&nd->rfs[k], c->receive_fifo[s]);
            }
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

/* What a run of the loaded trace on the configuration set is refused for, its figures: more
 * PEs than primary rays, the visits' cycles and the primaries' making beyond 2^62. */
static int check_figures(mprt_replay *r)
{
    int64_t g = r->cfg.gen_cycles;
    if (r->cfg.pes > r->ntrees)
        return fail(r, MPRT_ERR_INVALID_ARG, "pes: %d PEs but the trace has only %lld primary rays (one per pixel "
                    "sample)", r->cfg.pes, (long long)r->ntrees);
    if (g > 0 && r->ntrees > (INT64_MAX / 2 - r->total) / g)
        return fail(r, MPRT_ERR_INVALID_ARG, "gen_cycles: with the visits' cycles, more than 2^62 cycles in all");
    return MPRT_OK;
}

int mprt_replay_run(mprt_replay *r, int64_t *log, size_t log_cap)
{
    int rc, k;
    int64_t t, g;
    if (!r) return MPRT_ERR_INVALID_ARG;
    mprt__replay_free_run(r);
    r->errmsg[0] = '\0';
    if (!r->loaded) return fail(r, MPRT_ERR_STATE, "no trace loaded (mprt_replay_load)");
    g = r->cfg.gen_cycles;
    if ((rc = check_figures(r)) != MPRT_OK) return rc;
    if (r->cfg.ring && !r->flits_set)
        return fail(r, MPRT_ERR_STATE, "ring: no packet sizes for this trace (mprt_replay_set_flits)");
    if (log && log_cap < 8 * (r->nv + (size_t)r->ntrees))
        return fail(r, MPRT_ERR_INVALID_ARG, "log: room for %zu entries needed, %zu given",
                    8 * (r->nv + (size_t)r->ntrees), log_cap);
    r->now = r->retired = r->t_end = r->shared_next = 0;
    r->nlog = 0;
    r->oom = r->deadlocked = 0;
    rc = mprt__replay_memory_build(r);    /* sets mem_bound, the most cycles stalls can add */
    if (rc == MPRT_OK && r->cfg.ring &&
        r->cfg.flit_time > (INT64_MAX / 4 - r->total - (g > 0 ? g * r->ntrees : 0) - r->mem_bound) /
                               ((int64_t)(r->nv + (size_t)r->ntrees) * (RING_MAX + r->max_flits) + 1))
        rc = fail(r, MPRT_ERR_INVALID_ARG, "flit_time: %lld cycles per flit could make the run last more than 2^61 "
                  "cycles", (long long)r->cfg.flit_time);
    if (rc == MPRT_OK) rc = build(r);
    if (rc == MPRT_OK && r->cfg.ring) rc = mprt__ring_build(r);
    if (rc != MPRT_OK) {
        mprt__replay_free_run(r);
        return rc;
    }
    r->busy_recorded = r->record_busy;
    if (r->record_busy) {
        size_t nb = (size_t)r->ntrees * (size_t)r->cfg.nstages;
        if (RESERVE(r, tree_busy, cap_tree_busy, nb + 1)) {
            mprt__replay_free_run(r);
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
    mprt__replay_loop(r);
    r->log = NULL;
    if (r->oom) {
        mprt__replay_free_run(r);
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

/* Flit times a packet from node s to node d takes at least on the ring: its header's hops,
 * then the rest of its flits (none to its own node). */
INLINE int64_t ring_latency(const mprt_replay *r, int s, int d, int64_t flits)
{
    int k = r->cfg.nstages;
    if (s == d) return 0;
    return ((d - s + k) % k + (flits > 1 ? flits - 1 : 0)) * r->cfg.flit_time;
}

/* Each tree's critical path into out: the longest chain of its visits' cycles, a ray's
 * visits one after the other and the rays an SC visit made after it.  With ring (its
 * packets' sizes set), each step between stages also takes the packet's least time on the
 * ring (a primary SC made too); with reads (mprt__replay_memory_each's), each visit the
 * least stalls of its memory's reads, also summed by stage into fl (3 per tree).  The rays'
 * first visits go on a stack with their start (nothing recurses). */
static int chains(mprt_replay *r, int64_t *out, int64_t *fl, int ring, const int64_t *reads)
{
    const int *on = r->cfg.stage_of;
    int64_t t, most = 1, *stack;
    for (t = 0; t < r->ntrees; t++) {   /* a tree's rays are at most its visits */
        int64_t n = (t + 1 < r->ntrees ? r->tree_first[t + 1] : (int64_t)r->nv) - r->tree_first[t];
        if (n > most) most = n;
    }
    if (!(stack = malloc(2 * (size_t)most * sizeof *stack)))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the trees' critical paths");
    for (t = 0; t < r->ntrees; t++) {
        int64_t n = 0, cp = 0, x = r->tree_first[t];
        if (fl) fl[3 * t] = fl[3 * t + 1] = fl[3 * t + 2] = 0;
        stack[n++] = x;                 /* a primary SC made comes from SC's stage */
        stack[n++] = ring && r->cfg.gen_cycles > 0 ? ring_latency(r, on[2], on[0], r->pflits[x]) : 0;
        while (n) {
            int64_t at = stack[--n], j = stack[--n], nx;
            int sub = 0;                /* a ray begins on OS */
            for (;; j++) {              /* the ray's visits: the next one is j + 1 */
                if (r->wide) {
                    at += r->vi[j].dur;
                    nx = r->vi[j].next;
                } else {
                    uint64_t w = r->vp[j];
                    at += (int64_t)((w >> 10) & (((uint64_t)1 << PACK_DUR_BITS) - 1));
                    nx = (int64_t)((w >> 34) << 10 | (w & 1023));
                }
                if (reads) {
                    int64_t m = mprt__replay_memory_lines(r, j, reads);
                    at += m;
                    fl[3 * t + on[sub]] += m;   /* (the stage running it) */
                }
                if ((nx & 3) != NEXT_VISIT) break;
                if (ring) at += ring_latency(r, on[sub], on[(nx >> 2) & 3], r->pflits[j + 1]);
                sub = (int)((nx >> 2) & 3);
            }
            if (at > cp) cp = at;
            if ((nx & 3) == NEXT_CHILDREN) {
                int64_t c, a = nx >> 10, b = a + ((nx >> 2) & 255);
                for (c = a; c < b; c++) {
                    stack[n++] = r->child[c];
                    stack[n++] = at + (ring ? ring_latency(r, on[2], on[0], r->pflits[r->child[c]]) : 0);
                }
            }
        }
        out[t] = cp;
    }
    free(stack);
    return MPRT_OK;
}

/* The trees' critical paths for the configuration set: the visits' cycles alone (worked out
 * once a load), or with the ring's and the memories' least times (a run's), with *fl the
 * memories' least stalls per tree and stage (NULL: none), kept while what they depend on
 * stays (a search's designs differ in FIFOs, replicas and PEs more often). */
static const int64_t *critical_paths(mprt_replay *r, const int64_t **fl)
{
    const mprt_replay_config *c = &r->cfg;
    int64_t each[2], room, sig[CX_SIG];
    int ring = c->ring && r->flits_set, mem = mprt__replay_memory_each(r, each), i = 0;
    size_t nt = (size_t)r->ntrees;
    /* (every packet's least time at most what the run allows it: mprt_replay_run's check) */
    room = INT64_MAX / 8 - r->total - (c->gen_cycles > 0 ? c->gen_cycles * r->ntrees : 0);
    if (ring && c->flit_time > room / ((int64_t)(r->nv + nt) * (RING_MAX + r->max_flits) + 1)) ring = 0;
    *fl = NULL;
    if (ring || mem) {
        int t;
        sig[i++] = r->loads;
        sig[i++] = c->nstages;
        for (t = 0; t < 3; t++) sig[i++] = c->stage_of[t];
        sig[i++] = ring ? c->flit_time : 0;
        sig[i++] = c->gen_cycles > 0;
        for (t = 0; t < 2; t++) {
            sig[i++] = each[t];
            sig[i++] = c->cache_size[t];
            sig[i++] = c->cache_line[t];
            sig[i++] = c->cache_ways[t];
        }
        if (!r->cx_ok || memcmp(sig, r->cx_sig, sizeof sig) != 0) {
            r->cx_ok = 0;
            if (RESERVE(r, tree_cx, cap_tree_cx, nt + 1) || RESERVE(r, tree_fl, cap_tree_fl, 3 * nt + 1) ||
                chains(r, r->tree_cx, r->tree_fl, ring, mem ? each : NULL) != MPRT_OK) {
                fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the trees' critical paths");
                return NULL;
            }
            memcpy(r->cx_sig, sig, sizeof sig);
            r->cx_ok = 1;
        }
        *fl = mem ? r->tree_fl : NULL;
        return r->tree_cx;
    }
    if (r->cp_load != r->loads || !r->tree_cp) {
        if (RESERVE(r, tree_cp, cap_tree_cp, nt + 1) || chains(r, r->tree_cp, NULL, 0, NULL) != MPRT_OK) {
            fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the trees' critical paths");
            return NULL;
        }
        r->cp_load = r->loads;
    }
    return r->tree_cp;
}

int mprt_replay_work_bound(mprt_replay *r, int64_t *cycles)
{
    const mprt_replay_config *c;
    int64_t g, best = 0;
    const int64_t *cp, *fl;
    int p, k, s, rc;
    if (!r || !cycles) return MPRT_ERR_INVALID_ARG;
    r->errmsg[0] = '\0';
    if (!r->loaded) return fail(r, MPRT_ERR_STATE, "no trace loaded (mprt_replay_load)");
    c = &r->cfg;
    g = c->gen_cycles > 0 ? c->gen_cycles : 0;
    if ((rc = check_figures(r)) != MPRT_OK) return rc;
    if (!(cp = critical_paths(r, &fl))) return MPRT_ERR_OUT_OF_MEMORY;
    /* (every sum below is at most the visits' cycles and the making's, under 2^62, and the
     * stalls, under 2^60 a memory: mprt__replay_memory_each) */
    for (p = 0; p < (c->dis == MPRT_DIS_DYNAMIC ? 1 : c->pes); p++) {
        int64_t t, first, stop, step, sw[3] = {0, 0, 0}, life = 0, b;
        if (c->dis == MPRT_DIS_DYNAMIC) {       /* every tree, over every PE */
            first = 0;
            stop = r->ntrees;
            step = 1;
        } else {                                /* as the run's DIS deals them */
            deal(r, p, &first, &stop, &step);
        }
        for (t = first; t < stop; t += step) {
            /* the tree's work by stage: its visits' cycles, the making of its primary, and at
             * level 3 the stalls no cache can spare */
            const int64_t *tc = r->tree_cost + 9 * t;
            int64_t tw[3] = {0, 0, 0}, lives = cp[t] + g;
            for (k = 0; k < 3; k++) tw[c->stage_of[k]] += tc[k] + tc[3 + k];
            tw[c->stage_of[MPRT_STAGE_SC]] += g;
            if (fl)
                for (s = 0; s < 3; s++) tw[s] += fl[3 * t + s];
            /* it lives at least its chain, and its work on a stage over the stage's replicas */
            for (s = 0; s < c->nstages; s++) {
                sw[s] += tw[s];
                b = (tw[s] + c->replicas[s] - 1) / c->replicas[s];
                if (b > lives) lives = b;
            }
            life += lives;
        }
        /* DIS admits a tree while fewer than window rays are live, and a tree in flight has one:
         * at most window trees of a PE at once (the dynamic DIS's: every PE's) */
        b = life / c->window + (life % c->window != 0);
        if (c->dis == MPRT_DIS_DYNAMIC) b = b / c->pes + (b % c->pes != 0);
        if (b > best) best = b;
        for (s = 0; s < c->nstages; s++) {
            /* one PE's share: its replicas; the dynamic DIS's: every PE's */
            int64_t n = (int64_t)c->replicas[s] * (c->dis == MPRT_DIS_DYNAMIC ? c->pes : 1);
            b = (sw[s] + n - 1) / n;
            if (b > best) best = b;
        }
    }
    *cycles = best;
    return MPRT_OK;
}
