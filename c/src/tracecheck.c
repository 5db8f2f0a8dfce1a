/* tracecheck.c: a trace's records checked in one pass (mprt_trace_checker_*):
 * every field's range (python/mprt/tracevalid.py's check_arrays) and the
 * invariants between records (python/mprt/tracecheck.py), the same rules.
 *
 * Per ray it keeps a state byte (its visits begun, its SC visit seen) and
 * the difference between its children and the rays its SC visit says it
 * made: 9 bytes a ray.  The visits come in order, a chunk per call; a
 * ray's first visit is checked against its parent's SC visit (seen before
 * it), its later ones against the pipeline's transitions.  Records are read
 * through memcpy: a memory-mapped trace's members lie at any offset of the
 * file, so they need not be aligned.  When asked (mprt_trace_checker_keys),
 * the same pass makes level 3's memory keys (memkeys.c's, the same values)
 * of each visit once its ranges hold. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mprt_internal.h"

/* per ray: BEGUN, SC_SEEN; in a split's second part also CONT (its visits began in the first
 * part, before the split) and NEED (one of its children began here before its SC visit came
 * here: the first part must hold that SC visit) */
enum { BEGUN = 1, SC_SEEN = 2, CONT = 4, NEED = 8, CODES = 16 };
#define CODE(s, o) ((s) * CODES + (o))
#define BIT(s, o) ((uint64_t)1 << CODE(s, o))

struct mprt_trace_checker {
    mprt_trace_limits lim;
    const unsigned char *rays;      /* the records, possibly unaligned */
    size_t nrays;
    size_t next_ray;        /* rays checked: 0 .. next_ray - 1 */
    size_t seen;            /* visits checked */
    uint8_t *state;         /* per ray: BEGUN | SC_SEEN */
    int64_t *owed;          /* per ray: children - made */
    int64_t prev_ray;       /* the last visit's ray (-1: none yet) */
    int prev_code;
    int64_t to_ic, ic;      /* OS->IC handoffs, IC visits */
    int64_t ray_kind;       /* the last visit's ray's kind */
    /* level 3's memory keys (mprt_trace_checker_keys), made while keys_ok */
    const int64_t *mat;     /* prim_material[nmat_prims] */
    size_t nmat_prims, nkeys, nvox, nmat;
    int32_t *keys;
    int64_t *vref, *mref;
    int keys_ok;
    int part;               /* 1: the second part of a split check (mprt_trace_checker_split) */
    size_t from;            /* ... its first visit */
    int fault;
    char msg[160];
};

/* the allowed successors of a visit (bit CODE(stage, outcome)), by its code */
static uint64_t next_of(int code)
{
    switch (code) {
    case CODE(MPRT_STAGE_OS, MPRT_OUT_TO_IC):
        return BIT(MPRT_STAGE_IC, MPRT_OUT_HIT) | BIT(MPRT_STAGE_IC, MPRT_OUT_BLOCKED) |
               BIT(MPRT_STAGE_IC, MPRT_OUT_RETURN);
    case CODE(MPRT_STAGE_IC, MPRT_OUT_RETURN):
        return BIT(MPRT_STAGE_OS, MPRT_OUT_TO_IC) | BIT(MPRT_STAGE_OS, MPRT_OUT_LEFT) |
               BIT(MPRT_STAGE_OS, MPRT_OUT_TO_SC) | BIT(MPRT_STAGE_OS, MPRT_OUT_LATE_HIT);
    case CODE(MPRT_STAGE_IC, MPRT_OUT_HIT):
    case CODE(MPRT_STAGE_OS, MPRT_OUT_LATE_HIT):
        return BIT(MPRT_STAGE_SC, MPRT_OUT_SHADED);
    case CODE(MPRT_STAGE_OS, MPRT_OUT_TO_SC):
        return BIT(MPRT_STAGE_SC, MPRT_OUT_LIT);
    default:
        return 0;
    }
}

static const uint64_t LAST = BIT(MPRT_STAGE_OS, MPRT_OUT_LEFT) | BIT(MPRT_STAGE_IC, MPRT_OUT_BLOCKED) |
                             BIT(MPRT_STAGE_SC, MPRT_OUT_SHADED) | BIT(MPRT_STAGE_SC, MPRT_OUT_LIT);
static const uint64_t SHADOW_ONLY = BIT(MPRT_STAGE_IC, MPRT_OUT_BLOCKED) | BIT(MPRT_STAGE_SC, MPRT_OUT_LIT) |
                                    BIT(MPRT_STAGE_OS, MPRT_OUT_TO_SC);
static const uint64_t NEVER_SHADOW = BIT(MPRT_STAGE_IC, MPRT_OUT_HIT) | BIT(MPRT_STAGE_SC, MPRT_OUT_SHADED) |
                                     BIT(MPRT_STAGE_OS, MPRT_OUT_LEFT);

