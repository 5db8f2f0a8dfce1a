/* cost.c: every visit of a trace priced in one pass (mprt_cost_visits): the
 * cost model's per-visit arithmetic (python/mprt/cost/model.py, whose
 * numpy form is the reference the tests compare this with), with the
 * kernels' cycles, packet sizes and communication costs given as a table. */
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>

#include "mprt_internal.h"

enum { KINDS = 4, COST_THREADS = 16 };
#define COST_SHARE_MIN ((size_t)1 << 20)  /* visits: fewer per thread are not worth one */

static int cost_fail(char *errmsg, size_t errlen, const char *fmt, ...)
{
    va_list ap;
    if (errmsg && errlen) {
        va_start(ap, fmt);
        vsnprintf(errmsg, errlen, fmt, ap);
        va_end(ap);
    }
    return MPRT_ERR_INVALID_ARG;
}

int mprt_cost_children(const mprt_trace_ray *rays, size_t nrays, int64_t *children, char *errmsg, size_t errlen)
{
    size_t i;
    if (errmsg && errlen) errmsg[0] = '\0';
    if (nrays > SIZE_MAX / KINDS) return cost_fail(errmsg, errlen, "mprt_cost_children: %zu rays", nrays);
    if (nrays && (!rays || !children))
        return cost_fail(errmsg, errlen, "mprt_cost_children: an array is missing");
    for (i = 0; i < nrays * KINDS; i++) children[i] = 0;
    for (i = 0; i < nrays; i++) {
        const mprt_trace_ray yv = mprt__ray_at(rays, i), *y = &yv;
        if (y->kind >= KINDS)
            return cost_fail(errmsg, errlen, "ray %zu: kind %d is not a ray kind", i, (int)y->kind);
        if (y->parent < 0) continue;
        if ((uint64_t)y->parent >= nrays)
            return cost_fail(errmsg, errlen, "ray %zu: parent %lld is not a ray of the trace", i,
                             (long long)y->parent);
        children[(size_t)y->parent * KINDS + y->kind]++;
    }
    return MPRT_OK;
}

/* The general pass: every visit's kernel runs column by column (what
 * runs and packets report), its costs their products with the table. */
