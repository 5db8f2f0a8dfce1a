/* dda.h: the 3DDDA walk through the voxel grid (internal): the OS stage's
 * traversal (Amanatides & Woo), and its jumps over empty space.  Its
 * functions are static inline because the OS loop (pipeline.c) runs them
 * for every voxel a ray enters.
 *
 * On each axis the t at which the ray leaves its current voxel is summed up
 * voxel by voxel (tnext += tdelta), and each step takes the axis whose
 * boundary comes first, the lowest axis on ties.  The walk is therefore the
 * merge of three sequences of crossings, each depending on its own axis
 * alone, so the crossings taken across a block of empty voxels can be
 * found axis by axis, without the three-way choice at every voxel, and the
 * sums themselves in closed form (runs, below): mprt__dda_jump crosses a
 * block of empty voxels in one go and ends in exactly the state, with
 * exactly the voxel count, of the step-by-step walk (tests/c/test_skip.c
 * compares the two; tests/test_skip.py whole traces).  mprt__dda_seek is the
 * OS loop: voxel by voxel, or by jumps where the grid marks large empty
 * blocks (grid.h, empty and jump_min). */
#ifndef MPRT_DDA_H
#define MPRT_DDA_H

#include "grid.h"

#include <stdint.h>
#include <string.h>

/* State of one 3DDDA walk (Amanatides & Woo).  The walk visits voxels in ray
 * order; voxel k covers the ray stretch [t_enter, t_exit], and consecutive
 * stretches share their boundary value, so the stretches tile the ray's
 * part inside the grid without gaps whatever the rounding. */
typedef struct {
    int cell[3];       /* current voxel */
    int step[3];       /* +1 or -1 per axis */
    long long stride[3]; /* change of the linear voxel id per step on each axis */
    real tnext[3];     /* t at which the ray crosses the next boundary per axis */
    real tdelta[3];    /* t between boundaries per axis */
    real run_inc[3];   /* per axis, a run of the sums (below): what each addition adds */
    real run_last[3];  /* ... and the largest sum from which an addition still adds it (-inf: none yet) */
    real run_rinc[3];  /* ... and 1 / run_inc (0 when run_inc is 0) */
    real t_jump;       /* no jumps before the crossings reach this t (runs are short there) */
    real t_start;      /* where the walk starts: the first voxel's t_enter */
    real t_enter;      /* start of the current voxel's stretch */
    real t_exit;       /* end of the current voxel's stretch */
    real t_end;        /* where the walk stops: min(ray tmax, grid exit) */
    long long voxel;   /* linear id of the current voxel */
} mprt__dda;

/* Lower boundary i on axis a. */
static inline real mprt__dda_boundary(const mprt_grid *g, int a, int i)
{
    return vget(g->lo, a) + (real)i * vget(g->cell, a);
}

/* Start a walk for ray over (tmin, tmax].  Returns 0 when the ray misses the
 * grid box within that range; otherwise the state holds the first voxel. */
