/* ic_pack.c: the tests of several triangles, and the ball filter of several
 * spheres, cylinders or cones, at a time (ic_pack.h): portable C99 copies
 * and, where the compiler and processor allow, AVX2 copies chosen at run
 * time.
 *
 * The shear: mprt__tri_hit computes a vertex's shear coordinates as dot
 * products with the ray's rows mx and my (mprt__ray), whose terms are
 * q[kx] * 1, q[kz] * sx and a zero (for x; likewise y).  Multiplying by 1
 * and adding a zero are exact, so q[kx] + q[kz] * sx is the same value, up
 * to the sign of a zero result; the edge functions' decisions (ic.h,
 * mprt__edge_winding: e > 0, e < 0, y <= 0, y > 0) do not see that sign,
 * and t does not use the shear, so the blocks test with 2 products per
 * vertex instead of 6 and decide, and find t, exactly as mprt__tri_hit. */
#include "grid.h"

#include <stdlib.h>
#include <string.h>

#if defined(__GNUC__) && defined(__x86_64__) && !defined(MPRT_SINGLE)
#define MPRT__PACK_HAVE_AVX2 1
#include <immintrin.h>
#endif

/* Field f (0..12: v0 xyz, v1 xyz, v2 xyz, normal xyz, d) of a triangle's record. */
static real tri_field(const mprt__tri *t, int f)
{
    return f < 9 ? vget(t->v[f / 3], f % 3) : f < 12 ? vget(t->normal, f - 9) : t->d;
}

/* ---- The portable copies ------------------------------------------------------ */

/* One triangle against the ray, mprt__tri_hit's operations in its order
 * (ic.h) but for the shear (see the top): its 13 fields (MPRT__PACK_FIELDS)
 * at f[0], f[stride], ...; 1 and its t in *t when it hits over (tmin, tmax]. */
static int lane_hit(const real *f, size_t stride, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    const vec3 o = ray->o, d = ray->d;
    const int kx = ray->kx, ky = ray->ky, kz = ray->kz;
    const real ox = vget(o, kx), oy = vget(o, ky), oz = vget(o, kz), sx = ray->sx, sy = ray->sy;
    const real nx = f[9 * stride], ny = f[10 * stride], nz = f[11 * stride];
    real x[3], y[3], dn, u;
    size_t v;
    dn = nx * d.x + ny * d.y + nz * d.z;
    if (dn == 0) return 0;
    for (v = 0; v < 3; v++) {
        const real qz = f[(3 * v + (size_t)kz) * stride] - oz;
        x[v] = (f[(3 * v + (size_t)kx) * stride] - ox) + qz * sx;
        y[v] = (f[(3 * v + (size_t)ky) * stride] - oy) + qz * sy;
    }
    if (mprt__edge_winding(x[2], y[2], x[0], y[0]) + mprt__edge_winding(x[0], y[0], x[1], y[1]) +
            mprt__edge_winding(x[1], y[1], x[2], y[2]) == 0)
        return 0;
    u = (f[12 * stride] - (nx * o.x + ny * o.y + nz * o.z)) / dn;
    if (!(u > tmin && u <= tmax)) return 0;
    *t = u;
    return 1;
}

uint32_t mprt__pack_test_portable(const mprt__tri *tri, const uint32_t *index, unsigned n, const mprt__ray *ray,
                                  real tmin, real tmax, real *tt)
{
    uint32_t hits = 0;
    unsigned i;
    for (i = 0; i < n; i++) {
        real f[MPRT__PACK_FIELDS];
        int k;
        for (k = 0; k < MPRT__PACK_FIELDS; k++) f[k] = tri_field(&tri[index[i]], k);
        if (lane_hit(f, 1, ray, tmin, tmax, &tt[i])) hits |= (uint32_t)1 << i;
    }
    return hits;
}

/* Field f (0..12, MPRT__PACK_FIELDS) of lane j in block B. */
#define FIELD(B, f, j) ((B)[(f) * MPRT__PACK_W + (j)])

