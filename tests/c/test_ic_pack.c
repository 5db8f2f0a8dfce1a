/* test_ic_pack.c: the tests several at a time (ic_pack.h) change nothing.
 *  - The triangle test (the portable copy, and the AVX2 copy where the
 *    processor has it) decides for every triangle of every list as
 *    mprt__tri_hit and gives the same t, bit for bit, on rays aimed at a
 *    mesh's shared vertices and edges (lying on voxel planes, where the
 *    shear's zeros have signs) and at random ones; lanes past n never hit.
 *  - The ball filter (ic_pack.h) decides as mprt__line_misses for every
 *    sphere, cylinder and cone in every list.
 *  - So do the blocks' tests, lane by lane.
 *  - Walks on grids made one at a time (MPRT_IC_PACK=0), with the
 *    portable copies (MPRT_IC_SIMD=0), with and without blocks
 *    (MPRT_IC_BLOCKS=0), and with the default (AVX2 where the
 *    processor has it, else one at a time) give the same
 *    nearest hits, t and counters (tests by kind, vertices, visits), with
 *    and without the mailbox (renders), on triangles mixed with spheres,
 *    quads and cones in one voxel, on a mesh, and on spheres, quads,
 *    cylinders and cones alone (the ball filter without packed triangles). */
#include "check.h"
#include "geom.h"
#include "grid.h"

#include <stdlib.h>
#include <string.h>

#define NRAYS 3000

/* A triangle mesh over [0, 4]^2 at heights from a few values, its vertices on
 * the voxel planes of a 4x4x4 grid over [0, 4]^3 (corners at z 0 and 4 too),
 * plus, with mixed 1, spheres, quads and cones among the triangles; with
 * mixed 2 those alone (more of them), no triangle. */
static mprt_scene *mesh_scene(int mixed, rng *r)
{
    mprt_scene *s;
    int i, j;
    mprt_scene_create(&s);
    {
        double from[3] = {2.3, -3, 6}, at[3] = {2, 2, 1}, up[3] = {0, 0, 1}, l1[3] = {1, 1, 8}, l2[3] = {4.5, 2, 2.5};
        double mat[3] = {0.8, 0.7, 0.6};
        CHECK(mprt_scene_set_view(s, from, at, up, 45, 0.01, 40, 40) == MPRT_OK);
        CHECK(mprt_scene_add_light(s, l1, NULL) == MPRT_OK);
        CHECK(mprt_scene_add_light(s, l2, NULL) == MPRT_OK);
        CHECK(mprt_scene_set_material(s, mat, 0.6, 0.4, 20, 0.3, 1.2) == MPRT_OK);
    }
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) {
            double z00 = (i + j) % 3, z10 = (i + 1 + j) % 3, z01 = (i + j + 1) % 3, z11 = (i + j + 2) % 3;
            double a[9] = {i, j, z00, i + 1, j, z10, i + 1, j + 1, z11};
            double b[9] = {i, j, z00, i + 1, j + 1, z11, i, j + 1, z01};
            if (mixed < 2) {
                CHECK(mprt_scene_add_polygon(s, 3, a, NULL) == MPRT_OK);
                CHECK(mprt_scene_add_polygon(s, 3, b, NULL) == MPRT_OK);
            }
            if (mixed == 2 || (mixed && (i + j) % 2 == 0)) {
                double c[3] = {i + 0.5, j + 0.5, 1.5}, q[12] = {i, j, 3, i + 1, j, 3, i + 1, j + 1, 3, i, j + 1, 3};
                double base[3] = {i + 0.2, j + 0.3, 0.5}, apex[3] = {i + 0.7, j + 0.6, 2.5};
                CHECK(mprt_scene_add_sphere(s, c, rnd_in(r, 0.1, 0.6)) == MPRT_OK);
                CHECK(mprt_scene_add_polygon(s, 4, q, NULL) == MPRT_OK);
                CHECK(mprt_scene_add_cone(s, base, 0.3, apex, (i + j) % 4 ? 0.1 : 0.3) == MPRT_OK);
            }
        }
    if (mixed < 2) { /* corners at the box's top, so that the grid is [0, 4]^3 */
        double t[9] = {0, 0, 4, 0.5, 0, 4, 0, 0.5, 4};
        CHECK(mprt_scene_add_polygon(s, 3, t, NULL) == MPRT_OK);
    }
    return s;
}