static inline int mprt__dda_start(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, mprt__dda *w)
{
    real t0 = tmin, t1 = tmax, o[3], d[3], inv[3];
    int a;
    o[0] = ray->o.x; o[1] = ray->o.y; o[2] = ray->o.z;
    d[0] = ray->d.x; d[1] = ray->d.y; d[2] = ray->d.z;
    inv[0] = ray->inv.x; inv[1] = ray->inv.y; inv[2] = ray->inv.z;
    /* Clip the ray to the grid box, grown by pad (slabs) */
    for (a = 0; a < 3; a++) {
        real lo = vget(g->lo, a) - g->pad, hi = vget(g->hi, a) + g->pad;
        if (d[a] == 0) {
            if (!(o[a] >= lo && o[a] <= hi)) return 0;
            continue;
        }
        {
            real ta = (lo - o[a]) * inv[a], tb = (hi - o[a]) * inv[a];
            if (ta > tb) { real tmp = ta; ta = tb; tb = tmp; }
            if (ta > t0) t0 = ta;
            if (tb < t1) t1 = tb;
        }
    }
    if (!(t0 <= t1)) return 0;
    /* First voxel: the cell holding the entry point; then per axis the
     * first boundary crossing and the spacing of the following ones */
    w->voxel = 0;
    for (a = 0; a < 3; a++) {
        real entry = o[a] + t0 * d[a];
        real cells = (entry - vget(g->lo, a)) * vget(g->inv_cell, a); /* from the low face, in voxels */
        int cell = cells > 0 ? (cells >= (real)g->n[a] ? g->n[a] - 1 : (int)cells) : 0;
        long long stride = a == 0 ? 1 : a == 1 ? g->n[0] : (long long)g->n[0] * g->n[1];
        w->cell[a] = cell;
        w->voxel += cell * stride;
        if (d[a] == 0) {
            w->step[a] = 1;
            w->tnext[a] = (real)INFINITY;
            w->tdelta[a] = (real)INFINITY;
        } else {
            w->step[a] = d[a] < 0 ? -1 : 1;
            w->tnext[a] = (mprt__dda_boundary(g, a, cell + (d[a] > 0)) - o[a]) * inv[a];
            w->tdelta[a] = vget(g->cell, a) * (inv[a] < 0 ? -inv[a] : inv[a]);
        }
        w->stride[a] = w->step[a] * stride;
        w->run_last[a] = -(real)INFINITY;
    }
    w->t_start = w->t_enter = t0;
    /* A run holds about s / d additions of d to s: jump once the crossings
     * are jump_far voxels out on every axis */
    {
        real far = 0;
        for (a = 0; a < 3; a++)
            if (w->tdelta[a] != (real)INFINITY && w->tdelta[a] > far) far = w->tdelta[a];
        w->t_jump = far * (real)g->jump_far;
    }
    w->t_end = t1;
    w->t_exit = w->tnext[0] < w->tnext[1] ? (w->tnext[0] < w->tnext[2] ? w->tnext[0] : w->tnext[2])
                                          : (w->tnext[1] < w->tnext[2] ? w->tnext[1] : w->tnext[2]);
    if (w->t_exit > t1) w->t_exit = t1;
    if (w->t_exit < t0) w->t_exit = t0;
    return 1;
}

/* The smallest of three. */
static inline real mprt__min3(real a, real b, real c) { return a < b ? (a < c ? a : c) : (b < c ? b : c); }

/* One step of the walk: the axis whose boundary comes first (the lowest
 * axis on ties, so a ray through an edge or corner visits the voxels that
 * only touch it, one axis at a time); returns 0 when the walk has ended.
 * Written with constant indices so the state can live in registers. */
static inline int mprt__dda_next(const mprt_grid *g, mprt__dda *w)
{
    real t;
    if (w->t_exit >= w->t_end) return 0;
    if (w->tnext[0] <= w->tnext[1] && w->tnext[0] <= w->tnext[2]) {
        w->cell[0] += w->step[0];
        if ((unsigned)w->cell[0] >= (unsigned)g->n[0]) return 0;
        w->voxel += w->stride[0];
        w->tnext[0] += w->tdelta[0];
    } else if (w->tnext[1] <= w->tnext[2]) {
        w->cell[1] += w->step[1];
        if ((unsigned)w->cell[1] >= (unsigned)g->n[1]) return 0;
        w->voxel += w->stride[1];
        w->tnext[1] += w->tdelta[1];
    } else {
        w->cell[2] += w->step[2];
        if ((unsigned)w->cell[2] >= (unsigned)g->n[2]) return 0;
        w->voxel += w->stride[2];
        w->tnext[2] += w->tdelta[2];
    }
    /* The new stretch starts where the old one ended */
    w->t_enter = w->t_exit;
    t = mprt__min3(w->tnext[0], w->tnext[1], w->tnext[2]);
    if (t > w->t_end) t = w->t_end;
    w->t_exit = t < w->t_enter ? w->t_enter : t;
    return 1;
}