/* The blocks' test (ic_pack.h), lane by lane. */
uint32_t mprt__block_test_portable(const real *blocks, unsigned nblocks, const mprt__ray *ray, real tmin, real tmax,
                                  real *tt)
{
    uint32_t hits = 0;
    unsigned i;
    for (i = 0; i < nblocks * MPRT__PACK_W; i++) {
        const real *B = blocks + (size_t)(i / MPRT__PACK_W) * MPRT__PACK_BLOCK;
        if (lane_hit(&FIELD(B, 0, i % MPRT__PACK_W), MPRT__PACK_W, ray, tmin, tmax, &tt[i])) hits |= (uint32_t)1 << i;
    }
    return hits;
}

uint32_t mprt__ball_filter_portable(const mprt__ball *balls, const int32_t *ids, unsigned n, const mprt__ray *ray,
                                    real dd)
{
    uint32_t miss = 0;
    unsigned i;
    for (i = 0; i < n; i++) {
        const mprt__ball *b = &balls[ids[i]];
        if (mprt__line_misses(vsub(ray->o, b->c), ray->d, dd, b->r2)) miss |= (uint32_t)1 << i;
    }
    return miss;
}

/* ---- The AVX2 copy: four lanes in one register, the same operations ---------- */

#ifdef MPRT__PACK_HAVE_AVX2
#define TARGET_AVX2 __attribute__((target("avx2")))

/* Lanes where edge a->b adds +1 (up, as all-ones) and where it adds -1 (down): mprt__edge_winding. */
TARGET_AVX2 static inline void edge_avx2(__m256d ax, __m256d ay, __m256d bx, __m256d by, __m256i *up, __m256i *down)
{
    const __m256d z = _mm256_setzero_pd();
    const __m256d e = _mm256_sub_pd(_mm256_mul_pd(ax, by), _mm256_mul_pd(ay, bx));
    const __m256d u = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(ay, z, _CMP_LE_OQ), _mm256_cmp_pd(by, z, _CMP_GT_OQ)),
                                    _mm256_cmp_pd(e, z, _CMP_GT_OQ));
    const __m256d w = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(ay, z, _CMP_NLE_UQ), _mm256_cmp_pd(by, z, _CMP_LE_OQ)),
                                    _mm256_cmp_pd(e, z, _CMP_LT_OQ));
    *up = _mm256_add_epi64(*up, _mm256_castpd_si256(u));
    *down = _mm256_add_epi64(*down, _mm256_castpd_si256(w));
}

