/* replay_load.c: the compiled replay's trace, checked and packed once for any
 * number of runs (see replay.c). */
#include "replay.h"

#include <pthread.h>

/* ---- the trace ---------------------------------------------------------------- */

#define TRACE_FAIL(r, ...) fail((r), MPRT_ERR_INVALID_ARG, "cannot replay this trace: " __VA_ARGS__)

int mprt__replay_reserve(void **p, size_t *cap, size_t n, size_t size)
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
        const mprt_trace_ray yv = mprt__ray_at(rays, i), *y = &yv;
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
    r->nchild = (size_t)cs[nr + 1];
    if (RESERVE(r, child, cap_child, r->nchild + 1) || RESERVE(r, child_kind, cap_child_kind, r->nchild + 1))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %zu rays", nr);
    for (i = 0; i < nr; i++) {
        const mprt_trace_ray y = mprt__ray_at(rays, i);
        if (y.kind != MPRT_RAY_PRIMARY) {
            int64_t c = cs[y.parent + 1]++;
            r->child[c] = (int64_t)i;
            r->child_kind[c] = y.kind;           /* for the ring's packet sizes (mprt_replay_set_flits) */
        }
    }
    /* now cs[p] .. cs[p + 1] are p's children; the most leaves of any tree */
    r->max_leaves = 0;
    for (i = 0; i <= nr; i++) {
        if (i == nr || mprt__ray_at(rays, i).kind == MPRT_RAY_PRIMARY) {
            if (leaves > r->max_leaves) r->max_leaves = leaves;
            leaves = 0;
        }
        if (i < nr && cs[i + 1] == cs[i]) leaves++;
    }
    return MPRT_OK;
}

/* The visit infos are written packed in 8 bytes each (vp) while they fit
 * (half the memory the replay walks, and no second pass); the first that
 * does not turns them into 16-byte ones (vi) from there on. */
static uint64_t packed(int64_t dur, int64_t next)
{
    uint64_t nx = (uint64_t)next;
    return (nx >> 10) << 34 | (uint64_t)dur << 10 | (nx & 1023);
}

/* Visits 0 .. n-1, packed so far, unpacked into vi: the replay reads wide ones from here on. */
static int widen(mprt_replay *r, size_t n)
{
    size_t j;
    if (RESERVE(r, vi, cap_vi, r->nv + 1)) return -1;
    for (j = 0; j < n; j++) r->vi[j] = unpack_visit(r->vp[j]);
    r->wide = 1;
    return 0;
}

/* The visits, in one pass: each tree's visits contiguous and in order,
 * starting with its primary's; each ray's contiguous; known stages; costs
 * of at least one cycle; an SC visit that ends its ray made as many rays as
 * have it as parent.  Fills the visit infos and the trees' costs. */
/* What prices the visits as they load (mprt_replay_load_priced): the cost
 * table and what it reads, and a chunk's costs. */
typedef struct {
    const mprt_cost_table *table;
    const int64_t *children;
    const int32_t *prim_kind;
    size_t nprims;
    int64_t *buf;       /* PRICE_CHUNK process, then receive, then send */
    int32_t *flits;     /* the visits' flits out (or NULL) */
    int64_t *wide;      /* ... or out widened to int64, as mprt_replay_set_flits takes them (or NULL) */
    int32_t *tmp;       /* PRICE_CHUNK flits before they are widened (with wide) */
    int threads;        /* 2 or more: priced on a thread of their own, ahead of the loading (pipe) */
} pricer;
#define PRICE_CHUNK ((size_t)4096)

/* Priced on a second thread: the pricing runs ahead of the loading by up to PIPE_SLOTS blocks
 * of PIPE_BLOCK visits, each priced PRICE_CHUNK visits a call as one thread prices them; a
 * block whose pricing failed says from which visit (the failing call's first), and the loading
 * fails there, where one thread would: the same replay, the same errors, whatever the threads. */
