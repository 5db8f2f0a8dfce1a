/* replay_config.c: the compiled replay's configurations; making, reconfiguring and
 * destroying a replay (see replay.c). */
#include "replay.h"

#include <stdarg.h>

int mprt__replay_fail(mprt_replay *r, int status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    mprt__vformat(r->errmsg, sizeof r->errmsg, fmt, ap);
    va_end(ap);
    return status;
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
        if (c->feed[s] < 0 || c->feed[s] > 2)
            return fail(r, MPRT_ERR_INVALID_ARG,
                        "feed[%d]: must be shared (0), round-robin (1) or shortest queue (2), not %d", s, c->feed[s]);
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
    if (c->ring != 0 && c->ring != 1)
        return fail(r, MPRT_ERR_INVALID_ARG, "ring: must be 0 (the ideal network) or 1 (the ring), not %d", c->ring);
    if (c->ring) {
        if (c->nstages < 2)
            return fail(r, MPRT_ERR_INVALID_ARG, "ring: a ring needs at least 2 stages (one stage has no network)");
        if (c->flit_time < 1)
            return fail(r, MPRT_ERR_INVALID_ARG, "ring.flit_time: must be at least 1, not %lld",
                        (long long)c->flit_time);
        if (c->buffer_classes < 1 || c->buffer_classes > c->nstages)
            return fail(r, MPRT_ERR_INVALID_ARG, "ring.buffer_classes: must be 1..%d (one per hop plus the source's) "
                        "with %d stages, not %d", c->nstages, c->nstages, c->buffer_classes);
    }
    return mprt__replay_memory_check(r, c);
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
    mprt__replay_free_run(r);
    r->cfg = *cfg;
    return MPRT_OK;
}

void mprt_replay_destroy(mprt_replay *r)
{
    if (!r) return;
    mprt__replay_free_run(r);
    mprt__replay_memory_free(r);
    mprt__replay_free_trace(r);
    free(r->tree_cp);
    free(r->tree_cx);
    free(r->tree_ex);
    free(r->tree_fl);
    free(r);
}

const char *mprt_replay_errmsg(const mprt_replay *r) { return r ? r->errmsg : "no replay"; }
