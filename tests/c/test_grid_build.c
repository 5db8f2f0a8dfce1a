/* test_grid_build.c: the fast grid build gives the plain one's grid, bit for
 * bit.  mprt__grid_create_reference keeps the plain per-voxel build (every
 * voxel of a primitive's bounds tested with the primitive's own box test);
 * the grids mprt_grid_create makes must have the same lists (start table and
 * primitive ids), the same empty flags and jump values, the same macro cells,
 * and fail the same way: on the six SPD scenes at small sizes over cubic and
 * anisotropic subdivisions, and on random and degenerate polygons (concave,
 * non-planar within tolerance, axis-aligned, on voxel boundaries, tiny, huge,
 * far from the origin), with spheres and cones among them, where the rounding allowances differ from voxel to
 * voxel; for the exact listing and, on most of these, the occupied one (voxel boxes shrunk, not grown).  Full-size scenes at the prepass's subdivisions:
 * studies/03_bench/build.py --before. */
#include "check.h"
#include "geom.h"
#include "grid_reference.h"
#undef PI
#include "spd_check.h"

#include <string.h>

static long long grids_compared, entries_compared, jumps_single, jumps_macro;

/* Build both ways and compare everything the build makes. */
static void same_grid(const mprt_scene *s, int nx, int ny, int nz, int listing, const char *what)
{
    mprt_grid *a = NULL, *b = NULL;
    int sa = mprt__grid_create_reference(s, nx, ny, nz, 0, listing, &a);
    int sb = mprt_grid_create_listing(s, nx, ny, nz, 0, listing, &b);
    int k;
    CHECK_MSG(sa == sb, "%s %dx%dx%d: status %d vs %d", what, nx, ny, nz, sa, sb);
    CHECK_MSG(strcmp(mprt_grid_errmsg(a), mprt_grid_errmsg(b)) == 0, "%s: '%s' vs '%s'", what, mprt_grid_errmsg(a),
              mprt_grid_errmsg(b));
    if (sa == MPRT_OK && sb == MPRT_OK) {
        size_t nv = (size_t)a->voxels;
        CHECK_MSG(a->refs == b->refs, "%s %dx%dx%d listing %d: %lld vs %lld entries", what, nx, ny, nz, listing,
                  a->refs, b->refs);
        CHECK_MSG(memcmp(a->start, b->start, (nv + 1) * sizeof *a->start) == 0, "%s %dx%dx%d: start tables differ",
                  what, nx, ny, nz);
        if (a->refs == b->refs)
            CHECK_MSG(memcmp(a->ids, b->ids, (size_t)a->refs * sizeof *a->ids) == 0, "%s %dx%dx%d: ids differ", what,
                      nx, ny, nz);
        CHECK_MSG(memcmp(a->empty, b->empty, nv) == 0, "%s %dx%dx%d: empty flags or jumps differ", what, nx, ny, nz);
        CHECK(a->jump_min == b->jump_min && a->jump_far == b->jump_far);
        for (k = 0; k < 3; k++) {
            CHECK(a->macro[k] == b->macro[k]);
            if (a->macro_lo[k] && b->macro_lo[k])
                CHECK(memcmp(a->macro_lo[k], b->macro_lo[k], (size_t)a->n[k] * sizeof(int)) == 0);
            else
                CHECK(!a->macro_lo[k] && !b->macro_lo[k]);
        }
        grids_compared++;
        entries_compared += a->refs;
        for (k = 0; k < (int)nv; k++)
            if (a->empty[k] >= 3) {
                if (a->macro[0] == 1 && a->macro[1] == 1 && a->macro[2] == 1) jumps_single++;
                else jumps_macro++;
            }
    }
    mprt_grid_destroy(a);
    mprt_grid_destroy(b);
}

static const int dims[][3] = {{1, 1, 1},  {4, 4, 4},  {9, 9, 9},  {16, 16, 16}, {3, 17, 5},  {31, 2, 9},
                              {40, 40, 3}, {1, 60, 7}, {7, 1, 45}, {23, 29, 31}, {64, 64, 16}, {100, 100, 25}, {21, 21, 5}};
#define NDIMS ((int)(sizeof dims / sizeof dims[0]))

static void test_spd_scenes(void)
{
    int i, d, size;
    for (i = 0; i < NSCENES; i++)
        for (size = 1; size <= 2; size++) {
            mprt_scene *s = gen(names[i], size);
            if (!s) continue;
            for (d = 0; d < NDIMS; d++) same_grid(s, dims[d][0], dims[d][1], dims[d][2], MPRT_LIST_EXACT, names[i]);
            same_grid(s, 9, 5, 13, MPRT_LIST_BOX, names[i]);
            same_grid(s, 9, 5, 13, MPRT_LIST_BOX_OUTWARD, names[i]);
            same_grid(s, 9, 5, 13, MPRT_LIST_OCCUPIED, names[i]);
            same_grid(s, 16, 16, 16, MPRT_LIST_OCCUPIED, names[i]);
            mprt_scene_destroy(s);
        }
}

