/* test_prim.c: rays, spheres, polygons, cones and cylinders (prim_*.c, ray.c).
 *
 * Every randomised case seeds its own generator, so a failure reproduces.
 * Tolerances follow `real`: the same file builds with -DMPRT_SINGLE. */
#include "mprt_internal.h"

#include "check.h"

#include <stdlib.h>
#include <string.h>

#define EPS ((double)REAL_EPS)
/* Relative tolerance for quantities computed in a few operations */
#define TOL (4096 * EPS)
#define PI 3.14159265358979323846

/* ---- Helpers --------------------------------------------------------------- */

typedef struct { unsigned long long s; } rng;

static void rng_seed(rng *r, unsigned long long seed) { r->s = seed * 0x9E3779B97F4A7C15ULL + 1; }

static unsigned long long rng_next(rng *r)
{
    unsigned long long z = (r->s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static double rnd(rng *r) { return (double)(rng_next(r) >> 11) * (1.0 / 9007199254740992.0); }
static double rnd_in(rng *r, double a, double b) { return a + (b - a) * rnd(r); }
/* Integer in [a, b]. */
static int rnd_int(rng *r, int a, int b) { return a + (int)(rng_next(r) % (unsigned long long)(b - a + 1)); }

static vec3 vd(double x, double y, double z) { return v3((real)x, (real)y, (real)z); }

static vec3 rnd_unit(rng *r)
{
    double z = rnd_in(r, -1, 1), a = rnd_in(r, 0, 2 * PI), s = sqrt(1 - z * z);
    return vd(s * cos(a), s * sin(a), z);
}

static mprt__ray mkray(vec3 o, vec3 d)
{
    mprt__ray ray;
    mprt__ray_prepare(&ray, o, d);
    return ray;
}

static double dlen(vec3 a) { return sqrt((double)a.x * a.x + (double)a.y * a.y + (double)a.z * a.z); }
static double ddist(vec3 a, vec3 b) { return dlen(vsub(a, b)); }
static double dmag(vec3 a) { return (double)vmaxabs(a); }

/* A growable set of polygons with their own vertex array, as the scene keeps them. */
typedef struct {
    vec3 *v;
    int nv, capv;
    mprt__polygon *p;
    int np, capp;
} mesh;

/* Add a polygon; returns mprt__polygon_prepare's code (the polygon is kept only on 0). */
static int mesh_add(mesh *m, int n, const vec3 *pts, int flip)
{
    mprt__polygon p;
    char err[200];
    int i, st;
    if (m->nv + n > m->capv) {
        m->capv = 2 * (m->nv + n) + 16;
        m->v = (vec3 *)realloc(m->v, sizeof *m->v * (size_t)m->capv);
    }
    if (m->np + 1 > m->capp) {
        m->capp = 2 * m->np + 16;
        m->p = (mprt__polygon *)realloc(m->p, sizeof *m->p * (size_t)m->capp);
    }
    if (!m->v || !m->p) {
        fprintf(stderr, "out of memory\n");
        exit(2);
    }
    for (i = 0; i < n; i++) m->v[m->nv + i] = pts[flip ? n - 1 - i : i];
    memset(&p, 0, sizeof p);
    p.first = m->nv;
    p.n = n;
    st = mprt__polygon_prepare(&p, m->v, err, sizeof err);
    if (st == 0) {
        m->p[m->np++] = p;
        m->nv += n;
    }
    return st;
}

static void mesh_free(mesh *m)
{
    free(m->v);
    free(m->p);
    memset(m, 0, sizeof *m);
}

/* Number of faces hit in (tmin, tmax]. */
static int mesh_hits(const mesh *m, const mprt__ray *ray, real tmin, real tmax)
{
    int i, n = 0;
    real t;
    for (i = 0; i < m->np; i++) n += mprt__polygon_hit(&m->p[i], m->v, ray, tmin, tmax, &t);
    return n;
}

/* Even-odd point in polygon, 2D, in double. */
static int pip2(const double *x, const double *y, int n, double px, double py)
{
    int i, j, c = 0;
    for (i = 0, j = n - 1; i < n; j = i++)
        if (((y[i] > py) != (y[j] > py)) && (px < (x[j] - x[i]) * (py - y[i]) / (y[j] - y[i]) + x[i]))
            c = !c;
    return c;
}

/* Distance from (px, py) to the outline. */
static double outline_dist(const double *x, const double *y, int n, double px, double py)
{
    int i, j;
    double best = 1e300;
    for (i = 0, j = n - 1; i < n; j = i++) {
        double ex = x[i] - x[j], ey = y[i] - y[j], wx = px - x[j], wy = py - y[j];
        double s = (wx * ex + wy * ey) / (ex * ex + ey * ey), dx, dy, d;
        if (s < 0) s = 0;
        if (s > 1) s = 1;
        dx = wx - s * ex;
        dy = wy - s * ey;
        d = sqrt(dx * dx + dy * dy);
        if (d < best) best = d;
    }
    return best;
}

/* A gear-like concave outline of n vertices (n a multiple of 4): teeth of radius 1, gaps 0.8. */
static void gear_outline(int n, double *x, double *y)
{
    int i;
    for (i = 0; i < n; i++) {
        double a = 2 * PI * (i + 0.5 * (i & 1)) / n, r = (i & 2) ? 0.8 : 1.0;
        x[i] = r * cos(a);
        y[i] = r * sin(a);
    }
}

/* An orthonormal frame (e1, e2, n) in double. */
static void frame(const double n[3], double e1[3], double e2[3])
{
    double a[3] = {1, 0, 0}, l;
    if (fabs(n[0]) > 0.6) {
        a[0] = 0;
        a[1] = 1;
    }
    e1[0] = a[1] * n[2] - a[2] * n[1];
    e1[1] = a[2] * n[0] - a[0] * n[2];
    e1[2] = a[0] * n[1] - a[1] * n[0];
    l = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    e1[0] /= l;
    e1[1] /= l;
    e1[2] /= l;
    e2[0] = n[1] * e1[2] - n[2] * e1[1];
    e2[1] = n[2] * e1[0] - n[0] * e1[2];
    e2[2] = n[0] * e1[1] - n[1] * e1[0];
}

/* A planar polygon in 3D from a 2D outline: c + x e1 + y e2. */
typedef struct {
    double c[3], e1[3], e2[3], n[3];
} plane3;

static void plane_make(plane3 *pl, rng *r, double cx, double cy, double cz)
{
    vec3 u = rnd_unit(r);
    pl->c[0] = cx;
    pl->c[1] = cy;
    pl->c[2] = cz;
    pl->n[0] = (double)u.x;
    pl->n[1] = (double)u.y;
    pl->n[2] = (double)u.z;
    {
        double l = sqrt(pl->n[0] * pl->n[0] + pl->n[1] * pl->n[1] + pl->n[2] * pl->n[2]);
        pl->n[0] /= l;
        pl->n[1] /= l;
        pl->n[2] /= l;
    }
    frame(pl->n, pl->e1, pl->e2);
}

static void plane_point(const plane3 *pl, double x, double y, double h, double out[3])
{
    int k;
    for (k = 0; k < 3; k++) out[k] = pl->c[k] + x * pl->e1[k] + y * pl->e2[k] + h * pl->n[k];
}

static vec3 plane_vec(const plane3 *pl, double x, double y, double h)
{
    double q[3];
    plane_point(pl, x, y, h, q);
    return vd(q[0], q[1], q[2]);
}

/* Long-double reference for the sphere: the line's closest point and half chord. */
static int sphere_ref(vec3 c, real r, vec3 o, vec3 d, double tmin, double tmax, double *t)
{
    long double oc[3], dd[3], dd2 = 0, tc = 0, p2 = 0, h2, dt, t0, t1;
    int k;
    oc[0] = (long double)c.x - o.x;
    oc[1] = (long double)c.y - o.y;
    oc[2] = (long double)c.z - o.z;
    dd[0] = d.x;
    dd[1] = d.y;
    dd[2] = d.z;
    for (k = 0; k < 3; k++) {
        dd2 += dd[k] * dd[k];
        tc += oc[k] * dd[k];
    }
    tc /= dd2;
    for (k = 0; k < 3; k++) {
        long double e = tc * dd[k] - oc[k];
        p2 += e * e;
    }
    h2 = (long double)r * r - p2;
    if (h2 < 0) return 0;
    dt = sqrtl(h2 / dd2);
    t0 = tc - dt;
    t1 = tc + dt;
    if (t0 > tmin && t0 <= tmax) {
        *t = (double)t0;
        return 1;
    }
    if (t1 > tmin && t1 <= tmax) {
        *t = (double)t1;
        return 1;
    }
    return 0;
}

/* Long-double reference for a cone frustum: the plain quadratic in the cone's
 * frame, with the origin first moved to the ray's point nearest the base (so
 * far origins keep their precision).  *amb is set when the answer is close
 * to a decision boundary (tangent, rim, tmin), where either is fine. */
static int cone_ref(const mprt__cone *c, vec3 o, vec3 d, double tmin, double tmax, double *t, int *amb)
{
    long double b[3], w[3], oo[3], dd[3], len = 0, oz, dz, o2 = 0, d2 = 0, od = 0, k, r0, A, B, C,
        disc, s, roots[2], scale, sh, near = EPS > 1e-10 ? 1e-3L : 1e-6L;
    int i, j, hit = 0;
    b[0] = c->base.x;
    b[1] = c->base.y;
    b[2] = c->base.z;
    w[0] = (long double)c->apex.x - b[0];
    w[1] = (long double)c->apex.y - b[1];
    w[2] = (long double)c->apex.z - b[2];
    for (i = 0; i < 3; i++) len += w[i] * w[i];
    len = sqrtl(len);
    for (i = 0; i < 3; i++) w[i] /= len;
    dd[0] = d.x;
    dd[1] = d.y;
    dd[2] = d.z;
    oo[0] = (long double)o.x - b[0];
    oo[1] = (long double)o.y - b[1];
    oo[2] = (long double)o.z - b[2];
    for (i = 0; i < 3; i++) {
        d2 += dd[i] * dd[i];
        od += oo[i] * dd[i];
    }
    sh = -od / d2; /* shift: o' = o + sh d */
    od = 0;
    for (i = 0; i < 3; i++) {
        oo[i] += sh * dd[i];
        o2 += oo[i] * oo[i];
        od += oo[i] * dd[i];
    }
    oz = oo[0] * w[0] + oo[1] * w[1] + oo[2] * w[2];
    dz = dd[0] * w[0] + dd[1] * w[1] + dd[2] * w[2];
    k = ((long double)c->ra - (long double)c->rb) / len;
    r0 = (long double)c->rb + k * oz;
    A = (d2 - dz * dz) - k * k * dz * dz;
    B = (od - oz * dz) - k * dz * r0;
    C = (o2 - oz * oz) - r0 * r0;
    *amb = 0;
    scale = (long double)c->rb + c->ra + len;
    if (fabsl(A) <= 1e-15L * d2) {
        if (B == 0) return 0;
        roots[0] = roots[1] = -C / (2 * B);
    } else {
        disc = B * B - A * C;
        if (fabsl(disc) <= (long double)(1e4 * EPS) * (B * B + fabsl(A * C))) *amb = 1;
        if (disc < 0) return 0;
        s = sqrtl(disc);
        roots[0] = (-B - s) / A;
        roots[1] = (-B + s) / A;
        if (roots[0] > roots[1]) {
            long double x = roots[0];
            roots[0] = roots[1];
            roots[1] = x;
        }
    }
    for (j = 0; j < 2 && !hit; j++) {
        long double tt = roots[j] + sh, z = oz + roots[j] * dz;
        if (fabsl(z) < near * scale || fabsl(z - len) < near * scale) *amb = 1;
        if (fabsl(tt - tmin) < near * (fabsl(tt) + 1)) *amb = 1;
        if (tt > tmin && tt <= tmax && z >= 0 && z <= len) {
            *t = (double)tt;
            hit = 1;
        }
    }
    return hit;
}

static mprt__cone mkcone(vec3 base, double rb, vec3 apex, double ra)
{
    mprt__cone c;
    char err[200];
    memset(&c, 0, sizeof c);
    c.base = base;
    c.apex = apex;
    c.rb = (real)rb;
    c.ra = (real)ra;
    if (mprt__cone_prepare(&c, err, sizeof err) != 0) fprintf(stderr, "mkcone: %s\n", err);
    return c;
}

static int cone_any_hit(const mprt__cone *c, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    return c->rb == c->ra ? mprt__cylinder_hit(c, ray, tmin, tmax, t) : mprt__cone_hit(c, ray, tmin, tmax, t);
}

/* A point on the cone's lateral surface: axial fraction f, angle a. */
static vec3 cone_point(const mprt__cone *c, double f, double a)
{
    double z = f * (double)c->len, r = (double)c->rb + (double)c->slope * z, q[3];
    int k;
    for (k = 0; k < 3; k++)
        q[k] = (double)vget(c->base, k) + z * (double)vget(c->w, k) +
               r * (cos(a) * (double)vget(c->u, k) + sin(a) * (double)vget(c->v, k));
    return vd(q[0], q[1], q[2]);
}

/* A random box containing p, of size up to s (log-uniform down to 1e-9 s, sometimes empty). */
static void box_around(rng *r, vec3 p, double s, vec3 *lo, vec3 *hi)
{
    double h[3];
    int k;
    if (rnd(r) < 0.1) {
        *lo = *hi = p;
        return;
    }
    for (k = 0; k < 3; k++) h[k] = s * pow(10.0, rnd_in(r, -9, 0));
    *lo = vd((double)p.x - h[0] * rnd(r), (double)p.y - h[1] * rnd(r), (double)p.z - h[2] * rnd(r));
    *hi = vd((double)p.x + h[0] * rnd(r), (double)p.y + h[1] * rnd(r), (double)p.z + h[2] * rnd(r));
    /* rounding may have moved a face past p: keep p inside */
    if (lo->x > p.x) lo->x = p.x;
    if (lo->y > p.y) lo->y = p.y;
    if (lo->z > p.z) lo->z = p.z;
    if (hi->x < p.x) hi->x = p.x;
    if (hi->y < p.y) hi->y = p.y;
    if (hi->z < p.z) hi->z = p.z;
}

/* A cube of half size h about centre q. */
static void box_at(vec3 q, double h, vec3 *lo, vec3 *hi)
{
    *lo = vd((double)q.x - h, (double)q.y - h, (double)q.z - h);
    *hi = vd((double)q.x + h, (double)q.y + h, (double)q.z + h);
}

/* ---- Rays ----------------------------------------------------------------- */

/* The shear transform maps the direction to (0, 0, 1) and keeps a right-handed frame. */
static void test_ray_prepare(void)
{
    rng r;
    int i;
    mprt__ray ray = mkray(vd(1, 2, 3), vd(0, -0.0, -2));
    CHECK(ray.kz == 2);
    CHECK(ray.kx == 1 && ray.ky == 0); /* swapped for a negative dominant component */
    CHECK(isinf(ray.inv.x) && ray.inv.x > 0);
    CHECK(isinf(ray.inv.y) && ray.inv.y < 0);
    CHECK(ray.inv.z == R(-0.5));
    CHECK(ray.sz == R(-0.5));

    rng_seed(&r, 1);
    for (i = 0; i < 1000; i++) {
        vec3 d = vscale(rnd_unit(&r), (real)pow(10.0, rnd_in(&r, -3, 3)));
        real a[3], x, y, z;
        int perm;
        ray = mkray(vd(0, 0, 0), d);
        a[0] = d.x;
        a[1] = d.y;
        a[2] = d.z;
        CHECK(fabs((double)a[ray.kz]) >= fabs((double)a[ray.kx]) &&
              fabs((double)a[ray.kz]) >= fabs((double)a[ray.ky]));
        CHECK(ray.kx != ray.ky && ray.kx != ray.kz && ray.ky != ray.kz);
        x = a[ray.kx] + ray.sx * a[ray.kz];
        y = a[ray.ky] + ray.sy * a[ray.kz];
        z = ray.sz * a[ray.kz];
        CHECK_NEAR(x, 0, TOL * fabs((double)a[ray.kz]));
        CHECK_NEAR(y, 0, TOL * fabs((double)a[ray.kz]));
        CHECK_NEAR(z, 1, TOL);
        /* (kx, ky, kz) is an even permutation iff d[kz] > 0 */
        perm = (ray.ky == (ray.kx + 1) % 3);
        CHECK(perm == (a[ray.kz] > 0));
        CHECK(ray.inv.x == 1 / d.x && ray.inv.y == 1 / d.y && ray.inv.z == 1 / d.z);
    }
}

/* ---- Sphere ---------------------------------------------------------------- */

/* Hits of a sphere agree with hand-computed values and the (tmin, tmax] rule. */
static void test_sphere_analytic(void)
{
    mprt__sphere s;
    mprt__ray ray;
    real t = -1;
    s.c = vd(1, 2, 3);
    s.r = 2;
    ray = mkray(vd(1, 2, -7), vd(0, 0, 1));
    CHECK(mprt__sphere_hit(&s, &ray, 0, 100, &t) && t == 8);
    CHECK(mprt__sphere_hit(&s, &ray, 8, 100, &t) && t == 12);  /* near root excluded: tmin open */
    CHECK(mprt__sphere_hit(&s, &ray, 0, 8, &t) && t == 8);     /* tmax closed */
    CHECK(!mprt__sphere_hit(&s, &ray, 0, R(7.9), &t));
    CHECK(!mprt__sphere_hit(&s, &ray, 12, 100, &t));
    ray = mkray(vd(1, 2, -7), vd(0, 0, 2)); /* t in units of the given direction */
    CHECK(mprt__sphere_hit(&s, &ray, 0, 100, &t) && t == 4);
    ray = mkray(vd(1, 2, 13), vd(0, 0, 1)); /* moving away */
    CHECK(!mprt__sphere_hit(&s, &ray, 0, 100, &t));
    ray = mkray(vd(4, 2, -7), vd(0, 0, 1)); /* passes by */
    CHECK(!mprt__sphere_hit(&s, &ray, 0, 100, &t));
    ray = mkray(vd(1, 2, 3), vd(0, R(0.6), R(0.8))); /* from the centre */
    CHECK(mprt__sphere_hit(&s, &ray, 0, 100, &t));
    CHECK_NEAR(t, 2, TOL);
    CHECK_NEAR(mprt__sphere_normal(&s, vd(1, 2, 5)).z, 1, TOL);
    {
        vec3 lo, hi;
        mprt__sphere_bounds(&s, &lo, &hi);
        CHECK(lo.x == -1 && lo.y == 0 && lo.z == 1 && hi.x == 3 && hi.y == 4 && hi.z == 5);
    }
}

/* Random rays agree with a long-double reference, from outside and inside. */
static void test_sphere_random(void)
{
    rng r;
    int i, bad = 0, n = 0;
    mprt__sphere s;
    rng_seed(&r, 2);
    s.c = vd(0.25, -0.5, 1);
    s.r = R(0.75);
    for (i = 0; i < 20000; i++) {
        vec3 o = vadd(s.c, vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 3)));
        vec3 d = vscale(rnd_unit(&r), (real)rnd_in(&r, 0.1, 10));
        mprt__ray ray = mkray(o, d);
        double tr = 0;
        real t = 0;
        int h = mprt__sphere_hit(&s, &ray, 0, REAL_MAX, &t);
        int hr = sphere_ref(s.c, s.r, o, d, 0, (double)REAL_MAX, &tr);
        /* skip near-tangent rays and origins on the surface */
        double dist = ddist(o, s.c);
        if (fabs(dist - (double)s.r) < 1e-3) continue;
        {
            double oc[3] = {(double)o.x - (double)s.c.x, (double)o.y - (double)s.c.y,
                            (double)o.z - (double)s.c.z};
            double dn = dlen(d), b = (oc[0] * d.x + oc[1] * d.y + oc[2] * d.z) / dn;
            double miss2 = dist * dist - b * b;
            if (fabs(sqrt(fabs(miss2)) - (double)s.r) < 1e-3) continue;
        }
        n++;
        if (h != hr || (h && fabs((double)t - tr) > TOL * (tr + 1))) {
            if (bad++ < 5)
                fprintf(stderr, "  sphere ray %d: hit %d/%d t %.17g ref %.17g\n", i, h, hr, (double)t, tr);
        }
    }
    CHECK_MSG(bad == 0, "%d of %d rays disagree", bad, n);
    CHECK(n > 15000);
}