/* A ray aimed at a mesh vertex, an edge's midpoint or anywhere near the mesh. */
static void aim(rng *r, int i, double o[3], double d[3])
{
    double p[3];
    int k;
    for (k = 0; k < 3; k++) o[k] = rnd_in(r, -2, 6);
    switch (i % 4) {
    case 0: p[0] = rnd_int(r, 0, 4), p[1] = rnd_int(r, 0, 4), p[2] = rnd_int(r, 0, 2); break;
    case 1: p[0] = rnd_int(r, 0, 4) + 0.5, p[1] = rnd_int(r, 0, 4) + 0.5, p[2] = rnd_int(r, 0, 2) * 0.5; break;
    case 2: /* axis-aligned through a vertex */
        p[0] = rnd_int(r, 0, 4), p[1] = rnd_int(r, 0, 4), p[2] = rnd_int(r, 0, 2);
        o[0] = p[0], o[1] = p[1], o[2] = 7;
        break;
    default: for (k = 0; k < 3; k++) p[k] = rnd_in(r, 0, 4); break;
    }
    for (k = 0; k < 3; k++) d[k] = p[k] - o[k];
    if (d[0] == 0 && d[1] == 0 && d[2] == 0) d[2] = -1;
}

/* The triangle test fn on the triangles of every voxel's list of g against mprt__tri_hit. */
static void lanes_agree(const mprt_grid *g, mprt__pack_test_fn fn, rng *r, const char *name)
{
    long long differ = 0, hits = 0, lanes = 0;
    int i;
    for (i = 0; i < NRAYS; i++) {
        double o[3], d[3];
        mprt__ray ray;
        real tmin = i % 3 == 0 ? (real)rnd_in(r, 0, 1) : 0, tmax = i % 5 == 0 ? (real)rnd_in(r, 1, 3) : (real)INFINITY;
        long long v;
        aim(r, i, o, d);
        ray = mkray(vd(o[0], o[1], o[2]), vd(d[0], d[1], d[2]));
        for (v = 0; v < g->voxels; v++) {
            uint32_t index[MPRT__PACK_MAX], k, n = 0, got, j;
            real tt[MPRT__PACK_MAX];
            for (k = g->start[v]; k < g->start[v + 1] && n < MPRT__PACK_MAX; k++) {
                const uint32_t ref = g->ic.ref[g->ids[k]];
                if ((ref & 7u) == MPRT__IC_TRIANGLE) index[n++] = ref >> MPRT__IC_KIND_BITS;
            }
            got = fn(g->ic.tri, index, n, &ray, tmin, tmax, tt);
            CHECK(n == MPRT__PACK_MAX || (got >> n) == 0);
            for (j = 0; j < n; j++) {
                real t = 0;
                int want = mprt__tri_hit(&g->ic.tri[index[j]], &ray, tmin, tmax, &t), lane = (int)((got >> j) & 1);
                lanes++;
                hits += want;
                if ((lane != want || (want && memcmp(&t, &tt[j], sizeof t) != 0)) && differ++ < 5)
                    CHECK_MSG(0, "%s: ray %d voxel %lld triangle %u: %d at %.17g, mprt__tri_hit %d at %.17g", name, i,
                              v, j, lane, (double)tt[j], want, (double)t);
            }
        }
    }
    CHECK_MSG(differ == 0, "%s: %lld of %lld lanes differ", name, differ, lanes);
    CHECK_MSG(hits > 1000, "%s: only %lld hits", name, hits);
}

