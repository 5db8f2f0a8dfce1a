/* packet.c: mprt_grid_intersect's rays walked four at a time (issue 21,
 * item 2(b)).  Four lanes each hold a ray of the batch; the 3DDDA's
 * voxel-by-voxel steps (dda.h, mprt__dda_seek's inner loop) are taken for
 * the four in lockstep, in AVX2 registers: per lane its own tnext, cells,
 * voxel id and step count, each step choosing that lane's axis with the same
 * comparisons (the lowest axis on ties) and adding the same tdelta, so each
 * lane's walk is its ray's walk to the bit.  When a lane comes to a voxel
 * with primitives (or one the walk may jump from), or its walk ends, the
 * loop stops and that lane goes on alone, in plain C, exactly as walk.h's
 * os_ic_walk goes on (its IC visit with its own mailbox, the jump, the next
 * step, the OS visits and their counts), and then either steps with the
 * lanes again or finishes its ray, the lane taking the batch's next ray.  The
 * other lanes keep their state.  So every ray makes the same visits, tests
 * and counts as alone; the counters are sums over rays and come out the same.
 *
 * What is shared is the stepping, not the tests: a voxel's triangles are
 * already tested four at a time per ray (ic_pack.h), so testing a voxel's
 * triangle against four rays at once does the same number of vector tests.
 *
 * Off by default: it measured 0.88-1.03x the one-ray walk on tetra, mount
 * and tree (studies/03_bench/README.md, issue 21 item 2(b)); each ray comes to
 * a voxel with primitives every 3 to 19 steps, and the lanes' loop stops for
 * any lane's, so it takes few steps per start.  MPRT_PACKETS=1 turns it on:
 * the AVX2 loop where this build and processor have it, else (or with
 * MPRT_PACKET_SIMD=0) the portable loop, the same steps lane by lane.  A
 * batch holding a ray the walk refuses goes one ray at a time (and fails as
 * before). */
#include "walk.h"

#include <stdlib.h>
#include <string.h>

#if defined(__GNUC__) && defined(__x86_64__) && !defined(MPRT_SINGLE)
#define PACKET_HAVE_AVX2 1
#include <immintrin.h>
#endif

#define LANES 4

/* The lanes' walks as the stepping loop holds them (structure of arrays):
 * per axis the crossing ahead, its spacing, the voxels left before the walk
 * leaves the grid, the change of the voxel id; the walk's end and voxel;
 * lane j steps while bit j of active is set. */
typedef struct {
    real tn[3][LANES], td[3][LANES], te[LANES];
    int64_t left[3][LANES], stride[3][LANES], voxel[LANES];
    unsigned active;
} lanes;

/* Step the active lanes, voxel by voxel, until one comes to a voxel that is
 * not plain (grid.h) or its walk ends: returns the mask of the first, sets
 * *ended to the second; those lanes leave active, their state (tn, left,
 * voxel) as mprt__dda_seek's inner loop leaves it. */
typedef unsigned (*lanes_run_fn)(lanes *S, const uint64_t *plain, unsigned *ended);

static unsigned run_portable(lanes *S, const uint64_t *plain, unsigned *ended)
{
    for (;;) {
        unsigned stop = 0, end = 0, j;
        for (j = 0; j < LANES; j++) {
            const int64_t v = S->voxel[j];
            real t0, t1, t2, ta;
            int a;
            if (!(S->active >> j & 1)) continue;
            if (!(plain[v >> 6] >> (v & 63) & 1)) {
                stop |= 1u << j;
                continue;
            }
            t0 = S->tn[0][j];
            t1 = S->tn[1][j];
            t2 = S->tn[2][j];
            a = t0 <= t1 && t0 <= t2 ? 0 : t1 <= t2 ? 1 : 2;
            ta = S->tn[a][j];
            if (ta >= S->te[j] || S->left[a][j] == 0) {
                end |= 1u << j;
                continue;
            }
            S->left[a][j]--;
            S->voxel[j] = v + S->stride[a][j];
            S->tn[a][j] = ta + S->td[a][j];
        }
        if (stop | end) {
            S->active &= ~(stop | end);
            *ended = end;
            return stop;
        }
    }
}