/* A tangent ray touches; just outside misses; just inside hits twice nearby. */
static void test_sphere_tangent(void)
{
    mprt__sphere s;
    mprt__ray ray;
    real t = 0, dy = EPS > 1e-10 ? R(1e-3) : R(1e-7);
    s.c = vd(0, 0, 0);
    s.r = 1;
    ray = mkray(vd(-5, 1, 0), vd(1, 0, 0));
    CHECK(mprt__sphere_hit(&s, &ray, 0, 100, &t) && t == 5);
    ray = mkray(vd(-5, 1 + dy, 0), vd(1, 0, 0));
    CHECK(!mprt__sphere_hit(&s, &ray, 0, 100, &t));
    ray = mkray(vd(-5, 1 - dy, 0), vd(1, 0, 0));
    CHECK(mprt__sphere_hit(&s, &ray, 0, 100, &t));
    CHECK_NEAR(t, 5 - sqrt(2 * (double)dy - (double)dy * dy), 1e-3 * sqrt((double)dy));
    CHECK(mprt__sphere_hit(&s, &ray, t, 100, &t));
    CHECK_NEAR(t, 5 + sqrt(2 * (double)dy - (double)dy * dy), 1e-3 * sqrt((double)dy));
}

/* Rays from inside always leave through the surface, at a point on it. */
static void test_sphere_inside(void)
{
    rng r;
    int i, bad = 0;
    mprt__sphere s;
    rng_seed(&r, 3);
    s.c = vd(3, -1, 2);
    s.r = 2;
    for (i = 0; i < 10000; i++) {
        vec3 o = vadd(s.c, vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 1.999)));
        vec3 d = rnd_unit(&r);
        mprt__ray ray = mkray(o, d);
        real t = 0;
        if (!mprt__sphere_hit(&s, &ray, 0, REAL_MAX, &t) || t <= 0 ||
            fabs(ddist(vmadd(o, d, t), s.c) - 2) > TOL * 4)
            bad++;
    }
    CHECK_MSG(bad == 0, "%d rays from inside failed", bad);
}

