/* ic_pack.h: tests of a voxel's primitives several at a time (internal;
 * ic_pack.c holds the tests, walk.h uses them).
 *
 * The walk goes through a voxel's list a stretch at a time: first in list
 * order through the mailbox, gathering the triangles it would test (their
 * indices into IC's records, mprt__ic.tri) and the spheres, cylinders and
 * cones; then it tests the triangles MPRT__PACK_W at a time (each lane
 * loads its triangle's record, the lanes' records transposed into
 * registers) and puts the balls through the filter, several at a time; then
 * it goes through the stretch in list order again, counting each test and
 * taking its result as the one-at-a-time walk would (a shadow ray stops at
 * its first hit in list order; the limit best->t applies in order), so
 * counts, hits and ties are the same.  A block test computes the watertight
 * triangle test of ic.h (mprt__tri_hit) for every lane with the same
 * operations in the same order on the same values, but for the shear (see
 * ic_pack.c), so each lane's decision and t are the same bits; no fused
 * multiply-add (the Makefile's -ffp-contract=off, and the AVX2 copy names no
 * FMA).
 *
 * Chosen once per grid, when it is made: the AVX2 copies (x86-64 with GCC or
 * clang, double geometry, where the processor has AVX2); else none (the
 * walk tests one primitive at a time, in plain C99, as before: the portable
 * copies below are the same loops lane by lane, and measured slower than
 * that).  The environment can choose: MPRT_IC_PACK=0 none, MPRT_IC_SIMD=0
 * the portable C99 copies, the ones the tests run beside the others.  Every
 * choice gives the same bits (tests/c/test_ic_pack.c, tests/test_ic_pack.py). */
#ifndef MPRT_IC_PACK_H
#define MPRT_IC_PACK_H

#include "ic.h"

#include <stddef.h>
#include <stdint.h>

#define MPRT__PACK_W 4     /* lanes per block */
#define MPRT__PACK_MAX 32  /* triangles or balls one call tests at most */

/* Test the triangles tri[index[i]], i < n (n <= MPRT__PACK_MAX), for ray
 * over (tmin, tmax]: bit i of the result is set when triangle i hits, and
 * then tt[i] holds its t (mprt__tri_hit's decision and t). */
typedef uint32_t (*mprt__pack_test_fn)(const mprt__tri *tri, const uint32_t *index, unsigned n,
                                       const mprt__ray *ray, real tmin, real tmax, real *tt);

/* Blocks: for a voxel whose list holds a triangle, its list positions laid
 * out MPRT__PACK_W to a block, structure of arrays: lane j of block b holds
 * position MPRT__PACK_W b + j, the triangle's record (mprt__tri's 13 reals)
 * when that position is a triangle, zeros otherwise (a zero normal: a lane
 * that never hits).  The blocks need no gathering and no transposing, so
 * they test faster than records; but each list position takes 104 bytes
 * of its own, so they are made only where they all fit MPRT__PACK_BUDGET
 * (fine grids then test from the records: rays that go everywhere pay more
 * for the blocks' memory than they save).  MPRT_IC_BLOCKS=0: no blocks. */
#define MPRT__PACK_FIELDS 13  /* v0 xyz, v1 xyz, v2 xyz, normal xyz, d */
#define MPRT__PACK_BLOCK (MPRT__PACK_W * MPRT__PACK_FIELDS) /* reals per block */
#define MPRT__PACK_CHUNK 8    /* blocks one call tests at most */
#define MPRT__PACK_BUDGET ((size_t)4 << 20) /* bytes: tetra's 2.7 MB at 24^3 paid, 8.9 MB at 48^3 did not
                                            * (studies/03_bench/README.md; the L2 of the 2 cores measured) */

/* Test blocks [0, nblocks) (nblocks <= MPRT__PACK_CHUNK): bit i of the
 * result is set when lane i hits, and then tt[i] holds its t. */
typedef uint32_t (*mprt__block_test_fn)(const real *blocks, unsigned nblocks, const mprt__ray *ray, real tmin,
                                        real tmax, real *tt);

/* The ball filter: for the n (<= MPRT__PACK_MAX) primitives ids[0 .. n),
 * spheres, cylinders or cones, bit i set when ids[i]'s ball (ic.h: the
 * sphere, a cylinder's or a cone's bounding ball) certainly misses the ray: mprt__line_misses, computed with the
 * same operations in the same order (for a sphere on o - c, for a cone on
 * c - o: the same bits, a negated difference giving a negated cross
 * product).  IC's test of such a primitive is counted and returns no hit
 * without more (ic.h, mprt__ic_test), so the walk counts it and goes on. */
typedef uint32_t (*mprt__ball_filter_fn)(const mprt__ball *balls, const int32_t *ids, unsigned n,
                                         const mprt__ray *ray, real dd);

enum { MPRT__PACK_NONE, MPRT__PACK_PORTABLE, MPRT__PACK_AVX2 };

typedef struct {
    uint32_t *first;             /* NULL (no blocks), or per voxel + 1 its first block; equal neighbours: none */
    real *blocks;                /* the blocks, MPRT__PACK_BLOCK reals each */
    size_t nblocks;
    mprt__block_test_fn block_test; /* the blocks' test chosen (with blocks) */
    mprt__pack_test_fn test;     /* NULL (one at a time), or the triangle test chosen */
    mprt__ball_filter_fn filter; /* NULL, or the ball filter chosen */
    int kind;                    /* MPRT__PACK_NONE, _PORTABLE or _AVX2 */
} mprt__ic_pack;

struct mprt_grid;

/* Choose g's tests, as the environment and the processor allow: none
 * (kind NONE, the walk tests one at a time, with the same results) with
 * MPRT_IC_PACK=0, or without AVX2 unless MPRT_IC_SIMD=0 asks for the
 * portable copies; the triangle test only for a scene with triangles, the
 * filter only for one with spheres, cylinders or cones. */
void mprt__ic_pack_choose(struct mprt_grid *g);
void mprt__ic_pack_free(mprt__ic_pack *p);

/* The copies, for tests/c/test_ic_pack.c: the portable ones, and the AVX2
 * ones where this build and processor have them (else NULL). */
uint32_t mprt__pack_test_portable(const mprt__tri *tri, const uint32_t *index, unsigned n, const mprt__ray *ray,
                                  real tmin, real tmax, real *tt);
mprt__pack_test_fn mprt__pack_test_avx2(void);
uint32_t mprt__block_test_portable(const real *blocks, unsigned nblocks, const mprt__ray *ray, real tmin, real tmax,
                                   real *tt);
mprt__block_test_fn mprt__block_test_avx2(void);
uint32_t mprt__ball_filter_portable(const mprt__ball *balls, const int32_t *ids, unsigned n, const mprt__ray *ray,
                                    real dd);
mprt__ball_filter_fn mprt__ball_filter_avx2(void);

#endif
