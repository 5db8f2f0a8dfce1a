/* test_ic.c: IC's copy of the primitives (ic.h) decides every test as the
 * scene-level routines do.  The grid packs each primitive's kind and index
 * into one word, spheres and cone frusta into bounding balls tested first,
 * triangles into records of their own; for every primitive of a scene with
 * every kind (spheres, triangles, quads, cylinders, cones), over rays that
 * mostly aim at a primitive (hits, near misses, grazes) and some random
 * ones, IC's test must give the scene-level routine's answer and the same
 * t bit for bit, and count one test of the primitive's kind and the
 * polygon's vertices. */
#include "check.h"
#include "geom.h"
#include "grid.h"

#include <string.h>

#define NRAYS 4000

/* A scene of every kind, in random sizes and places about the unit cube. */
static mprt_scene *every_kind(rng *r)
{
    mprt_scene *s;
    int i, k;
    mprt_scene_create(&s);
    for (i = 0; i < 60; i++) {
        double c[3], v[12], b[3], a[3];
        for (k = 0; k < 3; k++) c[k] = rnd_in(r, -1, 1);
        switch (i % 5) {
        case 0:
            CHECK(mprt_scene_add_sphere(s, c, rnd_in(r, 0.01, 0.3)) == MPRT_OK);
            break;
        case 1: /* a triangle */
            for (k = 0; k < 9; k++) v[k] = c[k % 3] + rnd_in(r, -0.3, 0.3);
            CHECK(mprt_scene_add_polygon(s, 3, v, NULL) == MPRT_OK);
            break;
        case 2: /* a square in a random plane: a polygon IC does not pack */
        {
            vec3 n = rnd_unit(r), u = vnorm(vcross(n, fabs((double)n.x) < 0.9 ? vd(1, 0, 0) : vd(0, 1, 0)));
            vec3 w = vcross(n, u);
            double h = rnd_in(r, 0.05, 0.3), su[4] = {-1, 1, 1, -1}, sw[4] = {-1, -1, 1, 1};
            int j;
            for (j = 0; j < 4; j++) {
                v[3 * j] = c[0] + h * (su[j] * (double)u.x + sw[j] * (double)w.x);
                v[3 * j + 1] = c[1] + h * (su[j] * (double)u.y + sw[j] * (double)w.y);
                v[3 * j + 2] = c[2] + h * (su[j] * (double)u.z + sw[j] * (double)w.z);
            }
            CHECK(mprt_scene_add_polygon(s, 4, v, NULL) == MPRT_OK);
            break;
        }
        default: /* a cylinder (i % 5 == 3) or a cone frustum */
        {
            double rb = rnd_in(r, 0.02, 0.2);
            for (k = 0; k < 3; k++) {
                b[k] = c[k] - rnd_in(r, -0.3, 0.3);
                a[k] = c[k] + rnd_in(r, -0.3, 0.3);
            }
            CHECK(mprt_scene_add_cone(s, b, rb, a, i % 5 == 3 ? rb : rnd_in(r, 0, 0.2)) == MPRT_OK);
            break;
        }
        }
    }
    return s;
}

/* The scene-level test of primitive id (prim_*.c). */
static int scene_test(const mprt_scene *s, int32_t id, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    const mprt__prim *p = &s->prims[id];
    switch (p->kind) {
    case MPRT_SPHERE: return mprt__sphere_hit(&s->spheres[p->index], ray, tmin, tmax, t);
    case MPRT_POLYGON: return mprt__polygon_hit(&s->polygons[p->index], s->verts, ray, tmin, tmax, t);
    case MPRT_CYLINDER: return mprt__cylinder_hit(&s->cones[p->index], ray, tmin, tmax, t);
    default: return mprt__cone_hit(&s->cones[p->index], ray, tmin, tmax, t);
    }
}

/* A point on or near primitive id: its bounding box's centre, jittered by its size. */
static vec3 near_prim(const mprt_scene *s, int32_t id, rng *r)
{
    vec3 lo, hi, c, e;
    mprt__prim_bounds(s, id, &lo, &hi);
    c = vscale(vadd(lo, hi), R(0.5));
    e = vsub(hi, lo);
    return v3(c.x + (real)rnd_in(r, -0.6, 0.6) * e.x, c.y + (real)rnd_in(r, -0.6, 0.6) * e.y,
              c.z + (real)rnd_in(r, -0.6, 0.6) * e.z);
}

static void test_ic_decides_as_the_scene_routines(void)
{
    rng r;
    mprt_scene *s;
    mprt_grid *g;
    long long hits[MPRT_NKINDS] = {0, 0, 0, 0}, tested = 0, differ = 0;
    int i, k;
    rng_seed(&r, 11);
    s = every_kind(&r);
    CHECK(mprt_grid_create(s, 6, 6, 6, 0, &g) == MPRT_OK);
    CHECK(g->ic.ntri == 12);
    for (i = 0; i < NRAYS; i++) {
        vec3 o = vd(rnd_in(&r, -3, 3), rnd_in(&r, -3, 3), rnd_in(&r, -3, 3));
        vec3 d = i % 4 == 0 ? rnd_unit(&r) : vsub(near_prim(s, (int32_t)rnd_int(&r, 0, (int)s->nprims - 1), &r), o);
        real tmin = i % 3 == 0 ? (real)rnd_in(&r, 0, 0.5) : 0, tmax = i % 5 == 0 ? (real)rnd_in(&r, 0.5, 2) : (real)INFINITY;
        mprt__ray ray;
        real dd;
        int32_t id;
        if (i % 7 == 0) d = vscale(d, (real)rnd_in(&r, 0.001, 1000)); /* directions need not be unit */
        ray = mkray(o, d);
        dd = vdot(ray.d, ray.d);
        for (id = 0; id < (int32_t)s->nprims; id++) {
            int32_t tests[MPRT_NKINDS] = {0, 0, 0, 0}, vertices = 0;
            real t_ic = -1, t_scene = -1;
            int kind = s->prims[id].kind;
            int a = mprt__ic_test(&g->ic, s, id, &ray, dd, tmin, tmax, &t_ic, tests, &vertices);
            int b = scene_test(s, id, &ray, tmin, tmax, &t_scene);
            tested++;
            if (a != b || (a && memcmp(&t_ic, &t_scene, sizeof t_ic) != 0)) {
                if (differ++ < 5)
                    CHECK_MSG(0, "ray %d, primitive %d (kind %d): IC %d at t %.17g, scene %d at t %.17g", i, (int)id,
                              kind, a, (double)t_ic, b, (double)t_scene);
            }
            hits[kind] += a;
            for (k = 0; k < MPRT_NKINDS; k++) CHECK(tests[k] == (k == kind));
            CHECK(vertices == (kind == MPRT_POLYGON ? s->polygons[s->prims[id].index].n : 0));
            CHECK(mprt__ic_scene_kind(&g->ic, id) == kind);
        }
    }
    CHECK_MSG(differ == 0, "%lld of %lld tests differ", differ, tested);
    /* the rays meet every kind often enough for the comparison to mean something */
    for (k = 0; k < MPRT_NKINDS; k++) CHECK_MSG(hits[k] > 200, "kind %d: %lld hits", k, hits[k]);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_ic_decides_as_the_scene_routines);
    return CHECK_DONE();
}
