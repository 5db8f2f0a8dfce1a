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

/* A failure while building: the grid is unusable (failed set); the message
 * recorded; returns status. */
#define mprt__grid_build_fail(g, ...) ((g)->failed = 1, mprt__grid_fail((g), __VA_ARGS__))

/* ---- The build's stages (grid.c), and the parts of them a stage may use ----
 * tests/c/grid_reference.c builds grids with stages of its own, written
 * plainly, that the library's must match bit for bit (test_grid_build.c). */

/* (voxel, primitive) pairs, filled while testing, then sorted by voxel. */
typedef struct {
    uint32_t *vox;
    int32_t *prim;
    size_t n, cap;
} mprt__pairs;

/* A distance transform as mprt__chessboard_distance's. */
typedef int (*mprt__distance_fn)(const int n[3], uint8_t *d);

/* A build's stages; a NULL one is the library's own.  list: the pairs
 * (at most pair_limit; max_bytes names the limit in the error);
 * sort: the lists in voxel order (start, ids, refs) and the empty flags 0
 * (the voxel holds primitives) or 1; distance: the transform the jumps
 * mark with (mprt__grid_mark_jumps).  Each returns MPRT_OK or fails the
 * grid (mprt__grid_build_fail). */
typedef struct {
    int (*list)(mprt_grid *g, mprt__pairs *P, size_t pair_limit, size_t max_bytes);
    int (*sort)(mprt_grid *g, const mprt__pairs *P);
    mprt__distance_fn distance;
} mprt__grid_stages;

/* mprt_grid_create_listing with the stages given (NULL: the library's own). */
int mprt__grid_create_stages(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing,
                             const mprt__grid_stages *stages, mprt_grid **out);

/* Surface of primitive i may touch the box [lo, hi]: 1 yes, 0 no, -1 for a
 * primitive of unknown kind. */
int mprt__grid_prim_box(const mprt_scene *s, long long i, vec3 lo, vec3 hi);

/* The voxel range [a0, a1] primitive i's bounds touch, grown by the margin
 * (on MPRT_LIST_BOX_OUTWARD one voxel more on each axis's high side); and
 * per axis whether its voxel boxes shrink by the margin (MPRT_LIST_OCCUPIED,
 * on an axis along which the primitive is thicker than twice the margin and
 * the voxels thicker than four times it) or grow by it (otherwise). */
int mprt__grid_prim_range(mprt_grid *g, long long i, int a0[3], int a1[3], int shrink[3]);

/* Whether the listing tests each primitive's surface against the voxels
 * (else every voxel of its bounds' range lists it). */
static inline int mprt__grid_listing_tests(const mprt_grid *g)
{
    return g->listing == MPRT_LIST_EXACT || g->listing == MPRT_LIST_OCCUPIED;
}

/* Add the pair (voxel x, y, z; primitive i), or fail the grid when the pairs
 * would pass pair_limit (max_bytes in the message) or memory runs out. */
int mprt__grid_push(mprt_grid *g, mprt__pairs *P, int x, int y, int z, long long i, size_t pair_limit,
                    size_t max_bytes);

/* Lower corner of voxel (i, j, k); i == n gives the upper boundary. */
vec3 mprt__grid_voxel_lo(const mprt_grid *g, int i, int j, int k);

/* ---- Empty space (grid_jumps.c) ---- */

/* Chessboard (L-infinity) distance in cells to the nearest cell holding 0,
 * over an n[0] x n[1] x n[2] array of cells (x fastest) holding 0 or 255,
 * capped at 255.  MPRT_ERR_OUT_OF_MEMORY when scratch memory runs out. */
int mprt__chessboard_distance(const int n[3], uint8_t *d);

/* g->jump_min and g->jump_far as the environment asks (MPRT_SKIP,
 * MPRT_JUMP_MIN, MPRT_NO_SKIP); MPRT_OK, or fails the grid naming the
 * variable. */
int mprt__grid_jump_threshold(mprt_grid *g);

/* The macro cells (g->macro, g->macro_lo) and the jumps: an empty voxel
 * (empty 1) takes d + 1 (at most 255), d its macro cell's chessboard
 * distance to the nearest macro cell holding primitives, where d >= 1 (>= 2
 * where macro cells are single voxels: a block of one is not worth a jump).
 * The distances by distance, or NULL: mprt__chessboard_distance, run in
 * place on the flags where macro cells are single voxels.
 * MPRT_ERR_OUT_OF_MEMORY when memory runs out. */
int mprt__grid_mark_jumps(mprt_grid *g, mprt__distance_fn distance);

/* Fill g->plain from g->empty and g->jump_min (dda.c); MPRT_ERR_OUT_OF_MEMORY
 * when it cannot be allocated. */
int mprt__dda_plain(mprt_grid *g);

#endif