/* ---- The walk's sums in closed form ------------------------------------
 * On one axis the walk's crossings are s, s (+) d, (s (+) d) (+) d, ...
 * with (+) the rounded addition.  While the sums stay in one binade
 * [2^e, 2^(e+1)) of ulp u (and d <= s), s + d lies in it too, so it rounds
 * to the nearest multiple of u: each addition adds d rounded to a multiple
 * of u, the same amount every time, and a run of additions is one
 * multiplication, exact.  A tie (d an odd number of half ulps) goes to the
 * even significand: from an even significand on, every addition then adds
 * the even one of the two neighbouring multiples.  Anything else (a sum
 * below d, an odd significand at a tie, the addition that leaves the
 * binade) is made as the walk makes it. */

#ifdef MPRT_SINGLE
#define MPRT__MANT 24 /* bits of a real's significand */
#else
#define MPRT__MANT 53
#endif

/* A run of additions from s that each add exactly inc. */
typedef struct {
    real inc;
    real last;             /* the largest sum from which an addition stays in the run */
    long long m, q, delta; /* s / u, floor(d / u) and inc / u */
} mprt__run;

/* Start a run at s; 0 when the next addition must be made as it is. */
static inline int mprt__run_start(real s, real d, mprt__run *r)
{
    double sd = (double)s, u, iu, x, q;
    uint64_t b;
    long long e;
    if (!(s >= d && d > 0 && sd < 1e300)) return 0;
    memcpy(&b, &sd, sizeof b);
    e = (long long)(b >> 52); /* biased exponent (s > 0) */
    if (e < 256) return 0;    /* tiny sums: no runs */
    b = (uint64_t)(e - (MPRT__MANT - 1)) << 52;
    memcpy(&u, &b, sizeof u);
    b = (uint64_t)(2046 - e + (MPRT__MANT - 1)) << 52;
    memcpy(&iu, &b, sizeof iu);
    x = (double)d * iu;         /* d / u, exact */
    q = (double)(long long)x;   /* its floor (x >= 0) */
    r->m = (long long)(sd * iu);
    r->q = (long long)q;
    x -= q;
    if (x < 0.5)
        r->delta = r->q;
    else if (x > 0.5)
        r->delta = r->q + 1;
    else if (r->m & 1)
        return 0;
    else
        r->delta = r->q + (r->q & 1);
    r->inc = (real)((double)r->delta * u);
    /* an addition from m ulps stays in the binade while m + q + 1 <= 2^MANT */
    r->last = (real)((double)((1LL << MPRT__MANT) - r->q - 1) * u);
    return 1;
}

/* How many of the next additions on axis a (at most `most`) the cached run
 * covers exactly, refreshing the run when the sum has passed its end; the
 * sums after k <= that many additions are tnext[a] + k run_inc[a].  The
 * run stays valid as the walk sums on: within it every addition adds
 * run_inc, and its sums only grow. */
static inline int mprt__dda_run(mprt__dda *w, int a, int most)
{
    const real s = w->tnext[a];
    real inc;
    int k;
    if (!(s <= w->run_last[a])) {
        mprt__run r;
        if (!mprt__run_start(s, w->tdelta[a], &r)) return 0;
        w->run_inc[a] = r.inc;
        w->run_last[a] = r.last;
        w->run_rinc[a] = r.inc > 0 ? 1 / r.inc : 0;
        if (!(s <= r.last)) return 0;
    }
    inc = w->run_inc[a];
    if (inc == 0) return most;
    /* additions from the sums up to run_last: k with s + (k - 1) inc <= run_last */
    {
        real e = (w->run_last[a] - s) * w->run_rinc[a];
        k = e >= (real)most ? most : (int)e + 1;
    }
    while (k > 0 && !(s + (real)(k - 1) * inc <= w->run_last[a])) k--;
    return k;
}