/* A polygon through the library's own validation: added when valid. */
static void add_poly(mprt_scene *s, int n, const double *v) { (void)mprt_scene_add_polygon(s, n, v, NULL); }

/* n outline points (x, y) into plane pl, scaled by r, each lifted off the plane by h[i]. */
static void outline_poly(mprt_scene *s, const plane3 *pl, int n, const double *x, const double *y, double r,
                         const double *h)
{
    double v[3 * 64];
    int i;
    for (i = 0; i < n; i++) plane_point(pl, r * x[i], r * y[i], h ? h[i] : 0, v + 3 * i);
    add_poly(s, n, v);
}

/* Random polygons of every awkward kind, and spheres and cones, in a box about centre c of size L. */
static mprt_scene *random_scene(rng *r, double c, double L, int count)
{
    mprt_scene *s;
    double x[64], y[64], h[64], v[3 * 8];
    int i, j, n;
    mprt_scene_create(&s);
    for (i = 0; i < count; i++) {
        plane3 pl;
        int kind = rnd_int(r, 0, 8);
        double R = L * rnd_in(r, 0.01, 0.4);
        plane_make(&pl, r, c + rnd_in(r, -L, L), c + rnd_in(r, -L, L), c + rnd_in(r, -L, L));
        switch (kind) {
        case 0: /* convex, random vertex count */
            n = rnd_int(r, 3, 9);
            for (j = 0; j < n; j++) {
                x[j] = cos(2 * PI * j / n);
                y[j] = sin(2 * PI * j / n);
            }
            outline_poly(s, &pl, n, x, y, R, NULL);
            break;
        case 1: /* concave gear outline */
            n = 4 * rnd_int(r, 3, 15);
            gear_outline(n, x, y);
            outline_poly(s, &pl, n, x, y, R, NULL);
            break;
        case 2: /* non-planar within the tolerance (1e-6 of the extent) */
            n = 4 * rnd_int(r, 1, 8);
            gear_outline(n, x, y);
            for (j = 0; j < n; j++) h[j] = rnd_in(r, -4e-7, 4e-7) * R;
            outline_poly(s, &pl, n, x, y, R, h);
            break;
        case 3: /* axis-aligned rectangle, its plane and edges on simple values */
        {
            int a = rnd_int(r, 0, 2), b = (a + 1) % 3, e = (a + 2) % 3;
            double p0 = c + (double)rnd_int(r, -8, 8) * L / 8, lo1 = c - L * rnd(r), hi1 = c + L * rnd(r);
            double lo2 = c - L * rnd(r), hi2 = c + L * rnd(r);
            double q[4][2] = {{lo1, lo2}, {hi1, lo2}, {hi1, hi2}, {lo1, hi2}};
            for (j = 0; j < 4; j++) {
                v[3 * j + a] = p0;
                v[3 * j + b] = q[j][0];
                v[3 * j + e] = q[j][1];
            }
            add_poly(s, 4, v);
            break;
        }
        case 4: /* tiny triangle */
            for (j = 0; j < 3; j++) {
                x[j] = rnd_in(r, -1, 1);
                y[j] = rnd_in(r, -1, 1);
            }
            outline_poly(s, &pl, 3, x, y, L * 1e-7, NULL);
            break;
        case 5: /* huge: far beyond the others */
            n = 4;
            for (j = 0; j < n; j++) {
                x[j] = cos(2 * PI * j / n + 0.3);
                y[j] = sin(2 * PI * j / n + 0.3);
            }
            outline_poly(s, &pl, n, x, y, L * 30, NULL);
            break;
        case 7: /* a sphere */
        {
            double cc[3];
            plane_point(&pl, 0, 0, 0, cc);
            mprt_scene_add_sphere(s, cc, R);
            break;
        }
        case 8: /* a cone or cylinder, often along an axis */
        {
            double b0[3], b1[3];
            plane_point(&pl, 0, 0, 0, b0);
            plane_point(&pl, 0, 0, 2 * R, b1);
            if (rnd_int(r, 0, 1)) b1[0] = b0[0], b1[1] = b0[1];
            mprt_scene_add_cone(s, b0, R * rnd_in(r, 0.1, 1), b1, rnd_int(r, 0, 1) ? 0 : R * rnd(r));
            break;
        }
        case 6: /* a thin sliver along a diagonal */
            x[0] = -1, y[0] = 0, x[1] = 1, y[1] = 1e-3, x[2] = 1, y[2] = -1e-3;
            outline_poly(s, &pl, 3, x, y, R * 3, NULL);
            break;
        default:
            break;
        }
    }
    return s;
}

static void test_random_polygons(void)
{
    static const double centres[][2] = {{0, 1}, {0, 1000}, {1000, 1}, {-3.5e5, 10}, {1e-3, 1e-3}};
    rng r;
    int t, d;
    rng_seed(&r, 20261123);
    for (t = 0; t < 60; t++) {
        const double *cl = centres[t % 5];
        mprt_scene *s = random_scene(&r, cl[0], cl[1], rnd_int(&r, 1, 12));
        for (d = 0; d < 4; d++) {
            int nx = rnd_int(&r, 1, 40), ny = rnd_int(&r, 1, 40), nz = rnd_int(&r, 1, 40);
            same_grid(s, nx, ny, nz, MPRT_LIST_EXACT, "random polygons");
            if (d == 0) same_grid(s, nx, ny, nz, MPRT_LIST_OCCUPIED, "random polygons");
        }
        mprt_scene_destroy(s);
    }
}

