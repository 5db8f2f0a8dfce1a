/* test_pinned.c: hard cases pinned with their exact floats (C99 hexadecimal
 * literals), so they are tested bit for bit on every run.
 *
 * Rays through shared terrain edges: rays aimed at the vertices and edge
 * midpoints of SPD mount (size 4), found by a search in which a plain
 * Moller-Trumbore triangle test let them through the terrain (it misses
 * every triangle; the check below keeps that true, so each case stays a
 * hard one).  The watertight test must hit.
 *
 * A hit on the grid box's face: an eye ray of SPD balls (size 1, 24x24,
 * paper rules) that hits the floor, which lies on the low face of the grid
 * box; the 3DDDA walk ends before the voxel whose stretch reaches the hit,
 * so OS must hand the held hit to SC (outcome late_hit).
 *
 * The hit primitives and distances are pinned regression numbers, taken from
 * the double-precision build when the cases were pinned; the independent
 * checks are: a hit at all, the same hit through every grid, and the walk's
 * outcome.  An MPRT_SINGLE build runs the same rays in float and checks
 * those independent properties only. */
#include "check.h"
#include "mprt_internal.h"
#include "render.h"

#include <stdlib.h>
#include <string.h>

typedef struct {
    double origin[3], dir[3];
    int32_t prim;   /* pinned (double build) */
    double t;       /* pinned (double build) */
} pinned_ray;

static const pinned_ray terrain_rays[] = {
    {{0x1.541576e40e71ap-1, -0x1.31f1a50c66dfbp+0, 0x1.806574d85cf91p+1},
     {-0x1.ac74930134220p-7, 0x1.029786bb33d4fp-2, -0x1p+0}, 199, 0x1.8p+1},
    {{0x1.0b3d225abb290p-5, 0x1.95d7f1c740a5ap-1, 0x1.a4add77560e4ep+1},
     {-0x1.6b9a6d878f98cp-3, -0x1.e4ea84be01b9ap-4, -0x1p+0}, 408, 0x1.8000000000002p+1},
    {{-0x1.206ef4737ec2cp-1, -0x1.0453532a6d75fp+0, 0x1.91666778ce231p+1},
     {0x1.d5e945ef53ae6p-3, 0x1.c1bc66379d1fcp-4, -0x1p+0}, 156, 0x1.7ffffffffffffp+1},
};

static const pinned_ray floor_ray = {
    {0x1.0cccccccccccdp+1, 0x1.4cccccccccccdp+0, 0x1.b333333333333p+0},
    {-0x1.2d518ea4778e6p-1, -0x1.91bf987b30550p-1, -0x1.8efc2e277ea41p-3}, 0, 0x1.695d698cb67f2p+3};

#define NTERRAIN ((int)(sizeof terrain_rays / sizeof terrain_rays[0]))

#ifndef MPRT_SINGLE
/* (the plain test runs on the double-precision cases only) */
static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Plain Moller-Trumbore (not watertight): 1 when the ray hits triangle abc at t > 0. */
static int plain_hit(const double o[3], const double d[3], const double *a, const double *b, const double *c)
{
    double e1[3], e2[3], p[3], q[3], tv[3], det, u, v;
    int k;
    for (k = 0; k < 3; k++) {
        e1[k] = b[k] - a[k];
        e2[k] = c[k] - a[k];
        tv[k] = o[k] - a[k];
    }
    cross(d, e2, p);
    det = dot(e1, p);
    if (det == 0) return 0;
    u = dot(tv, p) / det;
    if (u < 0 || u > 1) return 0;
    cross(tv, e1, q);
    v = dot(d, q) / det;
    if (v < 0 || u + v > 1) return 0;
    return dot(e2, q) / det > 0;
}

/* Triangles of the scene hit by the plain test. */
static int plain_hits(const mprt_scene *s, const pinned_ray *r)
{
    mprt_scene_info info;
    int32_t *ids, *vstart;
    double *verts;
    long long k, n;
    int hits = 0;
    mprt_scene_get_info(s, &info);
    n = info.count[MPRT_POLYGON];
    ids = malloc((size_t)n * sizeof *ids);
    vstart = malloc((size_t)(n + 1) * sizeof *vstart);
    verts = malloc((size_t)info.vertices * 3 * sizeof *verts);
    CHECK(mprt_scene_get_polygons(s, ids, vstart, (size_t)n, verts, (size_t)info.vertices) == MPRT_OK);
    for (k = 0; k < n; k++)
        if (vstart[k + 1] - vstart[k] == 3) {
            const double *v = verts + 3 * vstart[k];
            hits += plain_hit(r->origin, r->dir, v, v + 3, v + 6);
        }
    free(ids);
    free(vstart);
    free(verts);
    return hits;
}
#endif