#define PIPE_BLOCK ((size_t)16 * PRICE_CHUNK)
#define PIPE_SLOTS 4
typedef struct {
    const pricer *pr;
    const mprt_trace_ray *rays;
    const mprt_trace_visit *v;
    size_t nv, nr;
    int64_t *buf;               /* PIPE_SLOTS x (PIPE_BLOCK process, receive, send) */
    int32_t *fbuf;              /* PIPE_SLOTS x PIPE_BLOCK flits, widened by the loading (pricer's wide) */
    int rc[PIPE_SLOTS];
    size_t bad[PIPE_SLOTS];     /* the first visit of the call that failed (SIZE_MAX: none) */
    char msg[PIPE_SLOTS][256];
    size_t produced, consumed;  /* blocks priced; blocks the loading is done with */
    int stop;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    pthread_t thread;
} pipe_t;

static void *pipe_price(void *arg)
{
    pipe_t *pp = arg;
    const pricer *pr = pp->pr;
    size_t b, nb = (pp->nv + PIPE_BLOCK - 1) / PIPE_BLOCK;
    for (b = 0; b < nb; b++) {
        size_t s = b % PIPE_SLOTS, lo = b * PIPE_BLOCK, n = pp->nv - lo < PIPE_BLOCK ? pp->nv - lo : PIPE_BLOCK, c;
        int64_t *out = pp->buf + s * 3 * PIPE_BLOCK;
        int failed = 0;
        pthread_mutex_lock(&pp->mu);
        while (!pp->stop && b >= pp->consumed + PIPE_SLOTS) pthread_cond_wait(&pp->cv, &pp->mu);
        failed = pp->stop;
        pthread_mutex_unlock(&pp->mu);
        if (failed) break;
        pp->rc[s] = MPRT_OK;
        pp->bad[s] = SIZE_MAX;
        for (c = 0; c < n; c += PRICE_CHUNK) {
            size_t m = n - c < PRICE_CHUNK ? n - c : PRICE_CHUNK, j = lo + c;
            mprt_trace_visit before;
            int rc;
            if (j) before = mprt__visit_at(pp->v, j - 1);
            rc = mprt__cost_range(pr->table, pp->rays, pr->children, pp->nr, pr->prim_kind, pr->nprims, pp->v, j, m,
                                  j ? before.ray : -1, j ? before.outcome : 0, out + c, out + PIPE_BLOCK + c,
                                  out + 2 * PIPE_BLOCK + c,
                                  pr->flits ? pr->flits + j : pp->fbuf ? pp->fbuf + s * PIPE_BLOCK + c : NULL,
                                  pp->msg[s], sizeof pp->msg[s]);
            if (rc != MPRT_OK) {
                pp->rc[s] = rc;
                pp->bad[s] = j;
                failed = 1;
                break;
            }
        }
        pthread_mutex_lock(&pp->mu);
        pp->produced = b + 1;
        pthread_cond_broadcast(&pp->cv);
        pthread_mutex_unlock(&pp->mu);
        if (failed) break;
    }
    return NULL;
}

/* Start pricing on a thread (0: started; -1: none started, price on this one). */
static int pipe_start(pipe_t *pp, const pricer *pr, const mprt_trace_ray *rays, const mprt_trace_visit *v, size_t nv,
                      size_t nr)
{
    memset(pp, 0, sizeof *pp);
    pp->pr = pr;
    pp->rays = rays;
    pp->v = v;
    pp->nv = nv;
    pp->nr = nr;
    pp->buf = malloc(PIPE_SLOTS * 3 * PIPE_BLOCK * sizeof *pp->buf);
    pp->fbuf = pr->wide ? malloc(PIPE_SLOTS * PIPE_BLOCK * sizeof *pp->fbuf) : NULL;
    if (!pp->buf || (pr->wide && !pp->fbuf)) {
        free(pp->buf);
        free(pp->fbuf);
        return -1;
    }
    if (pthread_mutex_init(&pp->mu, NULL)) {
        free(pp->buf);
        free(pp->fbuf);
        return -1;
    }
    if (pthread_cond_init(&pp->cv, NULL)) {
        pthread_mutex_destroy(&pp->mu);
        free(pp->buf);
        free(pp->fbuf);
        return -1;
    }
    if (pthread_create(&pp->thread, NULL, pipe_price, pp)) {
        pthread_cond_destroy(&pp->cv);
        pthread_mutex_destroy(&pp->mu);
        free(pp->buf);
        free(pp->fbuf);
        return -1;
    }
    return 0;
}