/* Crossings on axis a the walk takes before the event at t == lim (with
 * inclusive: ties count as before it), out of the at most `most` ahead, all
 * in the cached run; the axis's tnext and cell move past them. */
static inline int mprt__dda_take(mprt__dda *w, int a, int most, real lim, int inclusive)
{
    const real s = w->tnext[a], inc = w->run_inc[a];
    int k;
    if (most == 0) return 0;
    /* the first k whose sum is not before lim: estimated, then settled */
#define MPRT__BEFORE(x) (inclusive ? (x) <= lim : (x) < lim)
    if (inc == 0) {
        k = MPRT__BEFORE(s) ? most : 0;
    } else {
        real e = (lim - s) * w->run_rinc[a];
        k = !(e < (real)most) ? most : e < 0 ? 0 : (int)e;
        while (k < most && MPRT__BEFORE(s + (real)k * inc)) k++;
        while (k > 0 && !MPRT__BEFORE(s + (real)(k - 1) * inc)) k--;
    }
#undef MPRT__BEFORE
    w->tnext[a] = s + (real)k * inc;
    w->cell[a] += w->step[a] * k;
    return k;
}

/* The block of empty voxels the walk may jump from its current voxel,
 * whose empty value (grid.h) is k >= 2: the macro cells within k - 2 of
 * the voxel's own, clipped to the grid; last[a] is the block's last voxel
 * index on axis a in the ray's direction along it. */
static inline void mprt__dda_block(const mprt_grid *g, const mprt__dda *w, unsigned k, int last[3])
{
    int a;
    for (a = 0; a < 3; a++) {
        int m = g->macro[a], base = g->macro_lo[a][w->cell[a]], c;
        if (w->step[a] > 0) {
            c = base + ((int)k - 1) * m - 1;
            last[a] = c < g->n[a] ? c : g->n[a] - 1;
        } else {
            c = base - ((int)k - 2) * m;
            last[a] = c > 0 ? c : 0;
        }
    }
}

/* Leave a block of voxels about the current one, which the caller knows to
 * be empty, as the step-by-step walk would: the block's last voxel on axis
 * a in the ray's direction is last[a].  The walk leaves the block at the
 * first of the three crossings out of it, the lowest axis on ties, and on
 * each other axis it takes every crossing that comes before that one.  Adds
 * the voxels entered to *steps.  Returns 1 with the state at the first
 * voxel past the block, 0 when the walk ends in it (at t_end) or by leaving
 * the grid. */
static inline int mprt__dda_jump(const mprt_grid *g, mprt__dda *w, const int last[3], int32_t *steps)
{
    int a, ax, most[3], taken = 0;
    real out[3], t;
    if (w->t_exit >= w->t_end) return 0;
    /* Per axis, the crossing out of the block, `most` crossings ahead; the
     * block shrinks on an axis to the crossings its cached run covers (none
     * when there is no run: the block is then the current voxel's slab) */
    for (a = 0; a < 3; a++) {
        if (w->tdelta[a] == (real)INFINITY) {
            most[a] = 0;
            out[a] = (real)INFINITY;
            continue;
        }
        most[a] = mprt__dda_run(w, a, (last[a] - w->cell[a]) * w->step[a]);
        out[a] = most[a] == 0 ? w->tnext[a] : w->tnext[a] + (real)most[a] * w->run_inc[a];
    }
    ax = out[0] <= out[1] && out[0] <= out[2] ? 0 : out[1] <= out[2] ? 1 : 2;
    if (out[ax] >= w->t_end) {
        /* The walk ends in the block: it takes every crossing before t_end */
        for (a = 0; a < 3; a++) *steps += mprt__dda_take(w, a, most[a], w->t_end, 0);
        return 0;
    }
    for (a = 0; a < 3; a++)
        if (a != ax) taken += mprt__dda_take(w, a, most[a], out[ax], a < ax);
    /* and on the axis out: its crossings in the block, then the one out of it */
    w->cell[ax] += w->step[ax] * (most[ax] + 1);
    *steps += taken + most[ax];
    if ((unsigned)w->cell[ax] >= (unsigned)g->n[ax]) return 0; /* leaving the grid enters no voxel */
    ++*steps;
    w->tnext[ax] = out[ax] + w->tdelta[ax];
    w->voxel = w->cell[0] + (long long)g->n[0] * (w->cell[1] + (long long)g->n[1] * w->cell[2]);
    /* The stretch starts where the one before ended (dda_next's rule) */
    t = out[ax] < w->t_end ? out[ax] : w->t_end;
    w->t_enter = t < w->t_exit ? w->t_exit : t;
    t = mprt__min3(w->tnext[0], w->tnext[1], w->tnext[2]);
    if (t > w->t_end) t = w->t_end;
    w->t_exit = t < w->t_enter ? w->t_enter : t;
    return 1;
}

