/* grid.h: the voxel grid and its 3DDDA walk (internal). */
#ifndef MPRT_GRID_H
#define MPRT_GRID_H

#include "mprt_internal.h"

#include <pthread.h>
#include <stdint.h>

struct mprt_grid {
    const mprt_scene *scene;
    int n[3];
    long long voxels;
    vec3 lo, hi, cell, inv_cell;
    real pad;          /* the walk clips rays to the box grown by pad */
    uint32_t *start;   /* voxels + 1 offsets into ids */
    uint8_t *flag;     /* per voxel: 1 when its list is not empty (the OS flag) */
    int32_t *ids;      /* primitive ids, voxel by voxel */
    long long refs;
    int failed;
    pthread_mutex_t errlock; /* renders may fail in several threads at once */
    char errmsg[MPRT__ERRMSG];
};

/* Record an error message on the grid (thread-safe); returns status. */
int mprt__grid_fail(mprt_grid *g, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Lower corner of voxel (i, j, k); i == n gives the upper boundary. */
vec3 mprt__grid_voxel_lo(const mprt_grid *g, int i, int j, int k);

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

/* Start a walk for ray over (tmin, tmax].  Returns 0 when the ray misses the
 * grid box within that range; otherwise the state holds the first voxel. */
int mprt__dda_start(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, mprt__dda *w);
/* Step to the next voxel; returns 0 when the walk has ended. */
int mprt__dda_next(const mprt_grid *g, mprt__dda *w);

#endif