/* Block b's prices, once priced (the blocks before it are done with), its flits widened
 * (those priced) into the pricer's wide: here, on the loading's thread, the lighter one. */
static const int64_t *pipe_take(pipe_t *pp, size_t b)
{
    size_t s = b % PIPE_SLOTS, lo = b * PIPE_BLOCK, n, i;
    pthread_mutex_lock(&pp->mu);
    pp->consumed = b;
    pthread_cond_broadcast(&pp->cv);
    while (pp->produced <= b) pthread_cond_wait(&pp->cv, &pp->mu);
    pthread_mutex_unlock(&pp->mu);
    if (pp->fbuf) {
        n = pp->nv - lo < PIPE_BLOCK ? pp->nv - lo : PIPE_BLOCK;
        if (pp->bad[s] != SIZE_MAX) n = pp->bad[s] - lo;
        for (i = 0; i < n; i++) pp->pr->wide[lo + i] = pp->fbuf[s * PIPE_BLOCK + i];
    }
    return pp->buf + s * 3 * PIPE_BLOCK;
}

static void pipe_end(pipe_t *pp)
{
    pthread_mutex_lock(&pp->mu);
    pp->stop = 1;
    pthread_cond_broadcast(&pp->cv);
    pthread_mutex_unlock(&pp->mu);
    pthread_join(pp->thread, NULL);
    pthread_cond_destroy(&pp->cv);
    pthread_mutex_destroy(&pp->mu);
    free(pp->buf);
    free(pp->fbuf);
}

/* Price visits [j, j + PRICE_CHUNK) into the pricer's buffer. */
static int price(mprt_replay *r, const pricer *pr, const mprt_trace_ray *rays, const mprt_trace_visit *v, size_t nv,
                 size_t j)
{
    char msg[256];
    size_t n = nv - j < PRICE_CHUNK ? nv - j : PRICE_CHUNK;
    mprt_trace_visit before;
    int rc;
    if (j) before = mprt__visit_at(v, j - 1);
    size_t i;
    rc = mprt__cost_range(pr->table, rays, pr->children, r->nr, pr->prim_kind, pr->nprims, v, j, n,
                          j ? before.ray : -1, j ? before.outcome : 0, pr->buf, pr->buf + PRICE_CHUNK,
                          pr->buf + 2 * PRICE_CHUNK, pr->flits ? pr->flits + j : pr->wide ? pr->tmp : NULL, msg,
                          sizeof msg);
    if (rc != MPRT_OK) return fail(r, rc, "cannot cost this trace: %s", msg);
    if (pr->wide)
        for (i = 0; i < n; i++) pr->wide[j + i] = pr->tmp[i];
    return MPRT_OK;
}