/* Scaling a scene by 1e-6 or 1e6 scales t and keeps hit points on the surface;
 * a unit sphere seen from 1e6 (double) or 1e3 (single) away is hit accurately. */
static void test_sphere_scaled(void)
{
    static const double scales[] = {1e-6, 1e-3, 1, 1e3, 1e6};
    rng r;
    int i, k, bad = 0, badfar = 0;
    for (k = 0; k < 5; k++) {
        double sc = scales[k];
        mprt__sphere s1, ss;
        rng_seed(&r, 4);
        s1.c = vd(1, 2, 3);
        s1.r = R(0.5);
        ss.c = vd(sc, 2 * sc, 3 * sc);
        ss.r = (real)(0.5 * sc);
        for (i = 0; i < 2000; i++) {
            vec3 dir = rnd_unit(&r), aim = rnd_unit(&r);
            double dist = rnd_in(&r, 2, 20), f = rnd_in(&r, 0, 0.95);
            vec3 o1 = vadd(vmadd(s1.c, aim, (real)(0.5 * f)), vscale(dir, (real)(-dist)));
            vec3 os = vd((double)o1.x * sc, (double)o1.y * sc, (double)o1.z * sc);
            mprt__ray r1 = mkray(o1, dir), rs = mkray(os, dir);
            real t1 = 0, ts = 0;
            int h1 = mprt__sphere_hit(&s1, &r1, 0, REAL_MAX, &t1);
            int hs = mprt__sphere_hit(&ss, &rs, 0, REAL_MAX, &ts);
            if (!h1 || !hs || fabs((double)ts / sc - (double)t1) > TOL * (double)t1 ||
                fabs(ddist(vmadd(os, dir, ts), ss.c) / sc - 0.5) > TOL)
                bad++;
        }
    }
    CHECK_MSG(bad == 0, "%d scaled rays failed", bad);

    /* Far origin, unit sphere: the hit point stays within rounding of |o| */
    {
        double far = EPS > 1e-10 ? 1e3 : 1e6;
        mprt__sphere s;
        rng_seed(&r, 5);
        s.c = vd(0.5, -0.25, 0.125);
        s.r = 1;
        for (i = 0; i < 2000; i++) {
            vec3 dir = rnd_unit(&r), aim = rnd_unit(&r);
            vec3 o = vadd(vmadd(s.c, aim, (real)rnd_in(&r, 0, 0.9)), vscale(dir, (real)(-far)));
            mprt__ray ray = mkray(o, dir);
            real t = 0;
            double tr = 0;
            int h = mprt__sphere_hit(&s, &ray, 0, REAL_MAX, &t);
            int hr = sphere_ref(s.c, s.r, o, dir, 0, 1e300, &tr);
            if (h != hr || (h && (fabs((double)t - tr) > 16 * EPS * far ||
                                  fabs(ddist(vmadd(o, dir, t), s.c) - 1) > 64 * EPS * far)))
                badfar++;
        }
        CHECK_MSG(badfar == 0, "%d far rays failed", badfar);
    }
}

/* ---- Polygons -------------------------------------------------------------- */

/* prepare computes the Newell normal and plane, and rejects bad polygons with the right code. */
static void test_polygon_prepare(void)
{
    mprt__polygon p;
    char err[200];
    vec3 sq[4], v[8];
    int st;

    sq[0] = vd(0, 0, 1);
    sq[1] = vd(2, 0, 1);
    sq[2] = vd(2, 2, 1);
    sq[3] = vd(0, 2, 1);
    memset(&p, 0, sizeof p);
    p.n = 4;
    CHECK(mprt__polygon_prepare(&p, sq, err, sizeof err) == 0);
    CHECK(p.normal.x == 0 && p.normal.y == 0 && p.normal.z == 1 && p.d == 1);

    /* concave L shape, clockwise: normal -z */
    v[0] = vd(0, 0, -3);
    v[1] = vd(0, 2, -3);
    v[2] = vd(1, 2, -3);
    v[3] = vd(1, 1, -3);
    v[4] = vd(2, 1, -3);
    v[5] = vd(2, 0, -3);
    p.n = 6;
    CHECK(mprt__polygon_prepare(&p, v, err, sizeof err) == 0);
    CHECK(p.normal.z == -1 && p.d == 3);

    /* first offset: the polygon's vertices start at p.first */
    v[2] = vd(5, 5, 5);
    v[3] = vd(1, 0, 0);
    v[4] = vd(0, 1, 0);
    v[5] = vd(0, 0, 1);
    p.first = 3;
    p.n = 3;
    CHECK(mprt__polygon_prepare(&p, v, err, sizeof err) == 0);
    CHECK_NEAR(p.normal.x, 1 / sqrt(3.0), TOL);
    CHECK_NEAR(p.d, 1 / sqrt(3.0), TOL);
    p.first = 0;

    /* zero area: collinear, coincident */
    v[0] = vd(0, 0, 0);
    v[1] = vd(1, 1, 1);
    v[2] = vd(2, 2, 2);
    v[3] = vd(3, 3, 3);
    p.n = 4;
    st = mprt__polygon_prepare(&p, v, err, sizeof err);
    CHECK(st == MPRT__DEGENERATE);
    CHECK_MSG(strncmp(err, "zero area", 9) == 0, "message '%s'", err);
    v[0] = v[1] = v[2] = vd(1, 2, 3);
    p.n = 3;
    CHECK(mprt__polygon_prepare(&p, v, err, sizeof err) == MPRT__DEGENERATE);
    /* a sliver far below the tolerance, two vertices equal */
    v[0] = vd(0, 0, 0);
    v[1] = vd(1, 0, 0);
    v[2] = vd(1, 0, 0);
    v[3] = vd(0.5, 1e-14, 0);
    p.n = 4;
    CHECK(mprt__polygon_prepare(&p, v, err, sizeof err) == MPRT__DEGENERATE);

    /* non-planar: one vertex of a unit square 0.01 off */
    v[0] = vd(0, 0, 0);
    v[1] = vd(1, 0, 0);
    v[2] = vd(1, 1, 0);
    v[3] = vd(0, 1, 0.01);
    v[4] = vd(0.5, 1.5, 0);
    p.n = 5;
    st = mprt__polygon_prepare(&p, v, err, sizeof err);
    CHECK(st == MPRT__NONPLANAR);
    CHECK_MSG(strncmp(err, "non-planar: vertex ", 19) == 0 && strstr(err, "tolerance"), "message '%s'", err);
    /* ... but 1e-9 off passes (double) */
    if (EPS < 1e-10) {
        v[3] = vd(0, 1, 1e-9);
        CHECK(mprt__polygon_prepare(&p, v, err, sizeof err) == 0);
    }
    /* too few vertices, NaN */
    p.n = 2;
    CHECK(mprt__polygon_prepare(&p, v, err, sizeof err) == MPRT__BAD);
    p.n = 3;
    v[1].y = (real)NAN;
    CHECK(mprt__polygon_prepare(&p, v, err, sizeof err) == MPRT__BAD);
}