/* Every lane of every block of g against mprt__tri_hit, with test fn. */
static void blocks_agree(const mprt_grid *g, mprt__block_test_fn fn, rng *r, const char *name)
{
    long long differ = 0, hits = 0, lanes = 0;
    int i;
    CHECK(g->pack.first != NULL && g->pack.nblocks > 0);
    if (!g->pack.first) return;
    for (i = 0; i < NRAYS; i++) {
        double o[3], d[3];
        mprt__ray ray;
        real tmin = i % 3 == 0 ? (real)rnd_in(r, 0, 1) : 0, tmax = i % 5 == 0 ? (real)rnd_in(r, 1, 3) : (real)INFINITY;
        long long v;
        aim(r, i, o, d);
        ray = mkray(vd(o[0], o[1], o[2]), vd(d[0], d[1], d[2]));
        for (v = 0; v < g->voxels; v++) {
            const uint32_t b0 = g->pack.first[v], nb = g->pack.first[v + 1] - b0;
            uint32_t b, k;
            for (b = 0; b < nb; b += MPRT__PACK_CHUNK) {
                const unsigned n = nb - b < MPRT__PACK_CHUNK ? nb - b : MPRT__PACK_CHUNK;
                real tt[MPRT__PACK_CHUNK * MPRT__PACK_W];
                uint32_t got = fn(g->pack.blocks + (size_t)(b0 + b) * MPRT__PACK_BLOCK, n, &ray, tmin, tmax, tt);
                for (k = 0; k < n * MPRT__PACK_W; k++) {
                    const uint32_t at = g->start[v] + b * MPRT__PACK_W + k;
                    int want = 0, lane = (int)((got >> k) & 1);
                    real t = 0;
                    if (at < g->start[v + 1]) {
                        const uint32_t ref = g->ic.ref[g->ids[at]];
                        if ((ref & 7u) == MPRT__IC_TRIANGLE)
                            want = mprt__tri_hit(&g->ic.tri[ref >> MPRT__IC_KIND_BITS], &ray, tmin, tmax, &t);
                    }
                    lanes++;
                    hits += want;
                    if (lane != want || (want && memcmp(&t, &tt[k], sizeof t) != 0)) {
                        if (differ++ < 5)
                            CHECK_MSG(0, "%s: ray %d voxel %lld lane %u: %d at %.17g, mprt__tri_hit %d at %.17g",
                                      name, i, v, k, lane, (double)tt[k], want, (double)t);
                    }
                }
            }
        }
    }
    CHECK_MSG(differ == 0, "%s: %lld of %lld lanes differ", name, differ, lanes);
    CHECK_MSG(hits > 1000, "%s: only %lld hits", name, hits);
}

/* The ball filter fn on every voxel's list of g against mprt__line_misses. */
static void filter_agrees(const mprt_grid *g, mprt__ball_filter_fn fn, rng *r, const char *name)
{
    long long differ = 0, misses = 0, balls = 0;
    int i;
    for (i = 0; i < NRAYS; i++) {
        double o[3], d[3];
        mprt__ray ray;
        real dd;
        long long v;
        aim(r, i, o, d);
        ray = mkray(vd(o[0], o[1], o[2]), vd(d[0], d[1], d[2]));
        dd = vdot(ray.d, ray.d);
        for (v = 0; v < g->voxels; v++) {
            uint32_t k, n;
            for (k = g->start[v]; k < g->start[v + 1]; k += n) {
                uint32_t got, j;
                int32_t ids[MPRT__PACK_MAX];
                uint32_t m = 0;
                n = g->start[v + 1] - k < MPRT__PACK_MAX ? g->start[v + 1] - k : MPRT__PACK_MAX;
                for (j = 0; j < n; j++)
                    if (g->scene->prims[g->ids[k + j]].kind != MPRT_POLYGON) ids[m++] = g->ids[k + j];
                got = fn(g->ic.ball, ids, m, &ray, dd);
                CHECK(m == MPRT__PACK_MAX || (got >> m) == 0);
                for (j = 0; j < m; j++) {
                    const int32_t id = ids[j];
                    const mprt__ball *b = &g->ic.ball[id];
                    const int kind = g->scene->prims[id].kind;
                    /* a sphere's test subtracts c from o, a cone's o from c: the same decision */
                    int want = mprt__line_misses(kind == MPRT_SPHERE ? vsub(ray.o, b->c) : vsub(b->c, ray.o), ray.d,
                                                 dd, b->r2);
                    balls++;
                    misses += want;
                    if ((int)((got >> j) & 1) != want && differ++ < 5)
                        CHECK_MSG(0, "%s: ray %d voxel %lld position %u: %d, mprt__line_misses %d", name, i, v, j,
                                  (int)((got >> j) & 1), want);
                }
            }
        }
    }
    CHECK_MSG(differ == 0, "%s: %lld of %lld balls differ", name, differ, balls);
    CHECK_MSG(misses > 1000 && misses < balls - 1000, "%s: %lld misses of %lld", name, misses, balls);
}