static int cost_counted(const mprt_cost_table *t, const mprt_trace_ray *rays, const int64_t *children, size_t nrays,
                        const int32_t *prim_kind, size_t nprims, const mprt_trace_visit *visits, size_t nvisits,
                        int64_t prev_ray, int prev_outcome, int64_t *process, int64_t *receive, int64_t *send,
                        int32_t *flits, int32_t *runs, int32_t *packets, char *errmsg, size_t errlen)
{
    uint64_t c[MPRT_COST_KERNELS];
    size_t j, k;
    for (j = 0; j < nvisits; j++) {
        const mprt_trace_visit av = mprt__visit_at(visits, j), *a = &av;
        const int64_t *kd;
        int64_t ray = a->ray, pk = -1, src, dst = -1;
        int st = a->stage, out = a->outcome, kind, pout, first, shaded;
        uint64_t p, fin, fout, nout, wk;
        if (ray < 0 || (uint64_t)ray >= nrays)
            return cost_fail(errmsg, errlen, "visit %zu: ray %lld is not a ray of the trace", j, (long long)ray);
        if (st > MPRT_STAGE_SC) return cost_fail(errmsg, errlen, "visit %zu: stage %d is not OS, IC or SC", j, st);
        if (a->prim >= 0) {
            if ((size_t)a->prim >= nprims)
                return cost_fail(errmsg, errlen, "visit %zu: primitive %d is not a primitive of the trace", j,
                                 (int)a->prim);
            pk = prim_kind[a->prim];
        }
        kind = mprt__ray_at(rays, (size_t)ray).kind;
        if (kind >= KINDS)
            return cost_fail(errmsg, errlen, "ray %lld: kind %d is not a ray kind", (long long)ray, kind);
        kd = children + (size_t)ray * KINDS;
        if (j) {
            const mprt_trace_visit before = mprt__visit_at(visits, j - 1);
            first = ray != before.ray;
            pout = before.outcome;
        } else {
            first = ray != prev_ray;
            pout = prev_outcome;
        }
        shaded = st == MPRT_STAGE_SC && out == MPRT_OUT_SHADED;
        for (k = 0; k < MPRT_COST_KERNELS; k++) c[k] = 0;
        if (st == MPRT_STAGE_OS) {
            c[0] = (uint64_t)first;
            c[1] = (uint64_t)(int64_t)a->steps;
            c[2] = 1;
            if (out == MPRT_OUT_LATE_HIT && pk >= 0 && pk < KINDS) c[3 + pk] = 1;
        } else if (st == MPRT_STAGE_IC) {
            c[0] = 1;
            for (k = 0; k < KINDS; k++) c[1 + k] = (uint64_t)(int64_t)a->tests[k];
            c[5] = (uint64_t)(int64_t)a->vertices;
            if (out == MPRT_OUT_HIT && pk >= 0 && pk < KINDS) c[6 + pk] = 1;
        } else if (shaded) {
            c[0] = 1;
            c[1] = (uint64_t)t->lights;
            c[2] = (uint64_t)a->made + a->suppressed;
            c[3] = (uint64_t)kd[MPRT_RAY_SHADOW];
            c[4] = (uint64_t)kd[MPRT_RAY_REFLECT];
            c[5] = (uint64_t)kd[MPRT_RAY_REFRACT];
        } else if (out == MPRT_OUT_LIT) {
            c[6] = 1;
        }
        p = (uint64_t)t->overhead[st];
        for (k = 0; k < MPRT_COST_KERNELS; k++) p += c[k] * (uint64_t)t->kernel[st][k];
        /* the packet that brought the ray here, and those it sends */
        if (first) src = MPRT_STAGE_SC;
        else if (st == MPRT_STAGE_OS) src = MPRT_STAGE_IC;
        else if (st == MPRT_STAGE_IC) src = MPRT_STAGE_OS;
        else src = MPRT_STAGE_OS;
        if (st == MPRT_STAGE_SC && out == MPRT_OUT_LIT) src = MPRT_STAGE_OS;
        if (shaded) src = pout == MPRT_OUT_LATE_HIT ? MPRT_STAGE_OS : MPRT_STAGE_IC;
        fin = (uint64_t)t->flits[src][st][kind];
        if (st == MPRT_STAGE_OS && out == MPRT_OUT_TO_IC) dst = MPRT_STAGE_IC;
        else if (st == MPRT_STAGE_OS && (out == MPRT_OUT_TO_SC || out == MPRT_OUT_LATE_HIT)) dst = MPRT_STAGE_SC;
        else if (st == MPRT_STAGE_IC && out == MPRT_OUT_HIT) dst = MPRT_STAGE_SC;
        else if (st == MPRT_STAGE_IC && out == MPRT_OUT_RETURN) dst = MPRT_STAGE_OS;
        if (dst >= 0) {
            fout = (uint64_t)t->flits[st][dst][kind];
            nout = 1;
        } else if (shaded) {
            fout = 0;
            for (k = 0; k < KINDS; k++) fout += (uint64_t)kd[k] * (uint64_t)t->flits[MPRT_STAGE_SC][MPRT_STAGE_OS][k];
            nout = a->made;
        } else {
            fout = nout = 0;
        }
        if (process) process[j] = (int64_t)p;
        if (receive) receive[j] = (int64_t)((uint64_t)t->receive_packet[st] + fin * (uint64_t)t->receive_flit[st]);
        if (send) {
            wk = nout * (uint64_t)t->send_packet[st] + fout * (uint64_t)t->send_flit[st];
            send[j] = (int64_t)wk;
        }
        if (flits) flits[j] = (int32_t)(uint32_t)fout;
        if (runs)
            for (k = 0; k < MPRT_COST_KERNELS; k++) runs[j * MPRT_COST_KERNELS + k] = (int32_t)(uint32_t)c[k];
        if (packets) {
            packets[3 * j] = (int32_t)(uint32_t)fin;
            packets[3 * j + 1] = (int32_t)(uint32_t)nout;
            packets[3 * j + 2] = (int32_t)(uint32_t)fout;
        }
    }
    return MPRT_OK;
}