/* Tilted planar polygons written with 6 significant digits (as SPD prints them) pass. */
static void test_polygon_printed(void)
{
    rng r;
    int i, j, bad = 0;
    double x[144], y[144];
    rng_seed(&r, 6);
    gear_outline(144, x, y);
    for (j = 0; j < 200; j++) {
        plane3 pl;
        vec3 v[144];
        mprt__polygon p;
        char err[200], buf[64];
        double size = j % 2 ? 0.5 : 0.005;
        int n = j % 3 ? 144 : 4;
        plane_make(&pl, &r, rnd_in(&r, -3, 3), rnd_in(&r, -3, 3), rnd_in(&r, -3, 3));
        for (i = 0; i < n; i++) {
            double q[3], xx = n == 4 ? ((i == 1 || i == 2) ? 1 : -1) : x[i];
            double yy = n == 4 ? (i >= 2 ? 1 : -1) : y[i];
            int k;
            plane_point(&pl, size * xx, size * yy, 0, q);
            for (k = 0; k < 3; k++) {
                snprintf(buf, sizeof buf, "%g", q[k]);
                q[k] = strtod(buf, NULL);
            }
            v[i] = vd(q[0], q[1], q[2]);
        }
        memset(&p, 0, sizeof p);
        p.n = n;
        if (mprt__polygon_prepare(&p, v, err, sizeof err) != 0) {
            if (bad++ < 3) fprintf(stderr, "  printed polygon %d: %s\n", j, err);
        }
    }
    CHECK_MSG(bad == 0, "%d printed polygons rejected", bad);
}

/* Every polygon of the SPD reference gears, mount and tetra files passes prepare. */
static void test_polygon_spd_files(void)
{
    static const char *names[] = {"gears.nff", "mount.nff", "tetra.nff"};
    const char *dir = getenv("MPRT_SPD_REFERENCE");
    int f;
    if (!dir) dir = "../data/spd-reference"; /* from tests/c */
    for (f = 0; f < 3; f++) {
        char path[512], line[256], err[200];
        FILE *fp;
        int n, i, count = 0, bad = 0;
        vec3 *v = NULL;
        snprintf(path, sizeof path, "%s/%s", dir, names[f]);
        fp = fopen(path, "r");
        CHECK_MSG(fp != NULL, "%s not found (set MPRT_SPD_REFERENCE)", path);
        if (!fp) continue;
        while (fgets(line, sizeof line, fp)) {
            mprt__polygon p;
            if (sscanf(line, "p %d", &n) != 1) continue;
            v = (vec3 *)realloc(v, sizeof *v * (size_t)n);
            for (i = 0; i < n && v; i++) {
                double a, b, c;
                if (!fgets(line, sizeof line, fp) || sscanf(line, "%lf %lf %lf", &a, &b, &c) != 3) break;
                v[i] = vd(a, b, c);
            }
            if (!v || i < n) {
                bad++;
                break;
            }
            memset(&p, 0, sizeof p);
            p.n = n;
            count++;
            if (mprt__polygon_prepare(&p, v, err, sizeof err) != 0 && bad++ < 3)
                fprintf(stderr, "  %s polygon %d: %s\n", names[f], count, err);
        }
        fclose(fp);
        free(v);
        CHECK_MSG(bad == 0, "%s: %d of %d polygons rejected", names[f], bad, count);
        CHECK(count > 4000);
    }
}

/* t comes from the plane, with (tmin, tmax] and parallel rays rejected. */
static void test_polygon_plane(void)
{
    mesh m = {0};
    vec3 sq[4];
    mprt__ray ray;
    real t = 0;
    sq[0] = vd(0, 0, 1);
    sq[1] = vd(1, 0, 1);
    sq[2] = vd(1, 1, 1);
    sq[3] = vd(0, 1, 1);
    CHECK(mesh_add(&m, 4, sq, 0) == 0);
    ray = mkray(vd(0.5, 0.25, 0), vd(0, 0, 1));
    CHECK(mprt__polygon_hit(&m.p[0], m.v, &ray, 0, 10, &t) && t == 1);
    CHECK(mprt__polygon_hit(&m.p[0], m.v, &ray, 0, 1, &t) && t == 1);
    CHECK(!mprt__polygon_hit(&m.p[0], m.v, &ray, 1, 10, &t));
    CHECK(!mprt__polygon_hit(&m.p[0], m.v, &ray, 0, R(0.99), &t));
    ray = mkray(vd(0.5, 0.25, 3), vd(0, 0, -2));
    CHECK(mprt__polygon_hit(&m.p[0], m.v, &ray, 0, 10, &t) && t == 1);
    ray = mkray(vd(0.5, 0.25, 1), vd(1, 0, 0)); /* in the plane */
    CHECK(!mprt__polygon_hit(&m.p[0], m.v, &ray, -10, 10, &t));
    ray = mkray(vd(1.5, 0.25, 0), vd(0, 0, 1)); /* beside */
    CHECK(!mprt__polygon_hit(&m.p[0], m.v, &ray, 0, 10, &t));
    {
        vec3 lo, hi;
        mprt__polygon_bounds(&m.p[0], m.v, &lo, &hi);
        CHECK(lo.x == 0 && lo.y == 0 && lo.z == 1 && hi.x == 1 && hi.y == 1 && hi.z == 1);
    }
    mesh_free(&m);
}

/* A concave 144-vertex gear outline in a tilted plane agrees with a brute-force 2D test. */
static void test_polygon_concave(void)
{
    rng r;
    double x[144], y[144];
    int rep, i, bad = 0, n = 0, inside = 0;
    gear_outline(144, x, y);
    rng_seed(&r, 7);
    for (rep = 0; rep < 4; rep++) {
        plane3 pl;
        vec3 v[144];
        mesh m = {0};
        double margin = 1e4 * EPS;
        plane_make(&pl, &r, 0.3, -0.7, 2.1);
        for (i = 0; i < 144; i++) v[i] = plane_vec(&pl, x[i], y[i], 0);
        CHECK(mesh_add(&m, 144, v, rep & 1) == 0);
        for (i = 0; i < 20000; i++) {
            double px = rnd_in(&r, -1.1, 1.1), py = rnd_in(&r, -1.1, 1.1), q[3];
            vec3 dir = rnd_unit(&r), o;
            double cosn = (double)dir.x * pl.n[0] + (double)dir.y * pl.n[1] + (double)dir.z * pl.n[2];
            mprt__ray ray;
            real t = 0;
            int h, truth;
            if (fabs(cosn) < 0.2) continue;
            plane_point(&pl, px, py, 0, q);
            o = vd(q[0] - 2 * (double)dir.x, q[1] - 2 * (double)dir.y, q[2] - 2 * (double)dir.z);
            ray = mkray(o, dir);
            h = mprt__polygon_hit(&m.p[0], m.v, &ray, 0, 10, &t);
            if (outline_dist(x, y, 144, px, py) < margin / fabs(cosn)) continue;
            truth = pip2(x, y, 144, px, py);
            n++;
            inside += truth;
            if (h != truth || (h && fabs((double)t - 2) > TOL)) {
                if (bad++ < 5)
                    fprintf(stderr, "  point (%.17g, %.17g): hit %d truth %d t %.17g\n", px, py, h, truth,
                            (double)t);
            }
        }
        mesh_free(&m);
    }
    CHECK_MSG(bad == 0, "%d of %d rays disagree with the 2D test", bad, n);
    CHECK(inside > n / 4 && inside < n);
}

/* Rays aimed exactly at the shared edges and vertices of an octahedron never leak. */
static void test_watertight_octahedron(void)
{
    rng r;
    mesh m = {0};
    vec3 ax[6], targets[64];
    int nt = 0, i, j, k, leaks = 0, rays = 0;
    rng_seed(&r, 8);
    for (i = 0; i < 3; i++) {
        ax[2 * i] = vd(i == 0, i == 1, i == 2);
        ax[2 * i + 1] = vscale(ax[2 * i], -1);
    }
    for (i = 0; i < 8; i++) {
        vec3 tri[3];
        tri[0] = ax[0 + (i & 1)];
        tri[1] = ax[2 + ((i >> 1) & 1)];
        tri[2] = ax[4 + ((i >> 2) & 1)];
        CHECK(mesh_add(&m, 3, tri, rnd(&r) < 0.5) == 0);
    }
    /* vertices, edge midpoints and dyadic points along edges */
    for (i = 0; i < 6; i++) targets[nt++] = ax[i];
    for (i = 0; i < 6; i++)
        for (j = i + 1; j < 6; j++)
            if (j != (i ^ 1)) {
                targets[nt++] = vscale(vadd(ax[i], ax[j]), R(0.5));
                if (nt < 64) targets[nt++] = vadd(ax[i], vscale(vsub(ax[j], ax[i]), (real)rnd_int(&r, 1, 63) / 64));
            }
    for (k = 0; k < 40000; k++) {
        vec3 tgt = targets[k % nt], q, o, d;
        real s = (real)rnd_int(&r, 2, 32) / 4;
        mprt__ray ray;
        /* dyadic interior point: every difference below is exact */
        do q = vd(rnd_int(&r, -20, 20) / 64.0, rnd_int(&r, -20, 20) / 64.0, rnd_int(&r, -20, 20) / 64.0);
        while (fabs((double)q.x) + fabs((double)q.y) + fabs((double)q.z) > 0.95);
        /* from outside through the target into the solid: the target is at t = 1 */
        o = vadd(tgt, vscale(vsub(tgt, q), s));
        d = vsub(tgt, o);
        ray = mkray(o, d);
        rays++;
        if (mesh_hits(&m, &ray, 0, 1 + R(0.5) / s) == 0) leaks++;
        /* from inside out through the target */
        ray = mkray(q, vsub(tgt, q));
        rays++;
        if (mesh_hits(&m, &ray, 0, R(1.25)) == 0) leaks++;
    }
    CHECK_MSG(leaks == 0, "%d of %d rays leaked", leaks, rays);
    mesh_free(&m);
}