/* Vertices exactly on voxel boundaries: a grid over [0, 8]^3 (a sphere at each
 * corner fixes the box) with polygons whose vertices and planes sit on the
 * integer lattice and on half and quarter voxels. */
static void test_boundary_polygons(void)
{
    static const double c0[3] = {0.5, 0.5, 0.5}, c1[3] = {7.5, 7.5, 7.5};
    rng r;
    int t, j, d;
    rng_seed(&r, 7);
    for (t = 0; t < 10; t++) {
        mprt_scene *s;
        mprt_scene_create(&s);
        mprt_scene_add_sphere(s, c0, 0.5);
        mprt_scene_add_sphere(s, c1, 0.5);
        for (j = 0; j < 12; j++) {
            double v[12];
            int k, n = rnd_int(&r, 3, 4);
            for (k = 0; k < 3 * n; k++) v[k] = (double)rnd_int(&r, 0, 32) / 4;
            if (rnd_int(&r, 0, 1)) /* axis-aligned: one coordinate shared */
                for (k = 1; k < n; k++) v[3 * k + j % 3] = v[j % 3];
            add_poly(s, n, v);
        }
        for (d = 0; d < 5; d++) {
            static const int nd[5][3] = {{8, 8, 8}, {16, 16, 16}, {4, 8, 32}, {32, 1, 2}, {5, 7, 9}};
            same_grid(s, nd[d][0], nd[d][1], nd[d][2], MPRT_LIST_EXACT, "boundary polygons");
            same_grid(s, nd[d][0], nd[d][1], nd[d][2], MPRT_LIST_OCCUPIED, "boundary polygons");
        }
        mprt_scene_destroy(s);
    }
}

/* A big polygon beside small far-away primitives: the grid's box, not the
 * polygon, sets the rounding allowance of many of its voxels. */
static void test_mixed_magnitudes(void)
{
    static const double far[3] = {900, -700, 800}, cb[3] = {-50, 20, 0}, ca[3] = {-40, 30, 5};
    double v[3 * 48], x[48], y[48];
    plane3 pl;
    mprt_scene *s;
    rng r;
    int j;
    rng_seed(&r, 99);
    mprt_scene_create(&s);
    mprt_scene_add_sphere(s, far, 3);
    mprt_scene_add_cone(s, cb, 2, ca, 1);
    plane_make(&pl, &r, 1, 2, 3);
    gear_outline(48, x, y);
    for (j = 0; j < 48; j++) plane_point(&pl, 400 * x[j], 400 * y[j], 0, v + 3 * j);
    add_poly(s, 48, v);
    same_grid(s, 50, 50, 50, MPRT_LIST_EXACT, "mixed magnitudes");
    same_grid(s, 97, 13, 61, MPRT_LIST_EXACT, "mixed magnitudes");
    same_grid(s, 97, 13, 61, MPRT_LIST_OCCUPIED, "mixed magnitudes");
    mprt_scene_destroy(s);
}

/* Failures come out the same: a memory bound the lists exceed. */
static void test_same_failures(void)
{
    mprt_scene *s = gen("gears", 1);
    mprt_grid *a = NULL, *b = NULL;
    int sa, sb;
    if (!s) return;
    sa = mprt__grid_create_reference(s, 30, 30, 30, 150000, MPRT_LIST_EXACT, &a);
    sb = mprt_grid_create_listing(s, 30, 30, 30, 150000, MPRT_LIST_EXACT, &b);
    CHECK(sa == MPRT_ERR_OUT_OF_MEMORY && sb == sa);
    CHECK_MSG(strcmp(mprt_grid_errmsg(a), mprt_grid_errmsg(b)) == 0, "'%s' vs '%s'", mprt_grid_errmsg(a),
              mprt_grid_errmsg(b));
    mprt_grid_destroy(a);
    mprt_grid_destroy(b);
    mprt_scene_destroy(s);
}

int main(void)
{
    /* jumps are off by default: ask for them, so that the jump values are built and compared */
    setenv("MPRT_SKIP", "1", 1);
    RUN(test_spd_scenes);
    RUN(test_random_polygons);
    RUN(test_boundary_polygons);
    RUN(test_mixed_magnitudes);
    RUN(test_same_failures);
    /* the comparisons above compared real grids, not empty ones */
    CHECK(grids_compared > 400 && entries_compared > 500000 && jumps_single > 10000 && jumps_macro > 10000);
    printf("compared %lld grids, %lld list entries, %lld + %lld voxels to jump from (single-voxel macro cells or not)\n",
           grids_compared, entries_compared, jumps_single, jumps_macro);
    return CHECK_DONE();
}