/* The table folded for the fast pass: per stage the kernels' cycles, the
 * receive cycles and the cost and flits of one packet sent, by source or
 * destination stage and ray kind. */
typedef struct {
    uint64_t overhead[3], os[3], os_hit[KINDS], ic_visit, ic_test[KINDS], ic_vertex, ic_hit[KINDS];
    uint64_t sc_shade, sc_keep, sc_kid[3], sc_lit, sc_made, sc_flit, kid_flits[KINDS];
    uint64_t receive[3][3][KINDS], send1[3][3][KINDS], flits1[3][3][KINDS];
} folded;

static void fold(const mprt_cost_table *t, folded *f)
{
    int s, d, k;
    for (s = 0; s < 3; s++) {
        f->overhead[s] = (uint64_t)t->overhead[s];
        for (d = 0; d < 3; d++)
            for (k = 0; k < KINDS; k++) {
                uint64_t n = (uint64_t)t->flits[s][d][k];
                f->receive[s][d][k] = (uint64_t)t->receive_packet[d] + n * (uint64_t)t->receive_flit[d];
                f->send1[s][d][k] = (uint64_t)t->send_packet[s] + n * (uint64_t)t->send_flit[s];
                f->flits1[s][d][k] = n;
            }
    }
    for (k = 0; k < 3; k++) f->os[k] = (uint64_t)t->kernel[MPRT_STAGE_OS][k];
    f->ic_visit = (uint64_t)t->kernel[MPRT_STAGE_IC][0];
    f->ic_vertex = (uint64_t)t->kernel[MPRT_STAGE_IC][5];
    for (k = 0; k < KINDS; k++) {
        f->os_hit[k] = (uint64_t)t->kernel[MPRT_STAGE_OS][3 + k];
        f->ic_test[k] = (uint64_t)t->kernel[MPRT_STAGE_IC][1 + k];
        f->ic_hit[k] = (uint64_t)t->kernel[MPRT_STAGE_IC][6 + k];
        f->kid_flits[k] = (uint64_t)t->flits[MPRT_STAGE_SC][MPRT_STAGE_OS][k];
    }
    f->sc_shade = (uint64_t)t->kernel[MPRT_STAGE_SC][0] + (uint64_t)t->lights * (uint64_t)t->kernel[MPRT_STAGE_SC][1];
    f->sc_keep = (uint64_t)t->kernel[MPRT_STAGE_SC][2];
    for (k = 0; k < 3; k++) f->sc_kid[k] = (uint64_t)t->kernel[MPRT_STAGE_SC][3 + k];
    f->sc_lit = (uint64_t)t->kernel[MPRT_STAGE_SC][6];
    f->sc_made = (uint64_t)t->send_packet[MPRT_STAGE_SC];
    f->sc_flit = (uint64_t)t->send_flit[MPRT_STAGE_SC];
}

/* The fast pass: costs and flits only, stage by stage in straight lines:
 * visits[base .. base + nvisits - 1] into process[0 .. nvisits - 1] (and the
 * others).  Also the compiled replay's loading, a chunk at a time
 * (mprt__cost_range, mprt_internal.h). */