static int pack_visits(mprt_replay *r, const mprt_trace_ray *rays, const mprt_trace_visit *v, size_t nv,
                       const int64_t *process, const int64_t *receive, const int64_t *send, const pricer *pr,
                       pipe_t *pp)
{
    size_t j, nt = (size_t)r->ntrees;
    int64_t prev_t = -1, total = 0, *tc = NULL;
    const int64_t *cs = r->child_start, *cur = NULL;
    if (nv && !pr && (!process || !receive || !send)) return fail(r, MPRT_ERR_INVALID_ARG, "costs: missing array");
    r->wide = cs[r->nr] >= PACK_KID_LIMIT || RESERVE(r, vp, cap_vp, nv + 1);
    if ((r->wide && RESERVE(r, vi, cap_vi, nv + 1)) || RESERVE(r, tree_first, cap_tree, nt + 1) ||
        RESERVE(r, tree_cost, cap_tree9, 9 * nt + 1) || RESERVE(r, tree_pe, cap_tree_pe, nt + 1) ||
        RESERVE(r, tree_admit, cap_tree_admit, nt + 1))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %zu visits", nv);
    memset(r->tree_cost, 0, (9 * nt + 1) * sizeof *r->tree_cost);
    for (j = 0; j < nv; j++) {
        const mprt_trace_visit av = mprt__visit_at(v, j), *a = &av;
        int64_t ray = a->ray, t, p, x, y, c, next;
        int st = a->stage;
        if (pp) {
            size_t k = j % PIPE_BLOCK, s = j / PIPE_BLOCK % PIPE_SLOTS;
            if (k == 0) cur = pipe_take(pp, j / PIPE_BLOCK);
            if (j == pp->bad[s]) return fail(r, pp->rc[s], "cannot cost this trace: %s", pp->msg[s]);
            p = cur[k];
            x = cur[PIPE_BLOCK + k];
            y = cur[2 * PIPE_BLOCK + k];
        } else if (pr) {
            size_t k = j % PRICE_CHUNK;
            if (k == 0 && price(r, pr, rays, v, nv, j) != MPRT_OK) return MPRT_ERR_INVALID_ARG;
            p = pr->buf[k];
            x = pr->buf[PRICE_CHUNK + k];
            y = pr->buf[2 * PRICE_CHUNK + k];
        } else {
            p = process[j];
            x = receive[j];
            y = send[j];
        }
        if (ray < 0 || ray >= (int64_t)r->nr) return TRACE_FAIL(r, "a visit names a ray that does not exist");
        t = r->tree_of[ray];
        if (t != prev_t) {
            if (t != prev_t + 1)
                return TRACE_FAIL(r, "the visits of each primary ray's tree are not contiguous, in the primaries' "
                                     "order (traces made by mprt are)");
            if (mprt__ray_at(rays, (size_t)ray).kind != MPRT_RAY_PRIMARY) return TRACE_FAIL(r, "a tree's first visit is not its primary ray's");
            r->tree_first[t] = (int64_t)j;
            tc = r->tree_cost + 9 * t;
            prev_t = t;
        }
        if (j == 0 || mprt__visit_at(v, j - 1).ray != ray) {
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
        if (j + 1 < nv && mprt__visit_at(v, j + 1).ray == ray) {
            next = NEXT_VISIT | (int64_t)(mprt__visit_at(v, j + 1).stage & 3) << 2;
        } else if (st == MPRT_STAGE_SC && a->made > 0) {
            int64_t k = cs[ray + 1] - cs[ray];
            if (k != a->made)
                return TRACE_FAIL(r, "visit %zu made %d rays but %lld have it as parent", j, a->made, (long long)k);
            next = NEXT_CHILDREN | (int64_t)a->made << 2 | cs[ray] << 10;
        } else {
            next = NEXT_RETIRE;
        }
        if (!r->wide && p + c >= ((int64_t)1 << PACK_DUR_BITS) && widen(r, j))
            return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %zu visits", nv);
        if (r->wide) {
            r->vi[j].dur = p + c;
            r->vi[j].next = next;
        } else {
            r->vp[j] = packed(p + c, next);
        }
        tc[st] += p;
        tc[3 + st] += c;
        tc[6 + st]++;
    }
    if (prev_t != r->ntrees - 1) return TRACE_FAIL(r, "some primary rays have no visits");
    for (j = 0; j < r->nr; j++)
        if (r->ray_first[j] < 0) return TRACE_FAIL(r, "ray %zu has no visits", j);
    r->total = total;
    if (!r->wide) r->vp[nv] = 0;
    /* the rays made, as their first visits */
    for (j = 0; j < (size_t)cs[r->nr]; j++) r->child[j] = r->ray_first[r->child[j]];
    return MPRT_OK;
}

/* The visits packed, priced on a second thread when asked and worth it. */
static int prepare_visits(mprt_replay *r, const mprt_trace_ray *rays, const mprt_trace_visit *v, size_t nv,
                          const int64_t *process, const int64_t *receive, const int64_t *send, const pricer *pr)
{
    pipe_t pp;
    int rc;
    if (!pr || pr->threads < 2 || nv < 2 * PIPE_BLOCK || pipe_start(&pp, pr, rays, v, nv, r->nr))
        return pack_visits(r, rays, v, nv, process, receive, send, pr, NULL);
    rc = pack_visits(r, rays, v, nv, process, receive, send, pr, &pp);
    pipe_end(&pp);
    return rc;
}

void mprt__replay_free_trace(mprt_replay *r)
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
    free(r->pflits);
    free(r->child_kind);
    r->pflits = NULL;
    r->child_kind = NULL;
    r->cap_pflits = r->cap_child_kind = r->nchild = 0;
    r->flits_set = 0;
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

static int load(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits,
                size_t nvisits, const int64_t *process, const int64_t *receive, const int64_t *send,
                const pricer *pr)
{
    int rc;
    if (!r) return MPRT_ERR_INVALID_ARG;
    mprt__replay_free_run(r);
    mprt__replay_memory_free(r);     /* the memory data was the last trace's */
    r->errmsg[0] = '\0';
    r->loaded = r->flits_set = 0;
    r->loads++;
    r->ntrees = r->max_leaves = r->total = 0;
    if ((nrays && !rays) || (nvisits && !visits)) return fail(r, MPRT_ERR_INVALID_ARG, "rays or visits: missing");
    r->nv = nvisits;
    r->nr = nrays;
    rc = prepare_rays(r, rays, nrays);
    if (rc == MPRT_OK) rc = prepare_visits(r, rays, visits, nvisits, process, receive, send, pr);
    free_ray_arrays(r);
    if (rc != MPRT_OK) return rc;
    r->loaded = 1;
    return MPRT_OK;
}

int mprt_replay_load(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits,
                     size_t nvisits, const int64_t *process, const int64_t *receive, const int64_t *send)
{
    return load(r, rays, nrays, visits, nvisits, process, receive, send, NULL);
}

static int load_priced(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits,
                       size_t nvisits, const mprt_cost_table *table, const int64_t *children,
                       const int32_t *prim_kind, size_t nprims, int32_t *flits, int64_t *wide, int threads)
{
    pricer pr;
    int rc;
    if (!r) return MPRT_ERR_INVALID_ARG;
    if (!table || (nrays && !children) || (nprims && !prim_kind)) {
        mprt__replay_free_run(r);
        mprt__replay_memory_free(r);
        r->loaded = 0;
        return fail(r, MPRT_ERR_INVALID_ARG, "cannot cost this trace: a table or array is missing");
    }
    pr.table = table;
    pr.children = children;
    pr.prim_kind = prim_kind;
    pr.nprims = nprims;
    pr.flits = flits;
    pr.wide = wide;
    pr.threads = threads;
    pr.buf = malloc(3 * PRICE_CHUNK * sizeof *pr.buf);
    pr.tmp = wide ? malloc(PRICE_CHUNK * sizeof *pr.tmp) : NULL;
    if (!pr.buf || (wide && !pr.tmp)) {
        free(pr.buf);
        free(pr.tmp);
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the costs of %zu visits", PRICE_CHUNK);
    }
    rc = load(r, rays, nrays, visits, nvisits, NULL, NULL, NULL, &pr);
    free(pr.buf);
    free(pr.tmp);
    return rc;
}

int mprt_replay_load_priced(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits,
                            size_t nvisits, const mprt_cost_table *table, const int64_t *children,
                            const int32_t *prim_kind, size_t nprims, int32_t *flits)
{
    return load_priced(r, rays, nrays, visits, nvisits, table, children, prim_kind, nprims, flits, NULL, 1);
}

int mprt_replay_load_priced_threads(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays,
                                    const mprt_trace_visit *visits, size_t nvisits, const mprt_cost_table *table,
                                    const int64_t *children, const int32_t *prim_kind, size_t nprims, int64_t *flits,
                                    int threads)
{
    return load_priced(r, rays, nrays, visits, nvisits, table, children, prim_kind, nprims, NULL, flits, threads);
}