/* Rays at the edges and vertices of a triangulated sphere (quads and triangles,
 * random orientations) never leak. */
static void test_watertight_sphere_mesh(void)
{
    enum { NLAT = 12, NLON = 24 };
    rng r;
    mesh m = {0};
    vec3 grid[NLAT + 1][NLON], *targets;
    int i, j, k, nt = 0, leaks = 0, rays = 0, rejected = 0;
    rng_seed(&r, 9);
    for (i = 0; i <= NLAT; i++)
        for (j = 0; j < NLON; j++) {
            double th = PI * i / NLAT, ph = 2 * PI * j / NLON;
            grid[i][j] = i == 0 ? vd(0, 0, 1) : i == NLAT ? vd(0, 0, -1)
                                                          : vd(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
        }
    targets = (vec3 *)malloc(sizeof *targets * 8 * (NLAT + 1) * NLON);
    for (i = 0; i < NLAT; i++)
        for (j = 0; j < NLON; j++) {
            vec3 a = grid[i][j], b = grid[i][(j + 1) % NLON], c = grid[i + 1][(j + 1) % NLON],
                 d = grid[i + 1][j], f[4];
            int flip = rnd(&r) < 0.5;
            if (i == 0) {
                f[0] = a;
                f[1] = c;
                f[2] = d;
                rejected += mesh_add(&m, 3, f, flip) != 0;
            } else if (i == NLAT - 1) {
                f[0] = a;
                f[1] = b;
                f[2] = c;
                rejected += mesh_add(&m, 3, f, flip) != 0;
            } else if (rnd(&r) < 0.5) {
                f[0] = a;
                f[1] = b;
                f[2] = c;
                f[3] = d;
                rejected += mesh_add(&m, 4, f, flip) != 0;
            } else if (rnd(&r) < 0.5) {
                f[0] = a;
                f[1] = b;
                f[2] = c;
                rejected += mesh_add(&m, 3, f, flip) != 0;
                f[1] = c;
                f[2] = d;
                rejected += mesh_add(&m, 3, f, rnd(&r) < 0.5) != 0;
            } else {
                f[0] = a;
                f[1] = b;
                f[2] = d;
                rejected += mesh_add(&m, 3, f, flip) != 0;
                f[0] = b;
                f[1] = c;
                rejected += mesh_add(&m, 3, f, rnd(&r) < 0.5) != 0;
            }
            targets[nt++] = a;
            targets[nt++] = vscale(vadd(a, b), R(0.5));
            targets[nt++] = vscale(vadd(a, d), R(0.5));
            targets[nt++] = vscale(vadd(a, c), R(0.5));
            targets[nt++] = vscale(vadd(b, d), R(0.5));
            targets[nt++] = vadd(a, vscale(vsub(d, a), (real)rnd(&r)));
        }
    CHECK(rejected == 0);
    for (k = 0; k < 30000; k++) {
        vec3 tgt = targets[rnd_int(&r, 0, nt - 1)], q = vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.5)), o, d;
        real s = (real)rnd_in(&r, 0.5, 8);
        mprt__ray ray;
        o = vadd(tgt, vscale(vsub(tgt, q), s));
        d = vsub(tgt, o);
        ray = mkray(o, d);
        rays++;
        if (mesh_hits(&m, &ray, 0, 1 + R(0.3) / s) == 0) leaks++;
        ray = mkray(q, vsub(tgt, q));
        rays++;
        if (mesh_hits(&m, &ray, 0, R(1.3)) == 0) leaks++;
    }
    CHECK_MSG(leaks == 0, "%d of %d rays leaked", leaks, rays);
    free(targets);
    mesh_free(&m);
}

/* Flat grids of quads and triangles, and a triangulated height field: rays
 * exactly through shared vertices and edges never leak. */
static void test_watertight_grids(void)
{
    enum { N = 8 };
    rng r;
    int field, i, j, k, leaks = 0, rays = 0;
    rng_seed(&r, 10);
    for (field = 0; field < 2; field++) {
        mesh m = {0};
        real z[N + 1][N + 1];
        int diag_ac[N][N]; /* the cell is split along a-c (its diagonal is an edge) */
        for (i = 0; i <= N; i++)
            for (j = 0; j <= N; j++) z[i][j] = field ? (real)rnd_int(&r, -8, 8) / 8 : 0;
        for (i = 0; i < N; i++)
            for (j = 0; j < N; j++) {
                vec3 a = v3((real)i, (real)j, z[i][j]), b = v3((real)(i + 1), (real)j, z[i + 1][j]),
                     c = v3((real)(i + 1), (real)(j + 1), z[i + 1][j + 1]),
                     d = v3((real)i, (real)(j + 1), z[i][j + 1]), f[4];
                int kind = field ? 1 + rnd_int(&r, 0, 1) : rnd_int(&r, 0, 2);
                diag_ac[i][j] = kind == 1;
                if (kind == 0) {
                    f[0] = a;
                    f[1] = b;
                    f[2] = c;
                    f[3] = d;
                    CHECK(mesh_add(&m, 4, f, rnd(&r) < 0.5) == 0);
                } else if (kind == 1) {
                    f[0] = a;
                    f[1] = b;
                    f[2] = c;
                    CHECK(mesh_add(&m, 3, f, rnd(&r) < 0.5) == 0);
                    f[1] = c;
                    f[2] = d;
                    CHECK(mesh_add(&m, 3, f, rnd(&r) < 0.5) == 0);
                } else {
                    f[0] = a;
                    f[1] = b;
                    f[2] = d;
                    CHECK(mesh_add(&m, 3, f, rnd(&r) < 0.5) == 0);
                    f[0] = b;
                    f[1] = c;
                    CHECK(mesh_add(&m, 3, f, rnd(&r) < 0.5) == 0);
                }
            }
        for (k = 0; k < 40000; k++) {
            /* interior vertex, or a dyadic point on an interior edge */
            int gi = rnd_int(&r, 1, N - 2), gj = rnd_int(&r, 1, N - 2), e = rnd_int(&r, 0, 3);
            real f = (real)rnd_int(&r, 0, 16) / 16;
            vec3 tgt = v3((real)gi, (real)gj, z[gi][gj]), o, d, nb;
            mprt__ray ray;
            real up = field ? (real)rnd_int(&r, 80, 160) / 4 : (real)rnd_int(&r, 1, 32) / 4;
            if (e == 1) nb = v3((real)(gi + 1), (real)gj, z[gi + 1][gj]);
            else if (e == 2) nb = v3((real)gi, (real)(gj + 1), z[gi][gj + 1]);
            else if (e == 3 && (diag_ac[gi][gj] || !field)) nb = v3((real)(gi + 1), (real)(gj + 1), z[gi + 1][gj + 1]);
            else nb = tgt;
            tgt = vadd(tgt, vscale(vsub(nb, tgt), f));
            if (!field && rnd(&r) < 0.5) up = -up;
            o = vadd(tgt, v3((real)rnd_int(&r, -64, 64) / 16, (real)rnd_int(&r, -64, 64) / 16, up));
            d = vsub(tgt, o);
            ray = mkray(o, d);
            rays++;
            if (mesh_hits(&m, &ray, 0, 1 + R(1e-3)) == 0 && leaks++ < 5)
                fprintf(stderr, "  leak: field %d target (%g %g %g) o (%g %g %g) e %d f %g\n", field,
                        (double)tgt.x, (double)tgt.y, (double)tgt.z, (double)o.x, (double)o.y, (double)o.z, e, (double)f);
        }
        mesh_free(&m);
    }
    CHECK_MSG(leaks == 0, "%d of %d rays leaked", leaks, rays);
}

/* Patches interpolate vertex normals; plain polygons return the geometric normal. */
static void test_polygon_normal(void)
{
    mesh m = {0};
    vec3 v[4], nn[7], n;
    v[0] = vd(0, 0, 0);
    v[1] = vd(1, 0, 0);
    v[2] = vd(1, 1, 0);
    v[3] = vd(0, 1, 0);
    CHECK(mesh_add(&m, 3, v, 0) == 0);
    CHECK(mesh_add(&m, 4, v, 0) == 0);
    /* triangle: normals 0..2; quad (first == 3): normals 3..6 */
    nn[0] = vd(0, 0, 1);
    nn[1] = vnorm(vd(1, 0, 1));
    nn[2] = vnorm(vd(0, 1, 1));
    nn[3] = vd(0, 0, 1);
    nn[4] = vd(0, 0, 1);
    nn[5] = vnorm(vd(1, 1, 1));
    nn[6] = vnorm(vd(-1, 0, 1));
    n = mprt__polygon_normal(&m.p[0], m.v, nn, vd(0.5, 0.5, 0));
    CHECK(n.x == 0 && n.y == 0 && n.z == 1); /* not a patch */
    m.p[0].has_normals = 1;
    m.p[1].has_normals = 1;
    n = mprt__polygon_normal(&m.p[0], m.v, nn, vd(1, 0, 0));
    CHECK_NEAR(n.x, nn[1].x, TOL);
    CHECK_NEAR(n.z, nn[1].z, TOL);
    n = mprt__polygon_normal(&m.p[0], m.v, nn, vd(1, 0.5, 0));
    {
        vec3 e = vnorm(vadd(nn[1], nn[2]));
        CHECK_NEAR(n.x, e.x, TOL);
        CHECK_NEAR(n.y, e.y, TOL);
        CHECK_NEAR(n.z, e.z, TOL);
    }
    CHECK_NEAR(vlen(n), 1, TOL);
    /* quad: second fan triangle (v0, v2, v3) holds (0.25, 0.75) */
    n = mprt__polygon_normal(&m.p[1], m.v, nn, vd(0.25, 0.75, 0));
    {
        vec3 e = vnorm(vadd(vadd(vscale(nn[3], R(0.25)), vscale(nn[5], R(0.25))), vscale(nn[6], R(0.5))));
        CHECK_NEAR(n.x, e.x, TOL);
        CHECK_NEAR(n.y, e.y, TOL);
        CHECK_NEAR(n.z, e.z, TOL);
    }
    mesh_free(&m);
}