static mprt_grid *grid_with(const mprt_scene *s, int n, const char *pack, const char *simd, const char *blocks)
{
    mprt_grid *g = NULL;
    if (blocks) setenv("MPRT_IC_BLOCKS", blocks, 1);
    else unsetenv("MPRT_IC_BLOCKS");
    if (pack) setenv("MPRT_IC_PACK", pack, 1);
    else unsetenv("MPRT_IC_PACK");
    if (simd) setenv("MPRT_IC_SIMD", simd, 1);
    else unsetenv("MPRT_IC_SIMD");
    CHECK(mprt_grid_create(s, n, n, n, 0, &g) == MPRT_OK);
    unsetenv("MPRT_IC_PACK");
    unsetenv("MPRT_IC_SIMD");
    unsetenv("MPRT_IC_BLOCKS");
    return g;
}

static void test_lanes(void)
{
    rng r;
    int mixed;
    rng_seed(&r, 5);
    for (mixed = 0; mixed < 2; mixed++) {
        mprt_scene *s = mesh_scene(mixed, &r);
        mprt_grid *g = grid_with(s, 4, NULL, "0", NULL);
        mprt__pack_test_fn avx2 = mprt__pack_test_avx2();
        CHECK(g->pack.kind == MPRT__PACK_PORTABLE && g->pack.test == mprt__pack_test_portable);
        lanes_agree(g, mprt__pack_test_portable, &r, "portable");
        if (avx2) lanes_agree(g, avx2, &r, "avx2");
        blocks_agree(g, mprt__block_test_portable, &r, "portable blocks");
        if (mprt__block_test_avx2()) blocks_agree(g, mprt__block_test_avx2(), &r, "avx2 blocks");
        else printf("test_ic_pack: no AVX2 copy in this build or on this processor; the portable copy alone\n");
        mprt_grid_destroy(g);
        mprt_scene_destroy(s);
    }
    {
        mprt_scene *s = mesh_scene(2, &r);
        mprt_grid *g = grid_with(s, 4, NULL, "0", NULL);
        mprt__ball_filter_fn avx2 = mprt__ball_filter_avx2();
        CHECK(g->pack.test == NULL && g->pack.filter == mprt__ball_filter_portable);
        filter_agrees(g, mprt__ball_filter_portable, &r, "portable filter");
        if (avx2) filter_agrees(g, avx2, &r, "avx2 filter");
        mprt_grid_destroy(g);
        mprt_scene_destroy(s);
    }
}

#define NQ 4000
#define NG 5 /* one at a time; portable; default; portable and default without blocks */

/* Intersect NQ rays on g; returns the counters. */
static mprt_counters walk(mprt_grid *g, const double *o, const double *d, double *t, int32_t *prim)
{
    mprt_counters c;
    memset(&c, 0, sizeof c);
    CHECK(mprt_grid_intersect(g, NQ, o, d, t, prim, &c) == MPRT_OK);
    return c;
}