int mprt__cost_range(const mprt_cost_table *t, const mprt_trace_ray *rays, const int64_t *children, size_t nrays,
                     const int32_t *prim_kind, size_t nprims, const mprt_trace_visit *visits, size_t base,
                     size_t nvisits, int64_t prev_ray, int prev_outcome, int64_t *process, int64_t *receive,
                     int64_t *send, int32_t *flits, char *errmsg, size_t errlen)
{
    folded f;
    size_t j;
    int64_t prev = prev_ray;
    int pout = prev_outcome;
    fold(t, &f);
    for (j = 0; j < nvisits; j++) {
        const mprt_trace_visit av = mprt__visit_at(visits, base + j), *a = &av;
        int64_t ray = a->ray, pk = -1;
        int st = a->stage, out = a->outcome, kind, first, src, dst = -1;
        uint64_t p, x, y = 0, fo = 0;
        if (ray < 0 || (uint64_t)ray >= nrays)
            return cost_fail(errmsg, errlen, "visit %zu: ray %lld is not a ray of the trace", base + j, (long long)ray);
        if (st > MPRT_STAGE_SC) return cost_fail(errmsg, errlen, "visit %zu: stage %d is not OS, IC or SC", base + j, st);
        if (a->prim >= 0) {
            if ((size_t)a->prim >= nprims)
                return cost_fail(errmsg, errlen, "visit %zu: primitive %d is not a primitive of the trace", base + j,
                                 (int)a->prim);
            pk = prim_kind[a->prim];
        }
        kind = mprt__ray_at(rays, (size_t)ray).kind;
        if (kind >= KINDS)
            return cost_fail(errmsg, errlen, "ray %lld: kind %d is not a ray kind", (long long)ray, kind);
        first = ray != prev;
        p = f.overhead[st];
        if (st == MPRT_STAGE_OS) {
            p += (uint64_t)first * f.os[0] + (uint64_t)(int64_t)a->steps * f.os[1] + f.os[2];
            if (out == MPRT_OUT_LATE_HIT && pk >= 0 && pk < KINDS) p += f.os_hit[pk];
            src = first ? MPRT_STAGE_SC : MPRT_STAGE_IC;
            if (out == MPRT_OUT_TO_IC) dst = MPRT_STAGE_IC;
            else if (out == MPRT_OUT_TO_SC || out == MPRT_OUT_LATE_HIT) dst = MPRT_STAGE_SC;
        } else if (st == MPRT_STAGE_IC) {
            p += f.ic_visit + (uint64_t)(int64_t)a->tests[0] * f.ic_test[0] +
                 (uint64_t)(int64_t)a->tests[1] * f.ic_test[1] + (uint64_t)(int64_t)a->tests[2] * f.ic_test[2] +
                 (uint64_t)(int64_t)a->tests[3] * f.ic_test[3] + (uint64_t)(int64_t)a->vertices * f.ic_vertex;
            if (out == MPRT_OUT_HIT && pk >= 0 && pk < KINDS) p += f.ic_hit[pk];
            src = first ? MPRT_STAGE_SC : MPRT_STAGE_OS;
            if (out == MPRT_OUT_HIT) dst = MPRT_STAGE_SC;
            else if (out == MPRT_OUT_RETURN) dst = MPRT_STAGE_OS;
        } else if (out == MPRT_OUT_SHADED) {
            const int64_t *kd = children + (size_t)ray * KINDS;
            p += f.sc_shade + ((uint64_t)a->made + a->suppressed) * f.sc_keep +
                 (uint64_t)kd[MPRT_RAY_SHADOW] * f.sc_kid[0] + (uint64_t)kd[MPRT_RAY_REFLECT] * f.sc_kid[1] +
                 (uint64_t)kd[MPRT_RAY_REFRACT] * f.sc_kid[2];
            src = pout == MPRT_OUT_LATE_HIT ? MPRT_STAGE_OS : MPRT_STAGE_IC;
            fo = (uint64_t)kd[0] * f.kid_flits[0] + (uint64_t)kd[1] * f.kid_flits[1] +
                 (uint64_t)kd[2] * f.kid_flits[2] + (uint64_t)kd[3] * f.kid_flits[3];
            y = (uint64_t)a->made * f.sc_made + fo * f.sc_flit;
        } else {
            if (out == MPRT_OUT_LIT) {
                p += f.sc_lit;
                src = MPRT_STAGE_OS;
            } else {
                src = first ? MPRT_STAGE_SC : MPRT_STAGE_OS;
            }
        }
        x = f.receive[src][st][kind];
        if (dst >= 0) {
            y = f.send1[st][dst][kind];
            fo = f.flits1[st][dst][kind];
        }
        if (process) process[j] = (int64_t)p;
        if (receive) receive[j] = (int64_t)x;
        if (send) send[j] = (int64_t)y;
        if (flits) flits[j] = (int32_t)(uint32_t)fo;
        prev = ray;
        pout = out;
    }
    return MPRT_OK;
}