/* The hit of r through grids of n^3 for several n: the same everywhere. */
static void check_grid_independent(const mprt_scene *s, const pinned_ray *r, int32_t *prim, double *t)
{
    static const int subdivisions[] = {1, 4, 7, 13};
    int k;
    for (k = 0; k < 4; k++) {
        mprt_grid *g;
        double tk;
        int32_t pk;
        int n = subdivisions[k];
        CHECK(mprt_grid_create(s, n, n, n, 0, &g) == MPRT_OK);
        CHECK(mprt_grid_intersect(g, 1, r->origin, r->dir, &tk, &pk, NULL) == MPRT_OK);
        if (k == 0) {
            *prim = pk;
            *t = tk;
        }
        CHECK_MSG(pk == *prim && tk == *t, "grid %d: prim %d t %a, grid 1: prim %d t %a", n, (int)pk, tk,
                  (int)*prim, *t);
        mprt_grid_destroy(g);
    }
}

static void test_rays_through_shared_terrain_edges_do_not_leak(void)
{
    mprt_scene *s;
    int k;
    mprt_scene_create(&s);
    CHECK(mprt_scene_spd(s, "mount", 4) == MPRT_OK);
    for (k = 0; k < NTERRAIN; k++) {
        const pinned_ray *r = &terrain_rays[k];
        int32_t prim;
        double t;
        check_grid_independent(s, r, &prim, &t);
        CHECK_MSG(prim >= 0, "terrain ray %d leaks", k);
#ifndef MPRT_SINGLE
        CHECK_MSG(plain_hits(s, r) == 0, "terrain ray %d is no longer a hard case", k);
        CHECK_MSG(prim == r->prim && t == r->t, "terrain ray %d: prim %d t %a (pinned %d %a)", k, (int)prim, t,
                  (int)r->prim, r->t);
#endif
    }
    mprt_scene_destroy(s);
}

#ifndef MPRT_SINGLE
/* The outcome of the last OS visit of ray r's walk through g. */
static int last_os_outcome(const mprt_grid *g, const pinned_ray *r)
{
    mprt_trace_visit visits[64];
    mprt__recorder recorder;
    mprt__sink sink;
    mprt__ray ray;
    mprt__hit hit;
    memset(&recorder, 0, sizeof recorder);
    recorder.visits = visits;
    recorder.cap_visits = 64;
    memset(&sink.counters, 0, sizeof sink.counters);
    sink.recorder = &recorder;
    sink.bad_prim = -1;
    mprt__ray_prepare(&ray, v3((real)r->origin[0], (real)r->origin[1], (real)r->origin[2]),
                      v3((real)r->dir[0], (real)r->dir[1], (real)r->dir[2]));
    mprt__os_ic(g, &ray, 0, (real)INFINITY, 0, 0, &hit, &sink, 0, MPRT_RAY_PRIMARY);
    CHECK(recorder.nvisits >= 1 && recorder.nvisits <= 64);
    if (recorder.nvisits < 1 || recorder.nvisits > 64) return -1;
    CHECK(visits[recorder.nvisits - 1].stage == MPRT_STAGE_OS);
    return visits[recorder.nvisits - 1].outcome;
}
#endif

static void test_a_hit_on_the_grid_box_face_is_handed_on_by_os(void)
{
    mprt_scene *s;
    mprt_grid *g;
    mprt_scene_info info;
    int32_t prim;
    double t;
    mprt_scene_create(&s);
    CHECK(mprt_scene_spd(s, "balls", 1) == MPRT_OK);
    mprt_scene_get_info(s, &info);
    check_grid_independent(s, &floor_ray, &prim, &t);
    CHECK_MSG(prim == 0, "the floor (primitive 0), not %d", (int)prim);
    /* the floor is the low z face of the scene's box */
    CHECK_NEAR(floor_ray.origin[2] + t * floor_ray.dir[2], info.lo[2], 1e-5);
#ifndef MPRT_SINGLE
    CHECK_MSG(t == floor_ray.t, "t %a (pinned %a)", t, floor_ray.t);
    CHECK(mprt_grid_create(s, 4, 4, 4, 0, &g) == MPRT_OK);
    CHECK(last_os_outcome(g, &floor_ray) == MPRT_OUT_LATE_HIT);
    mprt_grid_destroy(g);
#else
    (void)g;
#endif
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_rays_through_shared_terrain_edges_do_not_leak);
    RUN(test_a_hit_on_the_grid_box_face_is_handed_on_by_os);
    return CHECK_DONE();
}
