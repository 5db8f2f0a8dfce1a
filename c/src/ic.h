/* ic.h: the IC stage's copy of the primitives, laid out for its tests
 * (internal).  The grid keeps, per primitive id, one word naming how IC
 * tests it and where its data lies, and a bounding ball; triangles keep
 * their vertices, normal and plane in one record.  A test then reads the
 * id's word and one record instead of going from the primitive table to
 * the kind's array and, for a polygon, on to the vertex array; spheres,
 * cylinders and cone frusta are first tested against their ball, 32 bytes
 * each, and only the few rays that pass it read the whole primitive.  Every
 * test computes what the scene-level routines (prim_*.c) compute, from the
 * same values in the same order, so every decision and every t is the same
 * bits; those routines call the functions here. */
#ifndef MPRT_IC_H
#define MPRT_IC_H

#include "mprt_internal.h"

#include <stdint.h>

/* How IC tests a primitive: its kind, with triangles apart (low 3 bits of
 * mprt__ic.ref; the index is the rest). */
enum { MPRT__IC_SPHERE, MPRT__IC_TRIANGLE, MPRT__IC_POLYGON, MPRT__IC_CYLINDER, MPRT__IC_CONE };
#define MPRT__IC_KIND_BITS 3
#define MPRT__IC_MAX_INDEX ((uint32_t)1 << (32 - MPRT__IC_KIND_BITS))

/* A ball: a sphere, or the bounding ball of a cone frustum (mprt__cone_ball). */
typedef struct {
    vec3 c;
    real r2;    /* squared radius */
} mprt__ball;

/* A triangle as IC tests it: the polygon's three vertices, normal and plane. */
typedef struct {
    vec3 v[3];
    vec3 normal;
    real d;
} mprt__tri;

typedef struct {
    uint32_t *ref;      /* per id: index << MPRT__IC_KIND_BITS | IC kind; the index is into
                         * tri for triangles, else into the scene's array of the kind */
    mprt__ball *ball;   /* per id: the sphere, or a cone's or cylinder's bounding ball */
    mprt__tri *tri;     /* the triangles */
    long long ntri;
} mprt__ic;

/* The ball about a cone frustum's middle that holds it (prim_cone.c): its
 * hit routines reject rays missing it first. */
void mprt__cone_ball(const mprt__cone *c, mprt__ball *b);

/* Nearest hit of the sphere b over (tmin, tmax]; dd = d.d of the ray
 * (mprt__sphere_hit's test, prim_sphere.c). */
static inline int mprt__ball_hit(const mprt__ball *b, const mprt__ray *ray, real dd, real tmin, real tmax, real *t)
{
    vec3 oc, f;
    real bb, c, disc, q, t0, t1, tmp;

    /* Quadratic dd t^2 + 2 bb t + c = 0 with oc = o - centre */
    oc = vsub(ray->o, b->c);
    if (mprt__line_misses(oc, ray->d, dd, b->r2)) return 0; /* a clear miss */
    bb = vdot(oc, ray->d);
    c = vdot(oc, oc) - b->r2;

    /* Outside and moving away: both roots are negative */
    if (c > 0 && bb > 0 && tmin >= 0) return 0;

    /* Discriminant bb^2 - dd c as dd (r^2 - |f|^2), f = oc minus its
     * projection on d: the vector from the centre to the line's closest
     * point.  No cancellation between two large squares for far origins. */
    f = vmadd(oc, ray->d, -bb / dd);
    disc = dd * (b->r2 - vdot(f, f));
    if (disc < 0) return 0;

    /* Stable roots: q = -(bb + sign(bb) sqrt(disc)), t0 = q/dd, t1 = c/q */
    q = bb >= 0 ? -(bb + SQRT(disc)) : -(bb - SQRT(disc));
    t0 = q / dd;
    t1 = q != 0 ? c / q : t0;
    if (t0 > t1) {
        tmp = t0;
        t0 = t1;
        t1 = tmp;
    }

    /* Nearest root in (tmin, tmax] */
    if (t0 > tmin && t0 <= tmax) {
        *t = t0;
        return 1;
    }
    if (t1 > tmin && t1 <= tmax) {
        *t = t1;
        return 1;
    }
    return 0;
}