/* A 4x4 transpose: r[j] = lane j of each of a[0..3]. */
TARGET_AVX2 static inline void transpose4(const __m256d a[4], __m256d r[4])
{
    const __m256d t0 = _mm256_unpacklo_pd(a[0], a[1]), t1 = _mm256_unpackhi_pd(a[0], a[1]);
    const __m256d t2 = _mm256_unpacklo_pd(a[2], a[3]), t3 = _mm256_unpackhi_pd(a[2], a[3]);
    r[0] = _mm256_permute2f128_pd(t0, t2, 0x20);
    r[1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    r[2] = _mm256_permute2f128_pd(t0, t2, 0x31);
    r[3] = _mm256_permute2f128_pd(t1, t3, 0x31);
}

/* The ray as four lanes see it: each value in every lane. */
typedef struct {
    __m256d ox, oy, oz, dx, dy, dz; /* origin and direction */
    __m256d px, py, pz, sx, sy;     /* the origin's kx, ky, kz coordinates, and the shear */
    __m256d lo, hi;                 /* tmin, tmax */
    int kx, ky, kz;
} ray4;

TARGET_AVX2 static inline void ray4_set(ray4 *r, const mprt__ray *ray, real tmin, real tmax)
{
    r->ox = _mm256_set1_pd(ray->o.x);
    r->oy = _mm256_set1_pd(ray->o.y);
    r->oz = _mm256_set1_pd(ray->o.z);
    r->dx = _mm256_set1_pd(ray->d.x);
    r->dy = _mm256_set1_pd(ray->d.y);
    r->dz = _mm256_set1_pd(ray->d.z);
    r->kx = ray->kx;
    r->ky = ray->ky;
    r->kz = ray->kz;
    r->px = _mm256_set1_pd(vget(ray->o, ray->kx));
    r->py = _mm256_set1_pd(vget(ray->o, ray->ky));
    r->pz = _mm256_set1_pd(vget(ray->o, ray->kz));
    r->sx = _mm256_set1_pd(ray->sx);
    r->sy = _mm256_set1_pd(ray->sy);
    r->lo = _mm256_set1_pd(tmin);
    r->hi = _mm256_set1_pd(tmax);
}

/* The four lanes of block B (ic_pack.h's layout) against the ray: bit j of
 * the result set when lane j hits; where any lane passes the edge tests,
 * tt[0 .. 4) takes the four lanes' t (read only where a bit is set).
 * Inlined into both tests, so the ray's registers stay registers. */
TARGET_AVX2 __attribute__((always_inline)) static inline uint32_t block4_avx2(const ray4 *r, const real *B, real *tt)
{
    const __m256d z = _mm256_setzero_pd();
    const __m256d nx = _mm256_loadu_pd(B + 9 * MPRT__PACK_W), ny = _mm256_loadu_pd(B + 10 * MPRT__PACK_W),
                  nz = _mm256_loadu_pd(B + 11 * MPRT__PACK_W);
    __m256d x[3], y[3], dn, t;
    __m256i up = _mm256_setzero_si256(), down = _mm256_setzero_si256();
    int v, m;
    dn = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(nx, r->dx), _mm256_mul_pd(ny, r->dy)), _mm256_mul_pd(nz, r->dz));
    for (v = 0; v < 3; v++) {
        const __m256d qz = _mm256_sub_pd(_mm256_loadu_pd(B + (3 * v + r->kz) * MPRT__PACK_W), r->pz);
        x[v] = _mm256_add_pd(_mm256_sub_pd(_mm256_loadu_pd(B + (3 * v + r->kx) * MPRT__PACK_W), r->px),
                             _mm256_mul_pd(qz, r->sx));
        y[v] = _mm256_add_pd(_mm256_sub_pd(_mm256_loadu_pd(B + (3 * v + r->ky) * MPRT__PACK_W), r->py),
                             _mm256_mul_pd(qz, r->sy));
    }
    edge_avx2(x[2], y[2], x[0], y[0], &up, &down);
    edge_avx2(x[0], y[0], x[1], y[1], &up, &down);
    edge_avx2(x[1], y[1], x[2], y[2], &up, &down);
    /* a winding number (ups less downs) other than 0, and dn != 0 (NaN too, as dn == 0 is false for it) */
    m = _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(up, down))) ^ 0xf;
    m &= _mm256_movemask_pd(_mm256_cmp_pd(dn, z, _CMP_NEQ_UQ));
    if (!m) return 0;
    t = _mm256_div_pd(_mm256_sub_pd(_mm256_loadu_pd(B + 12 * MPRT__PACK_W),
                                    _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(nx, r->ox), _mm256_mul_pd(ny, r->oy)),
                                                  _mm256_mul_pd(nz, r->oz))),
                      dn);
    m &= _mm256_movemask_pd(_mm256_and_pd(_mm256_cmp_pd(t, r->lo, _CMP_GT_OQ), _mm256_cmp_pd(t, r->hi, _CMP_LE_OQ)));
    _mm256_storeu_pd(tt, t);
    return (uint32_t)m;
}

/* The records of four triangles, gathered into a block and tested as one. */
TARGET_AVX2 static uint32_t pack_test_avx2(const mprt__tri *tri, const uint32_t *index, unsigned n,
                                           const mprt__ray *ray, real tmin, real tmax, real *tt)
{
    static const mprt__tri none; /* a zero normal: a lane that never hits */
    ray4 r;
    uint32_t hits = 0;
    unsigned b;
    ray4_set(&r, ray, tmin, tmax);
    for (b = 0; b < n; b += MPRT__PACK_W) {
        const mprt__tri *p[4];
        real B[MPRT__PACK_BLOCK];
        __m256d a[4], F[4];
        int j;
        for (j = 0; j < 4; j++) p[j] = b + (unsigned)j < n ? &tri[index[b + (unsigned)j]] : &none;
        /* the records (13 reals each) as three rows of four and d, transposed: field f of the four at B + 4 f */
        for (j = 0; j < 4; j++) a[j] = _mm256_loadu_pd(&p[j]->v[0].x);
        transpose4(a, F);
        for (j = 0; j < 4; j++) _mm256_storeu_pd(B + j * MPRT__PACK_W, F[j]);
        for (j = 0; j < 4; j++) a[j] = _mm256_loadu_pd(&p[j]->v[1].y);
        transpose4(a, F);
        for (j = 0; j < 4; j++) _mm256_storeu_pd(B + (4 + j) * MPRT__PACK_W, F[j]);
        for (j = 0; j < 4; j++) a[j] = _mm256_loadu_pd(&p[j]->v[2].z);
        transpose4(a, F);
        for (j = 0; j < 4; j++) _mm256_storeu_pd(B + (8 + j) * MPRT__PACK_W, F[j]);
        for (j = 0; j < 4; j++) B[12 * MPRT__PACK_W + j] = p[j]->d;
        hits |= block4_avx2(&r, B, tt + b) << b;
    }
    return n < 32 ? hits & (((uint32_t)1 << n) - 1) : hits;
}

