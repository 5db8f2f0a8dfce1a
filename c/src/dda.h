/* dda.h: the 3DDDA walk through the voxel grid (internal): the OS stage's
 * traversal (Amanatides & Woo).  Its functions are static inline because the
 * OS loop (pipeline.c) runs them for every voxel a ray enters. */
#ifndef MPRT_DDA_H
#define MPRT_DDA_H

#include "grid.h"

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
    }
    w->t_enter = t0;
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

#endif