#ifdef PACKET_HAVE_AVX2
#define TARGET_AVX2 __attribute__((target("avx2")))

/* Each step is taken for every lane before its plain bit is known and
 * before its end is checked (the loads and checks are then off the chain
 * of steps, which is compare, blend, add) and undone for the lanes that
 * stop or end, when the loop stops.  A lane not active has tdelta and
 * stride 0 (lane_go): its steps change nothing that is read. */
TARGET_AVX2 static unsigned run_avx2(lanes *S, const uint64_t *plain, unsigned *ended)
{
    __m256d t0 = _mm256_loadu_pd(S->tn[0]), t1 = _mm256_loadu_pd(S->tn[1]), t2 = _mm256_loadu_pd(S->tn[2]);
    const __m256d d0 = _mm256_loadu_pd(S->td[0]), d1 = _mm256_loadu_pd(S->td[1]), d2 = _mm256_loadu_pd(S->td[2]);
    const __m256d te = _mm256_loadu_pd(S->te);
    __m256i k0 = _mm256_loadu_si256((const __m256i *)S->left[0]), k1 = _mm256_loadu_si256((const __m256i *)S->left[1]);
    __m256i k2 = _mm256_loadu_si256((const __m256i *)S->left[2]);
    const __m256i r0 = _mm256_loadu_si256((const __m256i *)S->stride[0]);
    const __m256i r1 = _mm256_loadu_si256((const __m256i *)S->stride[1]);
    const __m256i r2 = _mm256_loadu_si256((const __m256i *)S->stride[2]);
    const __m256i zero = _mm256_setzero_si256(), ones = _mm256_cmpeq_epi64(zero, zero);
    const unsigned active = S->active;
    __m256i v = _mm256_loadu_si256((const __m256i *)S->voxel);
    for (;;) {
        /* each lane's plain bit, by four loads (every lane's voxel is one of
         * the grid's; a gather measured slower) */
        int64_t vv[LANES];
        unsigned pm, sm, em;
        __m256d m0, m1, ta, n0, n1, n2;
        __m256i i0, i1, i2, ka, nk0, nk1, nk2, nv;
        _mm256_storeu_si256((__m256i *)vv, v);
        pm = (unsigned)(plain[vv[0] >> 6] >> (vv[0] & 63) & 1) | (unsigned)(plain[vv[1] >> 6] >> (vv[1] & 63) & 1) << 1 |
             (unsigned)(plain[vv[2] >> 6] >> (vv[2] & 63) & 1) << 2 | (unsigned)(plain[vv[3] >> 6] >> (vv[3] & 63) & 1) << 3;
        /* the axis each lane steps on: mprt__dda_seek's comparisons */
        m0 = _mm256_and_pd(_mm256_cmp_pd(t0, t1, _CMP_LE_OQ), _mm256_cmp_pd(t0, t2, _CMP_LE_OQ));
        m1 = _mm256_andnot_pd(m0, _mm256_cmp_pd(t1, t2, _CMP_LE_OQ));
        i0 = _mm256_castpd_si256(m0);
        i1 = _mm256_castpd_si256(m1);
        i2 = _mm256_andnot_si256(_mm256_or_si256(i0, i1), ones);
        ta = _mm256_blendv_pd(_mm256_blendv_pd(t2, t1, m1), t0, m0);
        ka = _mm256_blendv_epi8(_mm256_blendv_epi8(k2, k1, i1), k0, i0);
        n0 = _mm256_blendv_pd(t0, _mm256_add_pd(t0, d0), m0);
        n1 = _mm256_blendv_pd(t1, _mm256_add_pd(t1, d1), m1);
        n2 = _mm256_blendv_pd(t2, _mm256_add_pd(t2, d2), _mm256_castsi256_pd(i2));
        nk0 = _mm256_add_epi64(k0, i0);
        nk1 = _mm256_add_epi64(k1, i1);
        nk2 = _mm256_add_epi64(k2, i2);
        nv = _mm256_add_epi64(v, _mm256_or_si256(_mm256_or_si256(_mm256_and_si256(r0, i0), _mm256_and_si256(r1, i1)),
                                                 _mm256_and_si256(r2, i2)));
        /* lanes at a voxel that is not plain stop; the others' walks end at
         * a crossing past t_end, or out of the grid */
        sm = ~pm & active;
        em = (unsigned)_mm256_movemask_pd(_mm256_castsi256_pd(_mm256_or_si256(
                 _mm256_cmpeq_epi64(ka, zero), _mm256_castpd_si256(_mm256_cmp_pd(ta, te, _CMP_GE_OQ))))) &
             active & ~sm;
        if (sm | em) {
            /* the lanes that stop or end keep their state, the others step */
            const unsigned x = sm | em;
            const __m256i keep = _mm256_set_epi64x(-(int64_t)(x >> 3 & 1), -(int64_t)(x >> 2 & 1),
                                                   -(int64_t)(x >> 1 & 1), -(int64_t)(x & 1));
            const __m256d kd = _mm256_castsi256_pd(keep);
            _mm256_storeu_pd(S->tn[0], _mm256_blendv_pd(n0, t0, kd));
            _mm256_storeu_pd(S->tn[1], _mm256_blendv_pd(n1, t1, kd));
            _mm256_storeu_pd(S->tn[2], _mm256_blendv_pd(n2, t2, kd));
            _mm256_storeu_si256((__m256i *)S->left[0], _mm256_blendv_epi8(nk0, k0, keep));
            _mm256_storeu_si256((__m256i *)S->left[1], _mm256_blendv_epi8(nk1, k1, keep));
            _mm256_storeu_si256((__m256i *)S->left[2], _mm256_blendv_epi8(nk2, k2, keep));
            _mm256_storeu_si256((__m256i *)S->voxel, _mm256_blendv_epi8(nv, v, keep));
            S->active &= ~x;
            *ended = em;
            return sm;
        }
        t0 = n0;
        t1 = n1;
        t2 = n2;
        k0 = nk0;
        k1 = nk1;
        k2 = nk2;
        v = nv;
    }
}

