/* replay_result.c: the compiled replay's figures after a run (see replay.c). */
#include "replay.h"

/* Occupancy integrated over [0, max(end, last change)]. */
static int64_t f_area(const fifo *f, int64_t end)
{
    int64_t t = end > f->last ? end : f->last;
    return (int64_t)(f->sojourn + ((uint64_t)f->q.len + (uint64_t)f->reserved) * (uint64_t)t);
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
    int rc = need_run(r, out, cap, r ? (size_t)r->nnode : 0), n, k;
    if (rc != MPRT_OK) return rc;
    for (n = 0; n < r->nnode; n++) {
        const node *nd = &r->nodes[n];
        mprt_replay_node *o = &out[n];
        int64_t end = r->t_end;
        o->receive_occupancy = (int64_t)nd->rf.q.len;
        o->receive_max = nd->rf.max;
        o->receive_puts = nd->rf.puts;
        o->receive_area = f_area(&nd->rf, end);
        o->local_queue = (int64_t)nd->local.len;
        for (k = 0; nd->feed && k < nd->n; k++) {   /* per replica: summed, the largest max */
            const fifo *f = &nd->rfs[k];
            o->receive_occupancy += (int64_t)f->q.len;
            o->receive_max = f->max > o->receive_max ? f->max : o->receive_max;
            o->receive_puts += f->puts;
            o->receive_area += f_area(f, end);
            o->local_queue += (int64_t)nd->locals[k].len;
        }
        o->send_occupancy = (int64_t)nd->sf.q.len;
        o->send_max = nd->sf.max;
        o->send_puts = nd->sf.puts;
        o->send_area = f_area(&nd->sf, end);
        o->generated = nd->generated;
        o->receive_reserved = nd->rf.reserved;
        for (k = 0; nd->feed && k < nd->n; k++) o->receive_reserved += nd->rfs[k].reserved;
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
