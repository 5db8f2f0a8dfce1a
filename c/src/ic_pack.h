/* ic_pack.h: the triangles of each voxel's list packed for tests several
 * at a time (internal; ic_pack.c builds them, walk.h uses them).
 *
 * For a voxel whose list holds at least one triangle, its list positions
 * are laid out in blocks of MPRT__PACK_W lanes, structure of arrays: lane j
 * of block b holds list position MPRT__PACK_W b + j, the triangle's three
 * vertices, normal and plane (mprt__tri's 13 values) when the position is a
 * triangle, zeros otherwise (a zero normal: a lane that never hits).  A
 * block test (mprt__pack_test) computes the watertight triangle test of
 * ic.h for every lane, with the same operations in the same order on the
 * same values, so each lane's decision and t are the same bits as
 * mprt__tri_hit's; no fused multiply-add (the Makefile's -ffp-contract=off,
 * and the AVX2 copy names no FMA).  What a block test computes is not yet a
 * test made: the walk (walk.h) goes through the list in order and counts,
 * and takes the result of, only the lanes the scalar walk would test (not
 * those the mailbox skips, none after a shadow ray's first hit), so counts,
 * hits and ties are those of the one-at-a-time walk.
 *
 * Chosen once per grid, when it is made: the AVX2 copy (x86-64 with GCC or
 * clang, double geometry, where the processor has AVX2); else no packing
 * (the walk tests one primitive at a time, in plain C99, as before: the
 * portable copy below computes every lane, mailboxed and empty ones too,
 * and measured 10% slower than that on tetra).  The environment can choose:
 * MPRT_IC_PACK=0 no packing, MPRT_IC_SIMD=0 the portable C99 block test
 * (plain loops over the lanes), the one the tests run beside the others.
 * Every choice gives the same bits (tests/c/test_ic_pack.c,
 * tests/test_ic_pack.py). */
#ifndef MPRT_IC_PACK_H
#define MPRT_IC_PACK_H

#include "ic.h"

#include <stddef.h>
#include <stdint.h>

#define MPRT__PACK_W 4        /* lanes per block */
#define MPRT__PACK_FIELDS 13  /* v0 xyz, v1 xyz, v2 xyz, normal xyz, d */
#define MPRT__PACK_BLOCK (MPRT__PACK_W * MPRT__PACK_FIELDS) /* reals per block */
#define MPRT__PACK_CHUNK 8    /* blocks one call tests at most */

/* Test blocks [0, nblocks) (nblocks <= MPRT__PACK_CHUNK) for ray over
 * (tmin, tmax]: bit i of the result is set when lane i hits, and then
 * tt[i] holds its t. */
typedef uint32_t (*mprt__pack_test_fn)(const real *blocks, unsigned nblocks, const mprt__ray *ray, real tmin,
                                       real tmax, real *tt);

/* The ball filter: for the n (<= MPRT__FILTER_MAX) primitives ids[0 .. n)
 * of a voxel's list, bit i set when ids[i]'s ball (ic.h: a sphere, a
 * cylinder's or a cone's bounding ball; zeros for polygons, whose bits mean
 * nothing) certainly misses the ray: mprt__line_misses, computed with the
 * same operations in the same order (for a sphere on o - c, for a cone on
 * c - o: the same bits, a negated difference giving a negated cross
 * product).  IC's test of such a primitive is counted and returns no hit
 * without more (ic.h, mprt__ic_test), so the walk counts it and goes on. */
#define MPRT__FILTER_MAX 32
typedef uint32_t (*mprt__ball_filter_fn)(const mprt__ball *balls, const int32_t *ids, unsigned n,
                                         const mprt__ray *ray, real dd);

enum { MPRT__PACK_NONE, MPRT__PACK_PORTABLE, MPRT__PACK_AVX2 };

typedef struct {
    uint32_t *first;          /* per voxel + 1: its first block; equal neighbours: no blocks (no triangle) */
    real *blocks;             /* the blocks, MPRT__PACK_BLOCK reals each */
    size_t nblocks;
    mprt__pack_test_fn test;  /* the block test chosen */
    int kind;                 /* MPRT__PACK_NONE (first and blocks NULL), _PORTABLE or _AVX2 */
    mprt__ball_filter_fn filter; /* NULL, or the ball filter for lists without packed triangles */
} mprt__ic_pack;

struct mprt_grid;

/* Pack the triangles of g's lists (after the grid is built), as the
 * environment and the processor allow; packing is skipped (kind NONE, the
 * walk then tests one at a time, with the same results) when the grid has
 * no triangle, without AVX2 unless MPRT_IC_SIMD=0 asks for the portable
 * copy, when the blocks would take more than max_bytes / 4, or when memory
 * runs out. */
void mprt__ic_pack_build(struct mprt_grid *g, size_t max_bytes);
void mprt__ic_pack_free(mprt__ic_pack *p);

/* The block tests, for tests/c/test_ic_pack.c: the portable copy, and the
 * AVX2 copy where this build and processor have it (else NULL). */
uint32_t mprt__pack_test_portable(const real *blocks, unsigned nblocks, const mprt__ray *ray, real tmin, real tmax,
                                  real *tt);
mprt__pack_test_fn mprt__pack_test_avx2(void);
uint32_t mprt__ball_filter_portable(const mprt__ball *balls, const int32_t *ids, unsigned n, const mprt__ray *ray,
                                    real dd);
mprt__ball_filter_fn mprt__ball_filter_avx2(void);

#endif