TARGET_AVX2 static uint32_t block_test_avx2(const real *blocks, unsigned nblocks, const mprt__ray *ray, real tmin,
                                            real tmax, real *tt)
{
    ray4 r;
    uint32_t hits = 0;
    unsigned b;
    ray4_set(&r, ray, tmin, tmax);
    for (b = 0; b < nblocks; b++)
        hits |= block4_avx2(&r, blocks + (size_t)b * MPRT__PACK_BLOCK, tt + b * MPRT__PACK_W) << (b * MPRT__PACK_W);
    return hits;
}

/* mprt__line_misses for four balls at a time, each loaded whole (c and r2:
 * 32 bytes) and the four transposed into x, y, z and r2 registers. */
TARGET_AVX2 static uint32_t ball_filter_avx2(const mprt__ball *balls, const int32_t *ids, unsigned n,
                                             const mprt__ray *ray, real dd)
{
    const __m256d vdd = _mm256_set1_pd(dd), c107 = _mm256_set1_pd(R(1.07));
    const __m256d k = _mm256_set1_pd(R(4096.0) * REAL_EPS * REAL_EPS);
    ray4 r; /* its o and d */
    uint32_t miss = 0;
    unsigned i;
    ray4_set(&r, ray, 0, 0);
    for (i = 0; i < n; i += 4) {
        __m256d b[4], c[4], mx, my, mz, cx, cy, cz, lhs, rhs;
        unsigned j;
        for (j = 0; j < 4; j++)
            b[j] = i + j < n ? _mm256_loadu_pd(&balls[ids[i + j]].c.x) : _mm256_setzero_pd();
        transpose4(b, c); /* x, y, z and r2 of the four */
        mx = _mm256_sub_pd(r.ox, c[0]);
        my = _mm256_sub_pd(r.oy, c[1]);
        mz = _mm256_sub_pd(r.oz, c[2]);
        /* c = om x d; |c|^2 > dd (1.07 r2 + 4096 eps^2 |om|^2) */
        cx = _mm256_sub_pd(_mm256_mul_pd(my, r.dz), _mm256_mul_pd(mz, r.dy));
        cy = _mm256_sub_pd(_mm256_mul_pd(mz, r.dx), _mm256_mul_pd(mx, r.dz));
        cz = _mm256_sub_pd(_mm256_mul_pd(mx, r.dy), _mm256_mul_pd(my, r.dx));
        lhs = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(cx, cx), _mm256_mul_pd(cy, cy)), _mm256_mul_pd(cz, cz));
        rhs = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(mx, mx), _mm256_mul_pd(my, my)), _mm256_mul_pd(mz, mz));
        rhs = _mm256_mul_pd(vdd, _mm256_add_pd(_mm256_mul_pd(c107, c[3]), _mm256_mul_pd(k, rhs)));
        miss |= (uint32_t)_mm256_movemask_pd(_mm256_cmp_pd(lhs, rhs, _CMP_GT_OQ)) << i;
    }
    return n < 32 ? miss & (((uint32_t)1 << n) - 1) : miss;
}

static int have_avx2(void)
{
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
}

mprt__pack_test_fn mprt__pack_test_avx2(void) { return have_avx2() ? pack_test_avx2 : NULL; }
mprt__block_test_fn mprt__block_test_avx2(void) { return have_avx2() ? block_test_avx2 : NULL; }
mprt__ball_filter_fn mprt__ball_filter_avx2(void) { return have_avx2() ? ball_filter_avx2 : NULL; }
#else
mprt__pack_test_fn mprt__pack_test_avx2(void) { return NULL; }
mprt__block_test_fn mprt__block_test_avx2(void) { return NULL; }
mprt__ball_filter_fn mprt__ball_filter_avx2(void) { return NULL; }
#endif