/* Walk on from the current voxel to the first voxel that holds primitives,
 * the current one included: returns 1 with the state at it, or 0 when the
 * walk ends first; adds the voxels entered to *steps.  The voxel-by-voxel
 * part keeps its state in locals: it is the walk's inner loop.  A stretch
 * ends at max(t_start, min(first crossing ahead, t_end)), the value
 * mprt__dda_next's running maximum reaches, since the crossing ahead never
 * decreases. */
static inline int mprt__dda_seek(const mprt_grid *g, mprt__dda *w, int32_t *steps)
{
    const uint8_t *empty = g->empty;
    const uint64_t *plain = g->plain;
    const real te = w->t_end, ts = w->t_start;
    const unsigned n0 = (unsigned)g->n[0], n1 = (unsigned)g->n[1], n2 = (unsigned)g->n[2];
    for (;;) {
        real t0 = w->tnext[0], t1 = w->tnext[1], t2 = w->tnext[2], last = 0;
        int c0 = w->cell[0], c1 = w->cell[1], c2 = w->cell[2];
        long long v = w->voxel;
        int32_t n = 0;
        unsigned e = 0;
        if (w->t_exit >= te) return empty[v] == 0;
        /* voxel by voxel while the voxels are empty and no jump pays: through
         * plain voxels (grid.h), and through those a jump may start from while
         * the walk is still near the ray's origin */
        for (;;) {
            if (!(plain[v >> 6] >> (v & 63) & 1) &&
                ((e = empty[v]) == 0 || !(mprt__min3(t0, t1, t2) < w->t_jump)))
                break;
            if (t0 <= t1 && t0 <= t2) {
                last = t0;
                if (t0 >= te || (unsigned)(c0 += w->step[0]) >= n0) goto ended;
                v += w->stride[0];
                t0 += w->tdelta[0];
            } else if (t1 <= t2) {
                last = t1;
                if (t1 >= te || (unsigned)(c1 += w->step[1]) >= n1) goto ended;
                v += w->stride[1];
                t1 += w->tdelta[1];
            } else {
                last = t2;
                if (t2 >= te || (unsigned)(c2 += w->step[2]) >= n2) goto ended;
                v += w->stride[2];
                t2 += w->tdelta[2];
            }
            n++;
        }
        *steps += n;
        w->tnext[0] = t0;
        w->tnext[1] = t1;
        w->tnext[2] = t2;
        w->cell[0] = c0;
        w->cell[1] = c1;
        w->cell[2] = c2;
        w->voxel = v;
        if (n > 0) {
            real t = last < te ? last : te;
            w->t_enter = t < ts ? ts : t;
            t = mprt__min3(t0, t1, t2);
            if (t > te) t = te;
            w->t_exit = t < ts ? ts : t;
        }
        if (e == 0) return 1;
        {
            /* the empty block about this voxel in one go */
            int lastc[3];
            mprt__dda_block(g, w, e, lastc);
            if (!mprt__dda_jump(g, w, lastc, steps)) return 0;
        }
        continue;
    ended: /* the walk ends in the voxel it is in */
        *steps += n;
        return 0;
    }
}

#endif