static int fault(mprt_trace_checker *c, int kind, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->msg, sizeof c->msg, fmt, ap);
    va_end(ap);
    c->fault = kind;
    return kind;
}

mprt_trace_checker *mprt_trace_checker_create(const mprt_trace_limits *lim, const mprt_trace_ray *rays,
                                              size_t nrays)
{
    mprt_trace_checker *c;
    if (!lim || (nrays && !rays)) return NULL;
    c = calloc(1, sizeof *c);
    if (!c) return NULL;
    c->lim = *lim;
    c->rays = (const unsigned char *)rays;
    c->nrays = nrays;
    c->prev_ray = -1;
    if (lim->invariants && nrays) {
        c->state = calloc(nrays, 1);
        c->owed = calloc(nrays, sizeof *c->owed);
        if (!c->state || !c->owed) {
            mprt_trace_checker_destroy(c);
            return NULL;
        }
    }
    return c;
}

void mprt_trace_checker_destroy(mprt_trace_checker *c)
{
    if (!c) return;
    free(c->state);
    free(c->owed);
    if (c->part) {          /* a split's second part owns its references */
        free(c->vref);
        free(c->mref);
    }
    free(c);
}

int mprt_trace_checker_keys(mprt_trace_checker *c, const int64_t *prim_material, size_t nprims, int32_t *keys,
                            size_t nvisits, int64_t *voxel_refs, size_t nvoxels, int64_t *material_refs,
                            size_t nmaterials)
{
    size_t i;
    if (!c || c->seen || (nprims && !prim_material) || (nvisits && !keys) || (nvoxels && !voxel_refs) ||
        (nmaterials && !material_refs))
        return MPRT_ERR_INVALID_ARG;
    c->mat = prim_material;
    c->nmat_prims = nprims;
    c->keys = keys;
    c->nkeys = nvisits;
    c->vref = voxel_refs;
    c->nvox = nvoxels;
    c->mref = material_refs;
    c->nmat = nmaterials;
    for (i = 0; i < nvoxels; i++) voxel_refs[i] = 0;
    for (i = 0; i < nmaterials; i++) material_refs[i] = 0;
    c->keys_ok = 1;
    return MPRT_OK;
}

int mprt_trace_checker_keys_done(const mprt_trace_checker *c)
{
    return c && !c->fault && c->keys_ok && c->seen == c->nkeys;
}

/* Visit j's memory key as mprt_visit_keys makes it; 0 where that would refuse it or
 * keep a voxel id beyond 32 bits (the caller then makes them with mprt_visit_keys). */
static int key_of(mprt_trace_checker *c, const mprt_trace_visit *a, size_t j)
{
    return j < c->nkeys && mprt__visit_key(a, c->mat, c->nmat_prims, c->vref, c->nvox, c->mref, c->nmat, &c->keys[j]);
}

const char *mprt_trace_checker_errmsg(const mprt_trace_checker *c)
{
    return c ? c->msg : "no checker";
}

static int outside(int64_t x, int64_t lo, int64_t hi)
{
    return x < lo || x > hi;
}

int mprt_trace_checker_rays(mprt_trace_checker *c, size_t lo, size_t hi)
{
    const mprt_trace_limits *L;
    int64_t n;
    size_t i;
    if (!c) return MPRT_TRACE_RANGE;
    if (c->fault) return c->fault;
    if (lo != c->next_ray || hi < lo || hi > c->nrays)
        return fault(c, MPRT_TRACE_RANGE, "rays %zu..%zu checked out of order", lo, hi);
    L = &c->lim;
    n = (int64_t)c->nrays;
    for (i = lo; i < hi; i++) {
        const mprt_trace_ray yr = mprt__ray_at(c->rays, i), *y = &yr;
        if (y->id != (int64_t)i) return fault(c, MPRT_TRACE_RANGE, "ray %zu: id %lld", i, (long long)y->id);
        if (outside(y->parent, -1, n - 1) || outside(y->pixel, 0, L->pixels - 1) ||
            outside(y->light, -1, L->lights - 1) || y->kind > MPRT_RAY_SHADOW || y->depth > L->max_depth ||
            !isfinite(y->contribution))
            return fault(c, MPRT_TRACE_RANGE, "ray %zu: a field out of range", i);
        if (!L->invariants) continue;
        if ((y->kind == MPRT_RAY_PRIMARY) != (y->parent < 0))
            return fault(c, MPRT_TRACE_INVARIANT, "ray %zu: primary rays and only they have no parent", i);
        if (y->parent >= 0) {
            const mprt_trace_ray pr = mprt__ray_at(c->rays, (size_t)y->parent), *p = &pr;
            if (y->depth < p->depth) return fault(c, MPRT_TRACE_INVARIANT, "ray %zu is shallower than its parent", i);
            if (y->pixel != p->pixel)
                return fault(c, MPRT_TRACE_INVARIANT, "ray %zu belongs to another pixel than its parent", i);
            c->owed[y->parent]++;
        }
    }
    c->next_ray = hi;
    return MPRT_TRACE_SOUND;
}