/* ---- The choice ------------------------------------------------------------------ */

/* Whether environment variable name is set to "0" (asks for less). */
static int env_off(const char *name)
{
    const char *v = getenv(name);
    return v && strcmp(v, "0") == 0;
}

/* Whether voxel v's list holds a triangle. */
static int has_triangle(const mprt_grid *g, long long v)
{
    uint32_t k;
    for (k = g->start[v]; k < g->start[v + 1]; k++)
        if ((g->ic.ref[g->ids[k]] & ((1u << MPRT__IC_KIND_BITS) - 1)) == MPRT__IC_TRIANGLE) return 1;
    return 0;
}

void mprt__ic_pack_free(mprt__ic_pack *p)
{
    free(p->first);
    free(p->blocks);
    memset(p, 0, sizeof *p);
}

/* Each voxel's list in blocks (ic_pack.h), where they fit MPRT__PACK_BUDGET. */
static void pack_blocks(mprt_grid *g, int portable)
{
    mprt__ic_pack *p = &g->pack;
    const long long nvox = g->voxels;
    size_t nb = 0, bytes;
    long long v;
    void *mem;
    for (v = 0; v < nvox; v++)
        if (has_triangle(g, v)) nb += (g->start[v + 1] - g->start[v] + MPRT__PACK_W - 1) / MPRT__PACK_W;
    bytes = nb * MPRT__PACK_BLOCK * sizeof(real) + (size_t)(nvox + 1) * sizeof *p->first;
    if (nb == 0 || bytes > MPRT__PACK_BUDGET) return;
    p->first = malloc((size_t)(nvox + 1) * sizeof *p->first);
    if (!p->first || posix_memalign(&mem, 64, nb * MPRT__PACK_BLOCK * sizeof(real)) != 0) {
        free(p->first);
        p->first = NULL;
        return;
    }
    p->blocks = mem;
    p->nblocks = nb;
    memset(p->blocks, 0, nb * MPRT__PACK_BLOCK * sizeof(real));
    nb = 0;
    for (v = 0; v < nvox; v++) {
        uint32_t k, k0 = g->start[v];
        p->first[v] = (uint32_t)nb;
        if (!has_triangle(g, v)) continue;
        for (k = k0; k < g->start[v + 1]; k++) {
            const uint32_t ref = g->ic.ref[g->ids[k]];
            real *B = p->blocks + (nb + (k - k0) / MPRT__PACK_W) * MPRT__PACK_BLOCK;
            const int j = (int)((k - k0) % MPRT__PACK_W), kind = (int)(ref & ((1u << MPRT__IC_KIND_BITS) - 1));
            const mprt__tri *t;
            int f;
            if (kind != MPRT__IC_TRIANGLE) continue; /* zeros: never hits */
            t = &g->ic.tri[ref >> MPRT__IC_KIND_BITS];
            for (f = 0; f < MPRT__PACK_FIELDS; f++) FIELD(B, f, j) = tri_field(t, f);
        }
        nb += (g->start[v + 1] - k0 + MPRT__PACK_W - 1) / MPRT__PACK_W;
    }
    p->first[nvox] = (uint32_t)nb;
    p->block_test = portable ? mprt__block_test_portable : mprt__block_test_avx2();
}

void mprt__ic_pack_choose(mprt_grid *g)
{
    mprt__ic_pack *p = &g->pack;
    const int portable = env_off("MPRT_IC_SIMD");
    memset(p, 0, sizeof *p);
    /* without AVX2, the portable copies only when asked for: they measured
     * slower than the one-at-a-time walk (studies/03_bench/README.md) */
    if (env_off("MPRT_IC_PACK") || (!portable && !mprt__pack_test_avx2())) return;
    p->kind = portable ? MPRT__PACK_PORTABLE : MPRT__PACK_AVX2;
    if (g->ic.ntri > 0) p->test = portable ? mprt__pack_test_portable : mprt__pack_test_avx2();
    if (g->ic.ntri > 0 && !env_off("MPRT_IC_BLOCKS")) pack_blocks(g, portable);
    if (g->scene->nprims > g->scene->npolygons) /* spheres, cylinders or cones */
        p->filter = portable ? mprt__ball_filter_portable : mprt__ball_filter_avx2();
}
