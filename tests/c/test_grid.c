/* test_grid.c: the voxel grid and the 3DDDA walk. */
#include "check.h"
#include "dda.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#ifdef MPRT_SINGLE
#define TOL 1e-4
#else
#define TOL 1e-9
#endif

static uint64_t rng_state;
static double rnd(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

/* A scene whose bounding box is exactly [0,8]^3: two spheres at opposite corners. */
static mprt_scene *cube_scene(void)
{
    mprt_scene *s;
    double c0[3] = {1, 1, 1}, c1[3] = {7, 7, 7};
    mprt_scene_create(&s);
    mprt_scene_add_sphere(s, c0, 1);
    mprt_scene_add_sphere(s, c1, 1);
    return s;
}

/* Walk a ray and check the walk's invariants: consecutive voxels share a
 * face, stretches tile [t0, t1] without gaps, each stretch's midpoint lies
 * in (or on the boundary of) its voxel, and the walk ends.  Returns the
 * number of voxels visited (or -1 on a violation). */
static int walk_checked(const mprt_grid *g, vec3 o, vec3 d, real tmax, int *cells, int maxcells)
{
    mprt__ray ray;
    mprt__dda w;
    int n = 0, prev[3] = {0, 0, 0};
    real prev_exit = 0;
    mprt__ray_prepare(&ray, o, d);
    if (!mprt__dda_start(g, &ray, 0, tmax, &w)) return 0;
    do {
        int a, diff = 0;
        vec3 mid = vmadd(o, d, (w.t_enter + w.t_exit) / 2);
        if (n > 0) {
            for (a = 0; a < 3; a++) diff += abs(w.cell[a] - prev[a]);
            CHECK_MSG(diff == 1, "voxels %d and %d are not face neighbours", n - 1, n);
            CHECK_MSG(w.t_enter == prev_exit, "gap between stretches at voxel %d", n);
            if (diff != 1) return -1;
        }
        CHECK(w.t_exit >= w.t_enter);
        for (a = 0; a < 3; a++) {
            double x = (double)vget(mid, a);
            double lo = (double)vget(g->lo, a) + w.cell[a] * (double)vget(g->cell, a);
            double hi = lo + (double)vget(g->cell, a);
            CHECK_MSG(x >= lo - TOL * 8 - (double)g->pad && x <= hi + TOL * 8 + (double)g->pad, "midpoint %g outside voxel [%g, %g] on axis %d", x, lo,
                      hi, a);
        }
        if (cells && n < maxcells) cells[n] = (int)w.voxel;
        for (a = 0; a < 3; a++) prev[a] = w.cell[a];
        prev_exit = w.t_exit;
        n++;
        if (n > g->n[0] + g->n[1] + g->n[2] + 3) {
            CHECK_MSG(0, "walk did not end after %d voxels", n);
            return -1;
        }
    } while (mprt__dda_next(g, &w));
    return n;
}

static mprt_grid *make_grid(const mprt_scene *s, int n)
{
    mprt_grid *g;
    int st = mprt_grid_create(s, n, n, n, 0, &g);
    CHECK_MSG(st == MPRT_OK, "%s", mprt_grid_errmsg(g));
    return g;
}

static void test_axis_parallel_rays_walk_one_row(void)
{
    mprt_scene *s = cube_scene();
    mprt_grid *g = make_grid(s, 8);
    int cells[16], k, a;
    for (a = 0; a < 3; a++) {
        vec3 o = v3(R(3.5), R(4.5), R(5.5)), d = v3(0, 0, 0);
        if (a == 0) { o.x = -1; d.x = 1; }
        if (a == 1) { o.y = -1; d.y = 1; }
        if (a == 2) { o.z = 9; d.z = -1; }
        CHECK(walk_checked(g, o, d, (real)INFINITY, cells, 16) == 8);
        for (k = 1; k < 8; k++) {
            int stride = a == 0 ? 1 : a == 1 ? 8 : -64;
            CHECK(cells[k] - cells[k - 1] == stride);
        }
    }
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

static void test_rays_on_voxel_faces_edges_and_corners_end(void)
{
    mprt_scene *s = cube_scene();
    mprt_grid *g = make_grid(s, 8);
    /* along a face (y = 4 exactly), along an edge (y = z = 4), through corners (diagonal) */
    CHECK(walk_checked(g, v3(-1, 4, R(2.5)), v3(1, 0, 0), (real)INFINITY, NULL, 0) == 8);
    CHECK(walk_checked(g, v3(-1, 4, 4), v3(1, 0, 0), (real)INFINITY, NULL, 0) == 8);
    /* the main diagonal passes through every voxel corner: x,y,z steps at each */
    CHECK(walk_checked(g, v3(-1, -1, -1), v3(1, 1, 1), (real)INFINITY, NULL, 0) == 22);
    /* along the outer faces of the box */
    CHECK(walk_checked(g, v3(0, 0, -5), v3(0, 0, 1), (real)INFINITY, NULL, 0) == 8);
    CHECK(walk_checked(g, v3(8, 8, 13), v3(0, 0, -1), (real)INFINITY, NULL, 0) == 8);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

static void test_start_inside_outside_and_miss(void)
{
    mprt_scene *s = cube_scene();
    mprt_grid *g = make_grid(s, 8);
    CHECK(walk_checked(g, v3(R(4.5), R(4.5), R(4.5)), v3(1, 0, 0), (real)INFINITY, NULL, 0) == 4);
    CHECK(walk_checked(g, v3(R(4.5), R(4.5), R(4.5)), v3(1, 0, 0), R(1.0), NULL, 0) == 2);
    CHECK(walk_checked(g, v3(-1, 9, 4), v3(1, 0, 0), (real)INFINITY, NULL, 0) == 0);
    CHECK(walk_checked(g, v3(-1, 4, 4), v3(-1, 0, 0), (real)INFINITY, NULL, 0) == 0);
    CHECK(walk_checked(g, v3(-1, 4, 4), v3(1, 0, 0), R(0.5), NULL, 0) == 0);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

static void test_random_rays_keep_the_walk_invariants(void)
{
    mprt_scene *s = cube_scene();
    int n, i;
    for (n = 1; n <= 13; n += 3) {
        mprt_grid *g = make_grid(s, n);
        rng_state = (uint64_t)n;
        for (i = 0; i < 2000; i++) {
            vec3 o = v3((real)(rnd() * 12 - 2), (real)(rnd() * 12 - 2), (real)(rnd() * 12 - 2));
            vec3 d = v3((real)(rnd() * 2 - 1), (real)(rnd() * 2 - 1), (real)(rnd() * 2 - 1));
            /* every fifth ray snaps its origin onto voxel boundaries */
            if (i % 5 == 0) o = v3((real)(int)(o.x * (real)n / 8) * 8 / (real)n, (real)(int)(o.y * (real)n / 8) * 8 / (real)n, o.z);
            if (walk_checked(g, o, d, (real)INFINITY, NULL, 0) < 0) break;
        }
        mprt_grid_destroy(g);
    }
    mprt_scene_destroy(s);
}

static void test_lists_are_conservative_and_stats_add_up(void)
{
    mprt_scene *s = cube_scene();
    mprt_grid *g = make_grid(s, 8);
    mprt_grid_stats st;
    long long v, refs = 0;
    CHECK(mprt_grid_get_stats(g, &st) == MPRT_OK);
    for (v = 0; v < g->voxels; v++) refs += g->start[v + 1] - g->start[v];
    CHECK(refs == st.refs);
    /* a unit sphere at (1,1,1) in 1-wide voxels touches the 3x3x3 block
     * around it except voxels entirely inside it (none: radius 1, voxel
     * diagonal sqrt(3) > 1); the 8 voxels with a corner at the centre are
     * inside the sphere's bounding box and touch its surface. */
    CHECK(st.nonempty >= 16 && st.nonempty <= 54);
    CHECK(st.max_len == 1);
    CHECK(st.lo[0] == 0 && st.hi[2] == 8);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

static void test_bad_subdivisions_and_memory_limits_are_errors(void)
{
    mprt_scene *s = cube_scene(), *empty;
    mprt_grid *g;
    CHECK(mprt_grid_create(s, 0, 4, 4, 0, &g) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_grid_errmsg(g), "1..1024") != NULL);
    mprt_grid_destroy(g);
    CHECK(mprt_grid_create(s, 1025, 4, 4, 0, &g) == MPRT_ERR_INVALID_ARG);
    mprt_grid_destroy(g);
    CHECK(mprt_grid_create(s, 1024, 1024, 1024, 1 << 20, &g) == MPRT_ERR_OUT_OF_MEMORY);
    CHECK(strstr(mprt_grid_errmsg(g), "allowed") != NULL);
    mprt_grid_destroy(g);
    mprt_scene_create(&empty);
    CHECK(mprt_grid_create(empty, 4, 4, 4, 0, &g) == MPRT_ERR_STATE);
    mprt_grid_destroy(g);
    mprt_scene_destroy(empty);
    mprt_scene_destroy(s);
}

static void test_intersect_matches_one_voxel_grid(void)
{
    /* Many random spheres; the 1x1x1 grid is a brute-force search. */
    mprt_scene *s;
    mprt_grid *g1, *g;
    int i, n, bad = 0;
    enum { NR = 3000 };
    static double o[3 * NR], d[3 * NR], t1[NR], t2[NR];
    static int32_t p1[NR], p2[NR];
    mprt_scene_create(&s);
    rng_state = 7;
    for (i = 0; i < 300; i++) {
        double c[3] = {rnd() * 10, rnd() * 10, rnd() * 10};
        mprt_scene_add_sphere(s, c, 0.05 + rnd() * 0.5);
    }
    for (i = 0; i < 3 * NR; i++) {
        o[i] = rnd() * 14 - 2;
        d[i] = rnd() * 2 - 1;
    }
    g1 = make_grid(s, 1);
    CHECK(mprt_grid_intersect(g1, NR, o, d, t1, p1, NULL) == MPRT_OK);
    for (n = 2; n <= 40; n = n * 2 + 1) {
        g = make_grid(s, n);
        CHECK(mprt_grid_intersect(g, NR, o, d, t2, p2, NULL) == MPRT_OK);
        for (i = 0; i < NR; i++) bad += t1[i] != t2[i] || p1[i] != p2[i];
        mprt_grid_destroy(g);
    }
    CHECK_MSG(bad == 0, "%d rays differ from brute force", bad);
    mprt_grid_destroy(g1);
    mprt_scene_destroy(s);
}

/* A scene destroyed while grids are built on it lives on until the last of them goes (under
 * ASan, a use after free otherwise); the grids work meanwhile. */
static void test_a_scene_destroyed_first_waits_for_its_grids(void)
{
    mprt_scene *s = cube_scene();
    mprt_grid *g = make_grid(s, 8), *h = make_grid(s, 4);
    mprt_scene_destroy(s);
    CHECK(walk_checked(g, v3(-1, R(3.5), R(2.5)), v3(1, 0, 0), (real)INFINITY, NULL, 0) == 8);
    mprt_grid_destroy(g);
    CHECK(walk_checked(h, v3(-1, R(1.5), R(1.5)), v3(1, 0, 0), (real)INFINITY, NULL, 0) == 4);
    mprt_grid_destroy(h);
}

int main(void)
{
    RUN(test_axis_parallel_rays_walk_one_row);
    RUN(test_rays_on_voxel_faces_edges_and_corners_end);
    RUN(test_start_inside_outside_and_miss);
    RUN(test_random_rays_keep_the_walk_invariants);
    RUN(test_lists_are_conservative_and_stats_add_up);
    RUN(test_bad_subdivisions_and_memory_limits_are_errors);
    RUN(test_intersect_matches_one_voxel_grid);
    RUN(test_a_scene_destroyed_first_waits_for_its_grids);
    return CHECK_DONE();
}