/* Edge a->b's share of the winding number, half-open in y: an upward
 * crossing counts +1 when the origin is left of a->b, a downward one -1
 * when it is right (E(a, b) = ax by - ay bx).  Without branches: every
 * edge's E is computed and the conditions combined. */
static inline int mprt__edge_winding(real ax, real ay, real bx, real by)
{
    real e = ax * by - ay * bx;
    return ((ay <= 0) & (by > 0) & (e > 0)) - (!(ay <= 0) & (by <= 0) & (e < 0));
}

/* Nearest hit of a triangle over (tmin, tmax]: the watertight polygon test
 * (prim_polygon.c) for three vertices, the winding number first, without a
 * branch per edge; most tests end on a winding number of 0 and need no
 * division. */
static inline int mprt__tri_hit(const mprt__tri *p, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    const vec3 o = ray->o, mx = ray->mx, my = ray->my;
    vec3 q;
    real dn, tt, x0, y0, x1, y1, x2, y2;

    /* Parallel rays never hit */
    dn = vdot(p->normal, ray->d);
    if (dn == 0) return 0;
    /* shear-space coordinates (the ray along +z through the origin) */
    q = vsub(p->v[0], o);
    x0 = vdot(q, mx);
    y0 = vdot(q, my);
    q = vsub(p->v[1], o);
    x1 = vdot(q, mx);
    y1 = vdot(q, my);
    q = vsub(p->v[2], o);
    x2 = vdot(q, mx);
    y2 = vdot(q, my);
    if (mprt__edge_winding(x2, y2, x0, y0) + mprt__edge_winding(x0, y0, x1, y1) +
            mprt__edge_winding(x1, y1, x2, y2) == 0)
        return 0;
    tt = (p->d - vdot(p->normal, o)) / dn;
    if (!(tt > tmin && tt <= tmax)) return 0;
    *t = tt;
    return 1;
}

/* The scene's kind (mprt_kind) of primitive id as IC holds it: a hit
 * counts only when the scene still holds that kind under the id. */
static inline int mprt__ic_scene_kind(const mprt__ic *ic, int32_t id)
{
    static const int kind[] = {MPRT_SPHERE, MPRT_POLYGON, MPRT_POLYGON, MPRT_CYLINDER, MPRT_CONE};
    return kind[ic->ref[id] & ((1u << MPRT__IC_KIND_BITS) - 1)];
}

/* IC's test of primitive id of scene s over (tmin, tmax]; dd = d.d of the
 * ray.  Counts the test in tests[kind] and the polygon vertices it touches
 * in *vertices.  Returns 1 with *t for a hit: the same decision and the
 * same t as the scene-level routine of the kind (tests/c/test_ic.c). */
static inline int mprt__ic_test(const mprt__ic *ic, const mprt_scene *s, int32_t id, const mprt__ray *ray, real dd,
                                real tmin, real tmax, real *t, int32_t tests[MPRT_NKINDS], int32_t *vertices)
{
    const uint32_t ref = ic->ref[id], index = ref >> MPRT__IC_KIND_BITS;
    const mprt__ball *ball = &ic->ball[id];
    switch (ref & ((1u << MPRT__IC_KIND_BITS) - 1)) {
    case MPRT__IC_SPHERE:
        tests[MPRT_SPHERE]++;
        return mprt__ball_hit(ball, ray, dd, tmin, tmax, t);
    case MPRT__IC_TRIANGLE:
        tests[MPRT_POLYGON]++;
        *vertices += 3;
        return mprt__tri_hit(&ic->tri[index], ray, tmin, tmax, t);
    case MPRT__IC_POLYGON:
        tests[MPRT_POLYGON]++;
        *vertices += s->polygons[index].n;
        return mprt__polygon_hit(&s->polygons[index], s->verts, ray, tmin, tmax, t);
    case MPRT__IC_CYLINDER:
        /* the bounding ball first, as mprt__cylinder_hit tests it */
        tests[MPRT_CYLINDER]++;
        return !mprt__line_misses(vsub(ball->c, ray->o), ray->d, dd, ball->r2) &&
               mprt__cylinder_hit(&s->cones[index], ray, tmin, tmax, t);
    default: /* MPRT__IC_CONE */
        tests[MPRT_CONE]++;
        return !mprt__line_misses(vsub(ball->c, ray->o), ray->d, dd, ball->r2) &&
               mprt__cone_hit(&s->cones[index], ray, tmin, tmax, t);
    }
}

#endif