/* the end of a ray's run of visits: its last visit's code */
static int ends(mprt_trace_checker *c, int code)
{
    if (!(LAST >> code & 1))
        return fault(c, MPRT_TRACE_INVARIANT, "ray %lld ends with visit code %d", (long long)c->prev_ray, code);
    return MPRT_TRACE_SOUND;
}

int mprt_trace_checker_visits(mprt_trace_checker *c, const mprt_trace_visit *visits, size_t nvisits)
{
    const mprt_trace_limits *L;
    int64_t n, made_max;
    size_t j;
    int inv;
    if (!c) return MPRT_TRACE_RANGE;
    if (c->fault) return c->fault;
    if (c->next_ray != c->nrays) return fault(c, MPRT_TRACE_RANGE, "visits checked before every ray");
    if (nvisits && !visits) return fault(c, MPRT_TRACE_RANGE, "visits missing");
    L = &c->lim;
    n = (int64_t)c->nrays;
    made_max = L->lights + 2;
    inv = L->invariants;
    for (j = 0; j < nvisits; j++, c->seen++) {
        const mprt_trace_visit va = mprt__visit_at(visits, j), *a = &va;
        int64_t ray = a->ray;
        int st = a->stage, code, k, tested = 0;
        for (k = 0; k < MPRT_NKINDS; k++) {
            if (outside(a->tests[k], 0, L->tests)) break;
            tested |= a->tests[k] != 0;
        }
        if (k < MPRT_NKINDS || outside(ray, 0, n - 1) || outside(a->voxel_id, -1, L->voxels - 1) ||
            outside(a->prim, -1, L->prims - 1) || outside(a->steps, 0, L->steps) ||
            outside(a->vertices, 0, L->vertices) || st > MPRT_STAGE_SC || a->outcome > MPRT_OUT_LATE_HIT ||
            a->made > made_max || a->suppressed > made_max)
            return fault(c, MPRT_TRACE_RANGE, "visit %zu: a field out of range", c->seen);
        if (c->keys_ok) c->keys_ok = key_of(c, a, c->seen);
        if (!inv) continue;
        code = CODE(st, a->outcome);
        if (ray != c->prev_ray) {
            const mprt_trace_ray y = mprt__ray_at(c->rays, (size_t)ray);
            int64_t parent = y.parent;
            c->ray_kind = y.kind;
            if (c->prev_ray >= 0 && ends(c, c->prev_code)) return c->fault;
            if (c->state[ray] & BEGUN)
                return fault(c, MPRT_TRACE_INVARIANT, "ray %lld: its visits are not contiguous", (long long)ray);
            c->state[ray] |= BEGUN;
            if (st != MPRT_STAGE_OS)
                return fault(c, MPRT_TRACE_INVARIANT, "ray %lld does not start at OS", (long long)ray);
            if (parent >= 0 && !(c->state[parent] & SC_SEEN)) {
                if (!c->part)
                    return fault(c, MPRT_TRACE_INVARIANT, "ray %lld starts before its parent's SC visit",
                                 (long long)ray);
                c->state[parent] |= NEED;       /* the first part's SC visit, or a fault (join) */
            }
        } else if (!(next_of(c->prev_code) >> code & 1)) {
            return fault(c, MPRT_TRACE_INVARIANT, "visit %zu: code %d after code %d", c->seen, code, c->prev_code);
        }
        if (c->ray_kind == MPRT_RAY_SHADOW ? NEVER_SHADOW >> code & 1 : SHADOW_ONLY >> code & 1)
            return fault(c, MPRT_TRACE_INVARIANT, "visit %zu: a shadow ray's outcome on another ray, or the reverse",
                         c->seen);
        if ((tested && st != MPRT_STAGE_IC) || (a->steps != 0 && st != MPRT_STAGE_OS))
            return fault(c, MPRT_TRACE_INVARIANT, "visit %zu: tests outside IC or voxels outside OS", c->seen);
        if (st == MPRT_STAGE_SC) {
            c->state[ray] |= SC_SEEN;
            c->owed[ray] -= a->made;
        }
        c->to_ic += code == CODE(MPRT_STAGE_OS, MPRT_OUT_TO_IC);
        c->ic += st == MPRT_STAGE_IC;
        c->prev_ray = ray;
        c->prev_code = code;
    }
    return MPRT_TRACE_SOUND;
}