/* A thread's share of the fast pass: visits [lo, hi). */
typedef struct {
    const mprt_cost_table *t;
    const mprt_trace_ray *rays;
    const int64_t *children, *prev_ray;
    const int32_t *prim_kind;
    const mprt_trace_visit *visits;
    const int *prev_outcome;
    size_t nrays, nprims, lo, hi;
    int64_t *process, *receive, *send;
    int32_t *flits;
    int rc;
    char msg[256];
    pthread_t thread;
} share;

static void *cost_share(void *arg)
{
    share *w = arg;
    int64_t pr = w->lo ? mprt__visit_at(w->visits, w->lo - 1).ray : *w->prev_ray;
    int po = w->lo ? mprt__visit_at(w->visits, w->lo - 1).outcome : *w->prev_outcome;
    w->rc = mprt__cost_range(w->t, w->rays, w->children, w->nrays, w->prim_kind, w->nprims, w->visits, w->lo,
                             w->hi - w->lo, pr, po, w->process ? w->process + w->lo : NULL,
                             w->receive ? w->receive + w->lo : NULL, w->send ? w->send + w->lo : NULL,
                             w->flits ? w->flits + w->lo : NULL, w->msg, sizeof w->msg);
    return NULL;
}

int mprt_cost_visits(const mprt_cost_table *t, const mprt_trace_ray *rays, const int64_t *children, size_t nrays,
                     const int32_t *prim_kind, size_t nprims, const mprt_trace_visit *visits, size_t nvisits,
                     int64_t prev_ray, int prev_outcome, int64_t *process, int64_t *receive, int64_t *send,
                     int32_t *flits, int32_t *runs, int32_t *packets, int threads, char *errmsg, size_t errlen)
{
    share w[COST_THREADS];
    int n, i, started;
    if (errmsg && errlen) errmsg[0] = '\0';
    if (!t || (nrays && (!rays || !children)) || (nvisits && !visits) || (nprims && !prim_kind))
        return cost_fail(errmsg, errlen, "mprt_cost_visits: a table or array is missing");
    if (runs || packets)
        return cost_counted(t, rays, children, nrays, prim_kind, nprims, visits, nvisits, prev_ray, prev_outcome,
                            process, receive, send, flits, runs, packets, errmsg, errlen);
    /* threads share the visits in order; each starts from the visit before its share */
    n = threads < 1 ? 1 : threads > COST_THREADS ? COST_THREADS : threads;
    if ((size_t)n > nvisits / COST_SHARE_MIN) n = (int)(nvisits / COST_SHARE_MIN);
    if (n <= 1)
        return mprt__cost_range(t, rays, children, nrays, prim_kind, nprims, visits, 0, nvisits, prev_ray, prev_outcome,
                         process, receive, send, flits, errmsg, errlen);
    for (i = 0; i < n; i++) {
        share *x = &w[i];
        x->t = t;
        x->rays = rays;
        x->children = children;
        x->prev_ray = &prev_ray;
        x->prev_outcome = &prev_outcome;
        x->prim_kind = prim_kind;
        x->visits = visits;
        x->nrays = nrays;
        x->nprims = nprims;
        x->lo = nvisits / (size_t)n * (size_t)i;
        x->hi = i + 1 == n ? nvisits : nvisits / (size_t)n * (size_t)(i + 1);
        x->process = process;
        x->receive = receive;
        x->send = send;
        x->flits = flits;
        x->rc = MPRT_OK;
        x->msg[0] = '\0';
    }
    for (started = 1; started < n; started++)
        if (pthread_create(&w[started].thread, NULL, cost_share, &w[started]) != 0) break;
    for (i = started; i < n; i++) cost_share(&w[i]);       /* shares no thread could take */
    cost_share(&w[0]);
    for (i = 1; i < started; i++) pthread_join(w[i].thread, NULL);
    for (i = 0; i < n; i++)     /* the first visit at fault, as one thread would find it */
        if (w[i].rc != MPRT_OK) {
            if (errmsg && errlen) snprintf(errmsg, errlen, "%s", w[i].msg);
            return w[i].rc;
        }
    return MPRT_OK;
}
