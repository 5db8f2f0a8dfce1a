/* grid.h: the voxel grid (internal).  Its 3DDDA walk is in dda.h. */
#ifndef MPRT_GRID_H
#define MPRT_GRID_H

#include "ic.h"
#include "ic_pack.h"
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
    uint8_t *empty;    /* per voxel: 0 when its list is not empty (the OS flag is
                        * empty == 0); 1 when empty; k >= 2 when empty and so is
                        * every macro cell within k - 2 of the voxel's own (chessboard
                        * distance in macro cells): the walk may jump that block */
    uint64_t *plain;   /* per voxel one bit (voxel v: bit v % 64 of word v / 64): set when the
                        * voxel is empty and the walk does not jump from it (0 < empty <
                        * jump_min); the walk's inner loop reads these 1/8-size bits
                        * (dda.c, mprt__dda_plain) instead of the bytes of empty */
    int macro[3];      /* voxels per macro cell on each axis: about cubic macro cells */
    int *macro_lo[3];  /* per axis, per voxel index: the first index of its macro cell */
    unsigned jump_min; /* the walk jumps from voxels whose empty value is at least this
                        * (dda.h); above 255 (the default, unless the environment held
                        * MPRT_SKIP or MPRT_JUMP_MIN when the grid was made): never, voxel
                        * by voxel, and empty is never above 1 */
    int jump_far;      /* ... and only once the walk is this many voxels from the ray's
                        * origin on every axis (runs of the walk's sums are short before) */
    int32_t *ids;      /* primitive ids, voxel by voxel */
    mprt__ic ic;       /* the primitives as IC tests them (ic.h) */
    mprt__ic_pack pack; /* ... and its tests several at a time (ic_pack.h) */
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

/* mprt_grid_create_listing built the plain way, voxel by voxel, kept as the
 * reference the faster build must match bit for bit (tests/c/test_grid_build.c). */
int mprt__grid_create_reference(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing,
                                mprt_grid **out);

/* Lower corner of voxel (i, j, k); i == n gives the upper boundary. */
vec3 mprt__grid_voxel_lo(const mprt_grid *g, int i, int j, int k);

/* Chessboard (L-infinity) distance in cells to the nearest cell holding 0,
 * over an n[0] x n[1] x n[2] array of cells (x fastest) holding 0 or 255,
 * capped at 255.  MPRT_ERR_OUT_OF_MEMORY when scratch memory runs out. */
int mprt__chessboard_distance(const int n[3], uint8_t *d);

/* Fill g->plain from g->empty and g->jump_min (dda.c); MPRT_ERR_OUT_OF_MEMORY
 * when it cannot be allocated. */
int mprt__dda_plain(mprt_grid *g);

#endif