static lanes_run_fn run_avx2_chosen(void)
{
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") ? run_avx2 : NULL;
}
#else
static lanes_run_fn run_avx2_chosen(void) { return NULL; }
#endif

/* ---- One lane's ray, as os_ic_walk (walk.h) walks it ------------------------------- */

typedef struct {
    mprt__ray ray;
    mprt__dda w;
    mprt__hit best;
    mailbox mb;
    real dd;
    int32_t steps;   /* voxels entered since OS last had the ray */
    size_t i;        /* the ray's index in the batch */
} lane;

typedef struct {
    const mprt_grid *g;
    size_t n, next;
    const double *org, *dir;
    double *t;
    int32_t *prim;
    mprt__sink *sink;
} batch;

/* The lane takes the batch's next ray whose walk starts (the others miss the
 * grid: their one OS visit and no hit); 0 when none is left. */
static int lane_take(batch *b, lane *L)
{
    while (b->next < b->n) {
        const size_t i = b->next++;
        const double *o = b->org + 3 * i, *d = b->dir + 3 * i;
        mprt__ray_prepare(&L->ray, v3((real)o[0], (real)o[1], (real)o[2]), v3((real)d[0], (real)d[1], (real)d[2]));
        L->dd = vdot(L->ray.d, L->ray.d);
        L->best.t = (real)INFINITY;
        L->best.prim = -1;
        L->i = i;
        if (!mprt__dda_start(b->g, &L->ray, 0, (real)INFINITY, &L->w)) {
            emit_os(b->sink, 0, MPRT__RAY_QUERY, MPRT_OUT_LEFT, 0, -1, -1, 0);
            b->t[i] = INFINITY;
            b->prim[i] = -1;
            continue;
        }
        memset(&L->mb, 0xff, sizeof L->mb); /* -1: no primitive */
        L->steps = 1;
        return 1;
    }
    return 0;
}