/* ---- Cones and cylinders ---------------------------------------------------- */

/* prepare fills the frame and rejects coincident ends and bad radii. */
static void test_cone_prepare(void)
{
    mprt__cone c;
    char err[200];
    rng r;
    int i;
    memset(&c, 0, sizeof c);
    c.base = vd(1, 1, 1);
    c.apex = vd(1, 1, 1);
    c.rb = 1;
    c.ra = 1;
    CHECK(mprt__cone_prepare(&c, err, sizeof err) == MPRT__BAD);
    CHECK_MSG(strstr(err, "coincide") != NULL, "message '%s'", err);
    c.apex = vd(1, 1, 3);
    c.rb = -1;
    CHECK(mprt__cone_prepare(&c, err, sizeof err) == MPRT__BAD);
    CHECK_MSG(strstr(err, "negative radius") != NULL, "message '%s'", err);
    c.rb = 1;
    c.ra = -0.5;
    CHECK(mprt__cone_prepare(&c, err, sizeof err) == MPRT__BAD);
    c.rb = 0;
    c.ra = 0;
    CHECK(mprt__cone_prepare(&c, err, sizeof err) == MPRT__BAD);
    CHECK_MSG(strstr(err, "zero") != NULL, "message '%s'", err);
    c.rb = 1;
    c.ra = 0;
    CHECK(mprt__cone_prepare(&c, err, sizeof err) == 0);
    CHECK(c.len == 2 && c.slope == R(-0.5) && c.w.z == 1);

    rng_seed(&r, 11);
    for (i = 0; i < 1000; i++) {
        vec3 w = rnd_unit(&r), x;
        if (i == 0) w = vd(0, 0, -1);
        c = mkcone(vd(1, 2, 3), 1, vadd(vd(1, 2, 3), vscale(w, 3)), 0.5);
        CHECK_NEAR(vdot(c.w, w), 1, TOL);
        CHECK_NEAR(vdot(c.u, c.u), 1, TOL);
        CHECK_NEAR(vdot(c.v, c.v), 1, TOL);
        CHECK_NEAR(vdot(c.u, c.v), 0, TOL);
        CHECK_NEAR(vdot(c.u, c.w), 0, TOL);
        x = vcross(c.u, c.v);
        CHECK_NEAR(vdot(x, c.w), 1, TOL);
        CHECK_NEAR(c.len, 3, TOL);
    }
}

/* Cylinder hits agree with hand-computed values: side, inside, open ends, axis, tangent. */
static void test_cylinder_analytic(void)
{
    mprt__cone c = mkcone(vd(0, 0, 0), 1, vd(0, 0, 2), 1);
    mprt__ray ray;
    real t = 0;
    ray = mkray(vd(-5, 0, 1), vd(1, 0, 0));
    CHECK(mprt__cylinder_hit(&c, &ray, 0, 100, &t));
    CHECK_NEAR(t, 4, TOL);
    CHECK(mprt__cylinder_hit(&c, &ray, t, 100, &t));
    CHECK_NEAR(t, 6, TOL);
    ray = mkray(vd(0, 0, 1), vd(0, 2, 0)); /* from the axis */
    CHECK(mprt__cylinder_hit(&c, &ray, 0, 100, &t));
    CHECK_NEAR(t, 0.5, TOL);
    ray = mkray(vd(0, 0, -5), vd(0, 0, 1)); /* along the axis */
    CHECK(!mprt__cylinder_hit(&c, &ray, 0, 100, &t));
    ray = mkray(vd(1, 0, -5), vd(0, 0, 1)); /* along the surface */
    CHECK(!mprt__cylinder_hit(&c, &ray, 0, 100, &t));
    ray = mkray(vd(-5, 0, 3), vd(1, 0, 0)); /* above the top rim */
    CHECK(!mprt__cylinder_hit(&c, &ray, 0, 100, &t));
    ray = mkray(vd(0, 0, -1), vd(1, 0, 2)); /* in through the open bottom, out the side */
    CHECK(mprt__cylinder_hit(&c, &ray, 0, 100, &t));
    CHECK_NEAR(t, 1, TOL);
    ray = mkray(vd(1, -5, 1), vd(0, 1, 0)); /* tangent */
    CHECK(mprt__cylinder_hit(&c, &ray, 0, 100, &t) && t == 5);
    ray = mkray(vd(1 + 1e3 * EPS, -5, 1), vd(0, 1, 0));
    CHECK(!mprt__cylinder_hit(&c, &ray, 0, 100, &t));
    CHECK_NEAR(mprt__cone_normal(&c, vd(0, -1, 0.5)).y, -1, TOL);
    CHECK_NEAR(mprt__cone_normal(&c, vd(0.6, 0.8, 2)).x, 0.6, TOL);
}

/* Cone hits agree with hand-computed values: side, apex along the axis, generators. */
static void test_cone_analytic(void)
{
    mprt__cone c = mkcone(vd(0, 0, 0), 1, vd(0, 0, 1), 0), f = mkcone(vd(0, 0, 0), 1, vd(0, 0, 1), 0.5);
    mprt__ray ray;
    real t = 0;
    vec3 n;
    ray = mkray(vd(-5, 0, 0.5), vd(1, 0, 0));
    CHECK(mprt__cone_hit(&c, &ray, 0, 100, &t));
    CHECK_NEAR(t, 4.5, TOL);
    CHECK(mprt__cone_hit(&c, &ray, t, 100, &t));
    CHECK_NEAR(t, 5.5, TOL);
    ray = mkray(vd(0, 0, 5), vd(0, 0, -1)); /* down the axis onto the apex */
    CHECK(mprt__cone_hit(&c, &ray, 0, 100, &t));
    CHECK_NEAR(t, 4, TOL);
    CHECK(!mprt__cone_hit(&f, &ray, 0, 100, &t)); /* a frustum has no apex point */
    ray = mkray(vd(0, 0, -5), vd(0, 0, 1));       /* up the axis from below */
    CHECK(!mprt__cone_hit(&f, &ray, 0, 100, &t));
    ray = mkray(vd(1.5, 0, -1), vd(-1, 0, 1)); /* parallel to a generator: A == 0 */
    CHECK(mprt__cone_hit(&c, &ray, 0, 100, &t));
    CHECK_NEAR(t, 1.75, TOL);
    ray = mkray(vd(2, 0, -1), vd(-1, 0, 1)); /* on a generator's line: grazes, no hit */
    CHECK(!mprt__cone_hit(&c, &ray, 0, 100, &t) || fabs((double)t - 2) < 1e-3);
    ray = mkray(vd(-5, 0, 0.5), vd(1, 0, 0)); /* frustum: r(0.5) = 0.75 */
    CHECK(mprt__cone_hit(&f, &ray, 0, 100, &t));
    CHECK_NEAR(t, 4.25, TOL);
    /* normals: outward, perpendicular to the generator */
    n = mprt__cone_normal(&c, vd(0.5, 0, 0.5));
    CHECK_NEAR(n.x, 1 / sqrt(2.0), TOL);
    CHECK_NEAR(n.z, 1 / sqrt(2.0), TOL);
    n = mprt__cone_normal(&f, vd(0, -0.75, 0.5));
    CHECK_NEAR(vdot(n, vd(0, 0.5, 1)), 0, TOL);
    CHECK(n.y < 0 && n.z > 0);
}

/* Random rays at random cones, frustums and cylinders agree with a long-double
 * reference, including rays through the apex, near the axis and near generators. */
static void test_cone_random(void)
{
    rng r;
    int i, bad = 0, n = 0, hits = 0;
    rng_seed(&r, 12);
    for (i = 0; i < 60000; i++) {
        int kind = i % 4;
        vec3 base = vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 3)), w = rnd_unit(&r), o, d;
        double len = rnd_in(&r, 0.2, 3), rb = rnd_in(&r, 0.1, 1.5);
        double ra = kind == 0 ? rb : kind == 1 ? 0 : kind == 2 ? rnd_in(&r, 0, 2) : rnd_in(&r, 0.1, 1.5);
        mprt__cone c = mkcone(base, rb, vadd(base, vscale(w, (real)len)), ra);
        mprt__ray ray;
        real t = 0;
        double tr = 0;
        int h, hr, amb, mode = rnd_int(&r, 0, 3);
        vec3 aim = cone_point(&c, rnd_in(&r, -0.2, 1.2), rnd_in(&r, 0, 2 * PI));
        if (mode == 0) { /* aim near a surface point */
            aim = vadd(aim, vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.3)));
            o = vadd(aim, vscale(rnd_unit(&r), (real)rnd_in(&r, 0.5, 8)));
            d = vsub(aim, o);
        } else if (mode == 1) { /* through the apex end's centre */
            o = vadd(c.apex, vscale(rnd_unit(&r), (real)rnd_in(&r, 0.5, 8)));
            d = vsub(c.apex, o);
        } else if (mode == 2) { /* nearly along the axis */
            o = vadd(vmadd(base, w, (real)rnd_in(&r, -5, -1)), vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.5)));
            d = vadd(w, vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.05)));
        } else { /* nearly parallel to a generator, from outside or inside */
            vec3 g = vsub(cone_point(&c, 1, 1.0), cone_point(&c, 0, 1.0));
            d = vadd(g, vscale(rnd_unit(&r), (real)(rnd_in(&r, 0, 1e-3) * len)));
            o = vsub(vadd(aim, vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.5))), vscale(d, 2));
        }
        ray = mkray(o, d);
        h = cone_any_hit(&c, &ray, 0, REAL_MAX, &t);
        hr = cone_ref(&c, o, d, 0, (double)REAL_MAX, &tr, &amb);
        if (h) {
            /* near-double roots (tangent rays, rays through the apex) are known to sqrt(eps) */
            double tol = amb ? 64 * sqrt(EPS) : 1e3 * EPS;
            /* any hit lies on the surface, between the rims */
            vec3 p = vmadd(o, d, t), q = vsub(p, c.base);
            double z = (double)vdot(q, c.w), x = (double)vdot(q, c.u), y = (double)vdot(q, c.v);
            double rr = (double)c.rb + (double)c.slope * z, sc = 1 + dmag(o) + dlen(d) * fabs((double)t);
            hits++;
            if (fabs(sqrt(x * x + y * y) - rr) > tol * sc || z < -tol * sc || z > (double)c.len + tol * sc) {
                if (bad++ < 5)
                    fprintf(stderr, "  cone ray %d (kind %d mode %d): hit off the surface: rho %.9g r %.9g z %.9g len %.9g t %.9g\n",
                            i, kind, mode, sqrt(x * x + y * y), rr, z, (double)c.len, (double)t);
                continue;
            }
        }
        if (amb) continue;
        n++;
        if (h != hr || (h && fabs((double)t - tr) > 1e2 * TOL * (fabs(tr) + 1))) {
            if (bad++ < 5)
                fprintf(stderr, "  cone ray %d (kind %d mode %d): hit %d/%d t %.17g ref %.17g\n", i, kind,
                        mode, h, hr, (double)t, tr);
        }
    }
    CHECK_MSG(bad == 0, "%d of %d rays disagree", bad, n);
    CHECK(n > 40000 && hits > 10000);
}

