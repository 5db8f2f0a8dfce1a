/* test_packets.c: mprt_grid_intersect's rays four at a time (packet.c,
 * MPRT_PACKETS=1; the AVX2 loop where this build and processor have it,
 * and the portable loop, MPRT_PACKET_SIMD=0) give the same hits, t (bits)
 * and counters as one ray at a time: on a triangle mesh whose vertices lie
 * on voxel planes mixed with spheres, quads and cones, rays aimed at its
 * vertices and edges, along the axes and anywhere; on cubic and uneven
 * grids, and on grids that jump over empty blocks (MPRT_JUMP_MIN); each
 * batch of 2 or 3 rays counting what its rays count alone; a batch with a
 * NaN ray failing as before.  Run under ASan/UBSan (make asan) and with
 * float geometry (make single: the portable loop alone). */
#include "check.h"
#include "geom.h"
#include "grid.h"

#include <stdlib.h>
#include <string.h>

#define NQ 3000

static mprt_scene *mixed_scene(rng *r)
{
    mprt_scene *s;
    int i, j;
    mprt_scene_create(&s);
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) {
            double z00 = (i + j) % 3, z10 = (i + 1 + j) % 3, z01 = (i + j + 1) % 3, z11 = (i + j + 2) % 3;
            double a[9] = {i, j, z00, i + 1, j, z10, i + 1, j + 1, z11};
            double b[9] = {i, j, z00, i + 1, j + 1, z11, i, j + 1, z01};
            CHECK(mprt_scene_add_polygon(s, 3, a, NULL) == MPRT_OK);
            CHECK(mprt_scene_add_polygon(s, 3, b, NULL) == MPRT_OK);
            if ((i + j) % 2 == 0) {
                double c[3] = {i + 0.5, j + 0.5, 1.5}, q[12] = {i, j, 3, i + 1, j, 3, i + 1, j + 1, 3, i, j + 1, 3};
                double base[3] = {i + 0.2, j + 0.3, 0.5}, apex[3] = {i + 0.7, j + 0.6, 2.5};
                CHECK(mprt_scene_add_sphere(s, c, rnd_in(r, 0.1, 0.6)) == MPRT_OK);
                CHECK(mprt_scene_add_polygon(s, 4, q, NULL) == MPRT_OK);
                CHECK(mprt_scene_add_cone(s, base, 0.3, apex, (i + j) % 4 ? 0.1 : 0.3) == MPRT_OK);
            }
        }
    {
        double t[9] = {0, 0, 4, 0.5, 0, 4, 0, 0.5, 4}; /* the box's top corner: the grid is [0, 4]^3 */
        CHECK(mprt_scene_add_polygon(s, 3, t, NULL) == MPRT_OK);
    }
    return s;
}

/* A ray aimed at a mesh vertex, an edge's midpoint, along an axis, or anywhere. */
static void aim(rng *r, int i, double o[3], double d[3])
{
    double p[3];
    int k;
    for (k = 0; k < 3; k++) o[k] = rnd_in(r, -2, 6);
    switch (i % 4) {
    case 0: p[0] = rnd_int(r, 0, 4), p[1] = rnd_int(r, 0, 4), p[2] = rnd_int(r, 0, 2); break;
    case 1: p[0] = rnd_int(r, 0, 4) + 0.5, p[1] = rnd_int(r, 0, 4) + 0.5, p[2] = rnd_int(r, 0, 2) * 0.5; break;
    case 2: /* axis-parallel through a vertex or an edge */
        p[0] = rnd_int(r, 0, 4), p[1] = rnd_int(r, 0, 4), p[2] = rnd_int(r, 0, 2);
        o[0] = p[0], o[1] = p[1], o[2] = 7;
        if (i % 8 == 2) o[2] = p[2], o[1] = -1;
        break;
    default: for (k = 0; k < 3; k++) p[k] = rnd_in(r, 0, 4); break;
    }
    for (k = 0; k < 3; k++) d[k] = p[k] - o[k];
    if (d[0] == 0 && d[1] == 0 && d[2] == 0) d[2] = -1;
}