mprt_trace_checker *mprt_trace_checker_split(mprt_trace_checker *c, const mprt_trace_visit *before, size_t from)
{
    mprt_trace_checker *p;
    if (!c || c->part || c->fault || c->seen || c->next_ray != c->nrays || (from && !before)) return NULL;
    p = calloc(1, sizeof *p);
    if (!p) return NULL;
    p->lim = c->lim;
    p->rays = c->rays;
    p->nrays = p->next_ray = c->nrays;
    p->seen = p->from = from;
    p->prev_ray = -1;
    p->part = 1;
    if (c->lim.invariants && c->nrays) {
        p->state = calloc(c->nrays, 1);
        p->owed = calloc(c->nrays, sizeof *p->owed);
        if (!p->state || !p->owed) {
            mprt_trace_checker_destroy(p);
            return NULL;
        }
    }
    if (c->keys_ok) {
        p->mat = c->mat;
        p->nmat_prims = c->nmat_prims;
        p->keys = c->keys;
        p->nkeys = c->nkeys;
        p->nvox = c->nvox;
        p->nmat = c->nmat;
        p->vref = calloc(c->nvox ? c->nvox : 1, sizeof *p->vref);
        p->mref = calloc(c->nmat ? c->nmat : 1, sizeof *p->mref);
        p->keys_ok = p->vref && p->mref;
    }
    if (from && c->lim.invariants) {    /* the run of visits it continues: the visit before it */
        const mprt_trace_visit b = mprt__visit_at(before, 0);
        if (outside(b.ray, 0, (int64_t)c->nrays - 1) || b.stage > MPRT_STAGE_SC || b.outcome > MPRT_OUT_LATE_HIT) {
            fault(p, MPRT_TRACE_RANGE, "visit %zu: a field out of range", from - 1);    /* (the first part's) */
        } else {
            p->prev_ray = b.ray;
            p->prev_code = CODE(b.stage, b.outcome);
            p->ray_kind = mprt__ray_at(c->rays, (size_t)b.ray).kind;
            p->state[b.ray] = BEGUN | CONT;
        }
    }
    return p;
}

int mprt_trace_checker_join(mprt_trace_checker *c, mprt_trace_checker *p)
{
    size_t i;
    if (!c || !p || c->part || !p->part || c->nrays != p->nrays) return MPRT_TRACE_RANGE;
    if (c->fault) return c->fault;      /* the first part's: before any of the second's */
    if (c->seen != p->from) return fault(c, MPRT_TRACE_RANGE, "a split's first part ends at visit %zu, not %zu",
                                         c->seen, p->from);
    if (p->fault) return MPRT_TRACE_REDO;
    if (c->lim.invariants) {
        for (i = 0; i < c->nrays; i++) {
            int s = p->state[i];
            if (((s & (BEGUN | CONT)) == BEGUN && (c->state[i] & BEGUN)) || ((s & NEED) && !(c->state[i] & SC_SEEN)))
                return MPRT_TRACE_REDO;
        }
        for (i = 0; i < c->nrays; i++) {
            c->state[i] |= (uint8_t)(p->state[i] & (BEGUN | SC_SEEN));
            c->owed[i] += p->owed[i];
        }
        c->to_ic += p->to_ic;
        c->ic += p->ic;
        if (p->prev_ray >= 0) {
            c->prev_ray = p->prev_ray;
            c->prev_code = p->prev_code;
            c->ray_kind = p->ray_kind;
        }
    }
    if (c->keys_ok && p->keys_ok && p->seen == p->nkeys) {
        for (i = 0; i < c->nvox; i++) c->vref[i] += p->vref[i];
        for (i = 0; i < c->nmat; i++) c->mref[i] += p->mref[i];
    } else {
        c->keys_ok = 0;
    }
    c->seen = p->seen;
    return MPRT_TRACE_SOUND;
}

int mprt_trace_checker_finish(mprt_trace_checker *c)
{
    size_t i;
    if (!c || c->part) return MPRT_TRACE_RANGE;
    if (c->fault) return c->fault;
    if (c->next_ray != c->nrays) return fault(c, MPRT_TRACE_RANGE, "finished before every ray was checked");
    if (!c->lim.invariants) return MPRT_TRACE_SOUND;
    if (c->prev_ray >= 0 && ends(c, c->prev_code)) return c->fault;
    for (i = 0; i < c->nrays; i++) {
        if (!(c->state[i] & BEGUN)) return fault(c, MPRT_TRACE_INVARIANT, "ray %zu has no visits", i);
        if (c->owed[i])
            return fault(c, MPRT_TRACE_INVARIANT, "ray %zu: its SC visit's 'made' differs from its children", i);
    }
    if (c->to_ic != c->ic) return fault(c, MPRT_TRACE_INVARIANT, "OS->IC handoffs and IC visits differ");
    return MPRT_TRACE_SOUND;
}