/* Scaled by 1e-6 and 1e6, a cone's hits scale with it. */
static void test_cone_scaled(void)
{
    static const double scales[] = {1e-6, 1e6};
    rng r;
    int k, i, bad = 0;
    for (k = 0; k < 2; k++) {
        double sc = scales[k];
        rng_seed(&r, 13);
        for (i = 0; i < 4000; i++) {
            int cyl = i & 1;
            vec3 base = vd(0.5, 1, -0.25), w = rnd_unit(&r), o, d;
            mprt__cone c1 = mkcone(base, 0.5, vadd(base, w), cyl ? 0.5 : 0.1), cs;
            vec3 aim = cone_point(&c1, rnd_in(&r, 0.05, 0.95), rnd_in(&r, 0, 2 * PI));
            mprt__ray r1, rs;
            real t1 = 0, ts = 0;
            int h1, hs;
            o = vadd(aim, vscale(rnd_unit(&r), (real)rnd_in(&r, 1, 5)));
            d = vsub(aim, o);
            cs = mkcone(vscale(c1.base, (real)sc), 0.5 * sc, vscale(c1.apex, (real)sc), (double)c1.ra * sc);
            r1 = mkray(o, d);
            rs = mkray(vscale(o, (real)sc), d);
            h1 = cone_any_hit(&c1, &r1, 0, REAL_MAX, &t1);
            hs = cone_any_hit(&cs, &rs, 0, REAL_MAX, &ts);
            {
                double tr;
                int amb;
                cone_ref(&c1, o, d, 0, 1e300, &tr, &amb);
                if (amb) continue; /* near tangent: either answer is right */
            }
            if (h1 != hs || (h1 && fabs((double)ts / sc - (double)t1) > 1e2 * TOL * (double)t1)) {
                if (bad++ < 5) {
                    double tr;
                    int amb, hr = cone_ref(&c1, o, d, 0, 1e300, &tr, &amb);
                    fprintf(stderr, "  scale %g ray %d (cyl %d): hit %d/%d t %.9g/%.9g ref %d %.9g\n", sc, i, cyl, h1, hs, (double)t1, (double)ts / sc, hr, tr);
                    hr = cone_ref(&cs, rs.o, d, 0, 1e300, &tr, &amb);
                    fprintf(stderr, "  scaled ref %d %.9g amb %d\n", hr, tr / sc, amb);
                }
            }
        }
    }
    CHECK_MSG(bad == 0, "%d scaled cone rays disagree", bad);

    /* Far origins (1e6 away in double, 1e3 in single): hits stay within rounding of |o| */
    {
        double far = EPS > 1e-10 ? 1e3 : 1e6;
        int badfar = 0, n = 0;
        rng_seed(&r, 19);
        for (i = 0; i < 4000; i++) {
            int cyl = i & 1;
            vec3 base = vd(0.5, 1, -0.25), w = rnd_unit(&r), dir, o;
            mprt__cone c = mkcone(base, 0.5, vadd(base, w), cyl ? 0.5 : 0.1);
            vec3 aim = cone_point(&c, rnd_in(&r, 0.05, 0.95), rnd_in(&r, 0, 2 * PI));
            mprt__ray ray;
            real t = 0;
            double tr = 0;
            int h, hr, amb;
            aim = vadd(aim, vscale(rnd_unit(&r), R(0.2)));
            dir = rnd_unit(&r);
            o = vsub(aim, vscale(dir, (real)far));
            ray = mkray(o, dir);
            h = cone_any_hit(&c, &ray, 0, REAL_MAX, &t);
            hr = cone_ref(&c, o, dir, 0, 1e300, &tr, &amb);
            if (amb) continue;
            n++;
            if (h != hr || (h && fabs((double)t - tr) > 64 * EPS * far)) {
                if (badfar++ < 5)
                    fprintf(stderr, "  far cone ray %d: hit %d/%d t %.17g ref %.17g\n", i, h, hr, (double)t, tr);
            }
        }
        CHECK_MSG(badfar == 0, "%d of %d far cone rays disagree", badfar, n);
        CHECK(n > 3000);
    }
}

/* ---- Reintersection --------------------------------------------------------- */

/* A ray leaving a convex surface outward from its hit point never hits it again. */
static void test_reintersect(void)
{
    rng r;
    int i, bad = 0, tried = 0;
    rng_seed(&r, 14);
    for (i = 0; i < 30000; i++) {
        int kind = i % 3;
        double scale = pow(10.0, rnd_in(&r, -3, 3));
        vec3 cen = vscale(rnd_unit(&r), (real)(scale * rnd_in(&r, 0, 10)));
        mprt__sphere s;
        mprt__cone c;
        vec3 o, d, p, n, d2;
        mprt__ray ray;
        real t = 0, tmin;
        int h;
        s.c = cen;
        s.r = (real)scale;
        c = mkcone(cen, scale, vadd(cen, vscale(rnd_unit(&r), (real)(2 * scale))), kind == 1 ? scale : 0.3 * scale);
        o = vadd(cen, vscale(rnd_unit(&r), (real)(scale * rnd_in(&r, 4, 20))));
        d = vsub(kind == 0 ? vadd(cen, vscale(rnd_unit(&r), (real)(0.9 * scale)))
                           : cone_point(&c, rnd_in(&r, 0.05, 0.95), rnd_in(&r, 0, 2 * PI)),
                 o);
        ray = mkray(o, d);
        h = kind == 0 ? mprt__sphere_hit(&s, &ray, 0, REAL_MAX, &t) : cone_any_hit(&c, &ray, 0, REAL_MAX, &t);
        if (!h) continue;
        p = vmadd(o, d, t);
        n = kind == 0 ? mprt__sphere_normal(&s, p) : mprt__cone_normal(&c, p);
        if (kind != 0 && vdot(n, d) > 0) continue; /* reached the inside of the cone first */
        /* a random direction in the outer hemisphere, not grazing */
        do d2 = rnd_unit(&r);
        while (vdot(d2, n) < R(0.05));
        tried++;
        tmin = (real)(256 * EPS * (dmag(p) + 3 * scale));
        ray = mkray(p, d2);
        h = kind == 0 ? mprt__sphere_hit(&s, &ray, tmin, REAL_MAX, &t) : cone_any_hit(&c, &ray, tmin, REAL_MAX, &t);
        if (h && bad++ < 5) fprintf(stderr, "  reintersect %d (kind %d): t %.9g tmin %.9g\n", i, kind, (double)t, (double)tmin);
    }
    CHECK_MSG(bad == 0, "%d of %d rays hit again", bad, tried);
    CHECK(tried > 15000);
}

/* ---- Box overlap -------------------------------------------------------------- */

/* Boxes holding a sphere's surface point are never missed; clearly separated ones are rejected. */
static void test_sphere_box(void)
{
    rng r;
    int i, miss = 0, wrong = 0;
    mprt__sphere s;
    rng_seed(&r, 15);
    for (i = 0; i < 40000; i++) {
        double sc = pow(10.0, rnd_in(&r, -4, 4));
        vec3 lo, hi, u = rnd_unit(&r), q;
        s.c = vscale(rnd_unit(&r), (real)(sc * rnd_in(&r, 0, 5)));
        s.r = (real)(sc * rnd_in(&r, 0.1, 2));
        box_around(&r, vmadd(s.c, u, s.r), 2 * (double)s.r, &lo, &hi);
        if (!mprt__sphere_box(&s, lo, hi)) miss++;
        /* outside: nearest point at 1.2 r or more */
        q = vmadd(s.c, rnd_unit(&r), (real)((double)s.r * rnd_in(&r, 1.35, 3)));
        box_at(q, 0.08 * (double)s.r, &lo, &hi);
        if (mprt__sphere_box(&s, lo, hi)) wrong++;
        /* inside: farthest point within 0.95 r */
        q = vmadd(s.c, rnd_unit(&r), (real)((double)s.r * rnd_in(&r, 0, 0.8)));
        box_at(q, 0.08 * (double)s.r, &lo, &hi);
        if (mprt__sphere_box(&s, lo, hi)) wrong++;
    }
    CHECK_MSG(miss == 0, "%d boxes on the surface missed", miss);
    CHECK_MSG(wrong == 0, "%d separated boxes reported", wrong);
}