/* Lane j's walk as mprt__dda_seek's inner loop leaves it, from the lanes:
 * the voxels entered are the cells crossed on the three axes.  (t_enter
 * is left as it was: the walk sets it before it reads it again.) */
static void lane_pull(const mprt_grid *g, const lanes *S, unsigned j, lane *L, int found)
{
    mprt__dda *w = &L->w;
    int a;
    for (a = 0; a < 3; a++) {
        const int64_t cell = w->step[a] > 0 ? g->n[a] - 1 - S->left[a][j] : S->left[a][j];
        L->steps += (int32_t)(cell > w->cell[a] ? cell - w->cell[a] : w->cell[a] - cell);
        w->cell[a] = (int)cell;
        w->tnext[a] = S->tn[a][j];
    }
    if (!found) return; /* the walk ended: its state is not used again */
    if (w->voxel != S->voxel[j]) {
        const real te = w->t_end, ts = w->t_start;
        real t = mprt__min3(w->tnext[0], w->tnext[1], w->tnext[2]);
        if (t > te) t = te;
        w->t_exit = t < ts ? ts : t;
    }
    w->voxel = S->voxel[j];
}

/* ... and into the lanes, to step from its current voxel. */
static void lane_push(const mprt_grid *g, lanes *S, unsigned j, const lane *L)
{
    const mprt__dda *w = &L->w;
    int a;
    for (a = 0; a < 3; a++) {
        S->tn[a][j] = w->tnext[a];
        S->td[a][j] = w->tdelta[a];
        S->left[a][j] = w->step[a] > 0 ? g->n[a] - 1 - w->cell[a] : w->cell[a];
        S->stride[a][j] = w->stride[a];
    }
    S->te[j] = w->t_end;
    S->voxel[j] = w->voxel;
    S->active |= 1u << j;
}

enum { LANE_FOUND, LANE_END, LANE_NEW, LANE_SEEK };

/* Lane j goes on alone from the outcome of its seek (LANE_FOUND: a voxel
 * with primitives; LANE_END: its walk ended; LANE_NEW: it has no ray) until
 * it is to step with the lanes again, or the batch has no rays left. */