/* Rays [first, first + n) on g with the lanes as mode says: 0 off, 1 on, 2 the portable loop. */
static int run(mprt_grid *g, int mode, size_t first, size_t n, const double *o, const double *d, double *t,
               int32_t *prim, mprt_counters *c)
{
    int status;
    if (mode) setenv("MPRT_PACKETS", "1", 1);
    if (mode == 2) setenv("MPRT_PACKET_SIMD", "0", 1);
    memset(c, 0, sizeof *c);
    status = mprt_grid_intersect(g, n, o + 3 * first, d + 3 * first, t + first, prim + first, c);
    unsetenv("MPRT_PACKETS");
    unsetenv("MPRT_PACKET_SIMD");
    return status;
}

static void test_lanes_agree(void)
{
    static double o[3 * NQ], d[3 * NQ], t[3][NQ];
    static int32_t prim[3][NQ];
    const int grids[][3] = {{1, 1, 1}, {4, 4, 4}, {9, 9, 9}, {8, 3, 5}, {16, 16, 16}};
    mprt_scene *s;
    rng r;
    int gi, m, jumps;
    size_t i;
    rng_seed(&r, 21);
    s = mixed_scene(&r);
    for (i = 0; i < NQ; i++) aim(&r, (int)i, o + 3 * i, d + 3 * i);
    for (jumps = 0; jumps < 2; jumps++)
        for (gi = 0; gi < (int)(sizeof grids / sizeof grids[0]); gi++) {
            mprt_grid *g = NULL;
            mprt_counters c[3];
            if (jumps) setenv("MPRT_JUMP_MIN", "2", 1);
            CHECK(mprt_grid_create(s, grids[gi][0], grids[gi][1], grids[gi][2], 0, &g) == MPRT_OK);
            unsetenv("MPRT_JUMP_MIN");
            for (m = 0; m < 3; m++) CHECK(run(g, m, 0, NQ, o, d, t[m], prim[m], &c[m]) == MPRT_OK);
            for (m = 1; m < 3; m++) {
                CHECK_MSG(memcmp(t[m], t[0], sizeof t[0]) == 0 && memcmp(prim[m], prim[0], sizeof prim[0]) == 0,
                          "grid %d, jumps %d, mode %d: hits differ", gi, jumps, m);
                CHECK_MSG(memcmp(&c[m], &c[0], sizeof c[0]) == 0, "grid %d, jumps %d, mode %d: counters differ", gi,
                          jumps, m);
            }
            CHECK(c[0].hits > 500 && c[0].tests[MPRT_POLYGON] > 0 && c[0].tests[MPRT_CONE] > 0);
            /* each ray's own counts: batches of 2 and 3 */
            for (i = 0; i + 3 <= NQ / 4; i += 2 + i % 2) {
                const size_t k = 2 + i % 2;
                mprt_counters a, b;
                CHECK(run(g, 0, i, k, o, d, t[0], prim[0], &a) == MPRT_OK);
                CHECK(run(g, 1, i, k, o, d, t[1], prim[1], &b) == MPRT_OK);
                CHECK_MSG(memcmp(&a, &b, sizeof a) == 0, "grid %d: rays %zu.. counted otherwise", gi, i);
            }
            mprt_grid_destroy(g);
        }
    mprt_scene_destroy(s);
}

static void test_bad_ray(void)
{
    static double o[3 * 64], d[3 * 64], t[64];
    static int32_t prim[64];
    mprt_scene *s;
    mprt_grid *g = NULL;
    mprt_counters c;
    rng r;
    int i, mode;
    rng_seed(&r, 4);
    s = mixed_scene(&r);
    for (i = 0; i < 64; i++) aim(&r, i, o + 3 * i, d + 3 * i);
    d[3 * 40 + 1] = NAN;
    for (mode = 0; mode < 2; mode++) {
        CHECK(mprt_grid_create(s, 4, 4, 4, 0, &g) == MPRT_OK);
        CHECK(run(g, mode, 0, 64, o, d, t, prim, &c) == MPRT_ERR_INVALID_ARG);
        CHECK(strstr(mprt_grid_errmsg(g), "ray 40") != NULL);
        mprt_grid_destroy(g);
    }
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_lanes_agree);
    RUN(test_bad_ray);
    return CHECK_DONE();
}