/* Boxes holding a polygon's point are never missed; boxes off the plane or
 * outside the outline are rejected. */
static void test_polygon_box(void)
{
    rng r;
    double x[144], y[144];
    int rep, i, miss = 0, wrong = 0, tested = 0;
    gear_outline(144, x, y);
    rng_seed(&r, 16);
    for (rep = 0; rep < 20; rep++) {
        plane3 pl;
        mesh m = {0};
        vec3 v[144];
        int n = rep % 2 ? 144 : 3;
        double sc = pow(10.0, rnd_in(&r, -3, 3));
        plane_make(&pl, &r, sc * rnd_in(&r, -5, 5), sc * rnd_in(&r, -5, 5), sc * rnd_in(&r, -5, 5));
        if (n == 3) { /* a convex triangle: the clip test is exact */
            x[0] = 1, y[0] = 0, x[1] = -0.5, y[1] = 0.8, x[2] = -0.5, y[2] = -0.8;
        } else {
            gear_outline(144, x, y);
        }
        for (i = 0; i < n; i++) v[i] = plane_vec(&pl, sc * x[i], sc * y[i], 0);
        CHECK(mesh_add(&m, n, v, rep & 2) == 0);
        for (i = 0; i < 4000; i++) {
            double px, py;
            vec3 lo, hi, p;
            /* a point inside (rejection sampling), on an edge, or a vertex */
            int how = rnd_int(&r, 0, 3);
            if (how == 0) {
                int j = rnd_int(&r, 0, n - 1);
                p = m.v[j];
            } else if (how == 1) {
                int j = rnd_int(&r, 0, n - 1), k = (j + 1) % n;
                p = vadd(m.v[j], vscale(vsub(m.v[k], m.v[j]), (real)rnd(&r)));
            } else {
                do {
                    px = rnd_in(&r, -1, 1);
                    py = rnd_in(&r, -1, 1);
                } while (!pip2(x, y, n, px, py));
                p = plane_vec(&pl, sc * px, sc * py, 0);
            }
            box_around(&r, p, sc, &lo, &hi);
            tested++;
            if (!mprt__polygon_box(&m.p[0], m.v, lo, hi)) {
                if (miss++ < 5) fprintf(stderr, "  polygon box missed (rep %d, how %d)\n", rep, how);
            }
            /* off the plane: distance h, cube half size h/3 */
            {
                double h = sc * rnd_in(&r, 0.01, 0.5);
                px = rnd_in(&r, -1.2, 1.2);
                py = rnd_in(&r, -1.2, 1.2);
                box_at(plane_vec(&pl, sc * px, sc * py, rnd(&r) < 0.5 ? h : -h), h / 3, &lo, &hi);
                if (mprt__polygon_box(&m.p[0], m.v, lo, hi)) wrong++;
            }
            /* in the plane, outside the outline's circumcircle */
            {
                double a = rnd_in(&r, 0, 2 * PI), rad = rnd_in(&r, 1.3, 2);
                box_at(plane_vec(&pl, sc * rad * cos(a), sc * rad * sin(a), 0), 0.1 * sc, &lo, &hi);
                if (mprt__polygon_box(&m.p[0], m.v, lo, hi)) wrong++;
            }
        }
        mesh_free(&m);
    }
    CHECK_MSG(miss == 0, "%d of %d boxes on the polygon missed", miss, tested);
    CHECK_MSG(wrong == 0, "%d separated boxes reported", wrong);
}

/* Boxes holding a cone's surface point are never missed; boxes well inside,
 * well outside or beyond the ends are rejected. */
static void test_cone_box(void)
{
    rng r;
    int i, miss = 0, wrong = 0;
    rng_seed(&r, 17);
    for (i = 0; i < 40000; i++) {
        int kind = i % 3;
        double sc = pow(10.0, rnd_in(&r, -4, 4)), len = sc * rnd_in(&r, 0.5, 3), rb = sc * rnd_in(&r, 0.3, 1);
        double ra = kind == 0 ? rb : kind == 1 ? 0 : rb * rnd_in(&r, 0.2, 2), f, rr, g;
        vec3 base = vscale(rnd_unit(&r), (real)(sc * rnd_in(&r, 0, 5))), lo, hi, p;
        mprt__cone c = mkcone(base, rb, vadd(base, vscale(rnd_unit(&r), (real)len)), ra);
        f = rnd(&r);
        if (rnd(&r) < 0.1) f = rnd(&r) < 0.5 ? 0 : 1; /* on a rim */
        p = cone_point(&c, f, rnd_in(&r, 0, 2 * PI));
        box_around(&r, p, sc, &lo, &hi);
        if (!mprt__cone_box(&c, lo, hi)) {
            if (miss++ < 5) fprintf(stderr, "  cone box missed (kind %d, f %g)\n", kind, f);
        }
        /* separated: |g| = |rho - r(z)| at the centre beyond the box's reach */
        f = rnd_in(&r, 0.1, 0.9);
        rr = (double)c.rb + (double)c.slope * f * (double)c.len;
        g = rnd(&r) < 0.5 ? rr * rnd_in(&r, 0, 0.6) : rr * rnd_in(&r, 1.5, 3) + 0.2 * sc;
        {
            double a = rnd_in(&r, 0, 2 * PI), h, q[3];
            int k;
            for (k = 0; k < 3; k++)
                q[k] = (double)vget(c.base, k) + f * (double)c.len * (double)vget(c.w, k) +
                       g * (cos(a) * (double)vget(c.u, k) + sin(a) * (double)vget(c.v, k));
            h = fabs(g - rr) / sqrt(1 + (double)c.slope * (double)c.slope) / sqrt(3.0) * 0.9;
            if (h > 0.1 * (double)c.len) h = 0.1 * (double)c.len;
            box_at(vd(q[0], q[1], q[2]), h, &lo, &hi);
            if (mprt__cone_box(&c, lo, hi)) {
                if (wrong++ < 5) fprintf(stderr, "  cone box wrongly reported (kind %d)\n", kind);
            }
        }
        /* beyond an end plane */
        p = vmadd(c.base, c.w, (real)(-0.3 * (double)c.len));
        box_at(p, 0.1 * (double)c.len, &lo, &hi);
        if (mprt__cone_box(&c, lo, hi)) wrong++;
        p = vmadd(c.apex, c.w, (real)(0.3 * (double)c.len));
        box_at(p, 0.1 * (double)c.len, &lo, &hi);
        if (mprt__cone_box(&c, lo, hi)) wrong++;
    }
    CHECK_MSG(miss == 0, "%d boxes on the surface missed", miss);
    CHECK_MSG(wrong == 0, "%d separated boxes reported", wrong);
}

/* Cone bounds hold every rim point and are tight. */
static void test_cone_bounds(void)
{
    rng r;
    int i, j, bad = 0, loose = 0;
    rng_seed(&r, 18);
    for (i = 0; i < 500; i++) {
        vec3 base = vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 5)), lo, hi, mx, mn;
        mprt__cone c = mkcone(base, rnd_in(&r, 0, 2), vadd(base, vscale(rnd_unit(&r), (real)rnd_in(&r, 0.1, 3))),
                              rnd_in(&r, 0.01, 2));
        if (i == 0) c = mkcone(vd(0, 0, 0), 1, vd(0, 0, 1), 0.5);
        mprt__cone_bounds(&c, &lo, &hi);
        mn = v3(REAL_MAX, REAL_MAX, REAL_MAX);
        mx = vscale(mn, -1);
        for (j = 0; j < 2000; j++) {
            vec3 p = cone_point(&c, (double)(j & 1), 2 * PI * j / 2000);
            double tol = 16 * EPS * (dmag(p) + 1);
            if (p.x < lo.x - tol || p.y < lo.y - tol || p.z < lo.z - tol || p.x > hi.x + tol ||
                p.y > hi.y + tol || p.z > hi.z + tol)
                bad++;
            if (p.x < mn.x) mn.x = p.x;
            if (p.y < mn.y) mn.y = p.y;
            if (p.z < mn.z) mn.z = p.z;
            if (p.x > mx.x) mx.x = p.x;
            if (p.y > mx.y) mx.y = p.y;
            if (p.z > mx.z) mx.z = p.z;
        }
        if (ddist(mn, lo) > 1e-4 * (1 + dmag(lo)) || ddist(mx, hi) > 1e-4 * (1 + dmag(hi))) loose++;
        if (i == 0) CHECK(lo.x == -1 && hi.x == 1 && lo.z == 0 && hi.z == 1);
    }
    CHECK_MSG(bad == 0, "%d rim points outside the bounds", bad);
    CHECK_MSG(loose == 0, "%d bounds not tight", loose);
}

int main(void)
{
    RUN(test_ray_prepare);
    RUN(test_sphere_analytic);
    RUN(test_sphere_random);
    RUN(test_sphere_tangent);
    RUN(test_sphere_inside);
    RUN(test_sphere_scaled);
    RUN(test_polygon_prepare);
    RUN(test_polygon_printed);
    RUN(test_polygon_spd_files);
    RUN(test_polygon_plane);
    RUN(test_polygon_concave);
    RUN(test_watertight_octahedron);
    RUN(test_watertight_sphere_mesh);
    RUN(test_watertight_grids);
    RUN(test_polygon_normal);
    RUN(test_cone_prepare);
    RUN(test_cylinder_analytic);
    RUN(test_cone_analytic);
    RUN(test_cone_random);
    RUN(test_cone_scaled);
    RUN(test_reintersect);
    RUN(test_sphere_box);
    RUN(test_polygon_box);
    RUN(test_cone_box);
    RUN(test_cone_bounds);
    return CHECK_DONE();
}