static void lane_go(batch *b, lanes *S, unsigned j, lane *L, int state)
{
    const mprt_grid *g = b->g;
    mprt__sink *sink = b->sink;
    for (;;) {
        if (state == LANE_FOUND) {
            /* OS hands the ray to IC */
            mprt__visit ic;
            int accepted;
            emit_os(sink, 0, MPRT__RAY_QUERY, MPRT_OUT_TO_IC, L->steps, L->w.voxel, -1, 0);
            mprt__visit_init(&ic, 0, MPRT__RAY_QUERY, MPRT_STAGE_IC, MPRT_OUT_RETURN);
            ic.voxel_id = L->w.voxel;
            accepted = ic_visit(g, L->w.voxel, L->w.t_exit, &L->ray, L->dd, 0, (real)INFINITY, 0, 0, &L->best, &L->mb,
                                &ic, sink);
            if (accepted) {
                ic.outcome = MPRT_OUT_HIT;
                ic.prim = L->best.prim;
            }
            mprt__emit_visit_as(sink, &ic, 0);
            if (accepted) {
                b->t[L->i] = (double)L->best.t;
                b->prim[L->i] = L->best.prim;
                state = LANE_NEW;
            } else {
                /* a return ray: back to OS, which walks on */
                L->steps = 0;
                if (mprt__dda_next(g, &L->w)) {
                    L->steps++;
                    state = LANE_SEEK;
                } else {
                    state = LANE_END;
                }
            }
        }
        if (state == LANE_END) {
            /* the nearest candidate, even past the last stretch (os_ic_walk) */
            if (L->best.prim >= 0) {
                emit_os(sink, 0, MPRT__RAY_QUERY, MPRT_OUT_LATE_HIT, L->steps, -1, L->best.prim, 0);
                b->t[L->i] = (double)L->best.t;
                b->prim[L->i] = L->best.prim;
            } else {
                emit_os(sink, 0, MPRT__RAY_QUERY, MPRT_OUT_LEFT, L->steps, -1, -1, 0);
                b->t[L->i] = INFINITY;
                b->prim[L->i] = -1;
            }
            state = LANE_NEW;
        }
        if (state == LANE_NEW && !lane_take(b, L)) {
            /* no rays left: the lane's steps (run_avx2) change nothing */
            int a;
            for (a = 0; a < 3; a++) {
                S->td[a][j] = 0;
                S->stride[a][j] = 0;
            }
            return;
        }
        /* LANE_SEEK: mprt__dda_seek from the current voxel; its first check
         * here, and the voxel-by-voxel steps with the lanes, but from a voxel
         * that is not plain (one with primitives, or one to jump from) */
        {
            const long long v = L->w.voxel;
            if (L->w.t_exit >= L->w.t_end) {
                state = g->empty[v] == 0 ? LANE_FOUND : LANE_END;
            } else if (!(g->plain[v >> 6] >> (v & 63) & 1)) {
                state = g->empty[v] == 0 || mprt__dda_seek(g, &L->w, &L->steps) ? LANE_FOUND : LANE_END;
            } else {
                lane_push(g, S, j, L);
                return;
            }
        }
    }
}

/* The whole batch, LANES rays at a time. */
static void intersect_lanes(batch *b, lanes_run_fn run)
{
    lanes S;
    lane L[LANES];
    unsigned j;
    const mprt_grid *g = b->g;
    memset(&S, 0, sizeof S);
    for (j = 0; j < LANES; j++) lane_go(b, &S, j, &L[j], LANE_NEW);
    while (S.active) {
        unsigned ended = 0, found = run(&S, g->plain, &ended);
        for (j = 0; j < LANES; j++) {
            if ((found | ended) >> j & 1) {
                const int f = (int)(found >> j & 1);
                int state = LANE_END;
                lane_pull(g, &S, j, &L[j], f);
                /* a voxel with primitives; or one the walk may jump from (only with
                 * MPRT_SKIP or MPRT_JUMP_MIN): mprt__dda_seek goes on from it */
                if (f) state = g->empty[L[j].w.voxel] == 0 || mprt__dda_seek(g, &L[j].w, &L[j].steps) ? LANE_FOUND : LANE_END;
                lane_go(b, &S, j, &L[j], state);
            }
        }
    }
}

/* Whether environment variable name is set to "0" (off), or to "1" (on). */
static int env_is(const char *name, const char *value)
{
    const char *v = getenv(name);
    return v && strcmp(v, value) == 0;
}

int mprt__intersect_packets(const mprt_grid *g, size_t n, const double *org, const double *dir, double *t,
                            int32_t *prim, mprt__sink *sink)
{
    lanes_run_fn run;
    batch b;
    if (n < 2 || !env_is("MPRT_PACKETS", "1")) return 0;
    run = env_is("MPRT_PACKET_SIMD", "0") ? NULL : run_avx2_chosen();
    if (!run) run = run_portable;
    b.g = g;
    b.n = n;
    b.next = 0;
    b.org = org;
    b.dir = dir;
    b.t = t;
    b.prim = prim;
    b.sink = sink;
    intersect_lanes(&b, run);
    return 1;
}
