/* grid.h: the voxel grid (internal).  Its 3DDDA walk is in dda.h. */
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
    int listing;       /* mprt_listing */
    int failed;
    int counted;       /* 1 once counted among the scene's grids (see mprt__scene_count_grid) */
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

#endif