static void test_walks_agree(void)
{
    static double o[3 * NQ], d[3 * NQ], t[NG][NQ];
    static int32_t prim[NG][NQ];
    static float img[NG][3 * 40 * 40];
    rng r;
    int mixed, n, i, m;
    rng_seed(&r, 9);
    for (i = 0; i < NQ; i++) aim(&r, i, o + 3 * i, d + 3 * i);
    for (mixed = 0; mixed < 3; mixed++) {
        mprt_scene *s = mesh_scene(mixed, &r);
        for (n = 1; n <= 9; n += 4) {
            mprt_grid *g[NG];
            mprt_counters c[NG];
            g[0] = grid_with(s, n, "0", NULL, NULL);
            g[1] = grid_with(s, n, NULL, "0", NULL);
            g[2] = grid_with(s, n, NULL, NULL, NULL);
            g[3] = grid_with(s, n, NULL, "0", "0");
            g[4] = grid_with(s, n, NULL, NULL, "0");
            CHECK((g[1]->pack.first != NULL) == (mixed < 2) && !g[3]->pack.first && !g[4]->pack.first);
            CHECK(g[0]->pack.kind == MPRT__PACK_NONE && !g[0]->pack.test && !g[0]->pack.filter);
            CHECK(g[1]->pack.kind == MPRT__PACK_PORTABLE && (g[1]->pack.test != NULL) == (mixed < 2));
            CHECK(g[2]->pack.kind == (mprt__pack_test_avx2() ? MPRT__PACK_AVX2 : MPRT__PACK_NONE));
            CHECK((g[1]->pack.filter != NULL) == (mixed > 0));
            for (m = 0; m < NG; m++) c[m] = walk(g[m], o, d, t[m], prim[m]);
            for (m = 1; m < NG; m++) {
                CHECK_MSG(memcmp(t[m], t[0], sizeof t[0]) == 0 && memcmp(prim[m], prim[0], sizeof prim[0]) == 0,
                          "grid %d, mixed %d, pack kind %d: hits differ", n, mixed, g[m]->pack.kind);
                CHECK_MSG(memcmp(&c[m], &c[0], sizeof c[0]) == 0, "grid %d, mixed %d, pack kind %d: counters differ",
                          n, mixed, g[m]->pack.kind);
            }
            CHECK(c[0].tests[MPRT_POLYGON] > 0 && (!mixed || (c[0].tests[MPRT_SPHERE] > 0 && c[0].tests[MPRT_CONE] > 0)));
            CHECK(mixed < 2 || c[0].tests[MPRT_CYLINDER] > 0);
            /* renders: shadow rays (first hit in list order), with and without the mailbox */
            {
                int mailbox;
                for (mailbox = 0; mailbox < 2; mailbox++) {
                    mprt_render_desc rd;
                    mprt_render_desc_init(&rd);
                    rd.width = rd.height = 40;
                    rd.mailbox = mailbox;
                    for (m = 0; m < NG; m++) {
                        memset(&c[m], 0, sizeof c[m]);
                        CHECK(mprt_grid_render(g[m], &rd, img[m], 3 * 40 * 40, &c[m]) == MPRT_OK);
                    }
                    for (m = 1; m < NG; m++) {
                        CHECK(memcmp(img[m], img[0], sizeof img[0]) == 0);
                        CHECK_MSG(memcmp(&c[m], &c[0], sizeof c[0]) == 0, "render, grid %d, mailbox %d: counters differ",
                                  n, mailbox);
                    }
                    CHECK(c[0].shadow_rays > 0);
                }
            }
            for (m = 0; m < NG; m++) mprt_grid_destroy(g[m]);
        }
        mprt_scene_destroy(s);
    }
}

int main(void)
{
    RUN(test_lanes);
    RUN(test_walks_agree);
    return CHECK_DONE();
}
