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
void mprt__replay_deal(const mprt_replay *r, int p, int64_t *first, int64_t *stop, int64_t *step)
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
        mprt__replay_deal(r, p, &e->next, &e->stop, &e->step);
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

/* What a run of the loaded trace on the configuration set is refused for, its figures: a trace
 * without primary rays, the visits' cycles and the primaries' making beyond 2^62.  (More PEs
 * than primary rays is run: the PEs that get none stay idle, as in the SimPy model.) */
int mprt__replay_check_figures(mprt_replay *r)
{
    int64_t g = r->cfg.gen_cycles;
    if (r->ntrees == 0) return fail(r, MPRT_ERR_INVALID_ARG, "the trace has no primary rays: nothing to replay");
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
    if ((rc = mprt__replay_check_figures(r)) != MPRT_OK) return rc;
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
