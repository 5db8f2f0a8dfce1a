/* test_sphere.c: rays (ray.c) and spheres (prim_sphere.c).
 *
 * Every randomised case seeds its own generator, so a failure reproduces. */
#include "geom.h"

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

int main(void)
{
    RUN(test_ray_prepare);
    RUN(test_sphere_analytic);
    RUN(test_sphere_random);
    RUN(test_sphere_tangent);
    RUN(test_sphere_inside);
    RUN(test_sphere_scaled);
    return CHECK_DONE();
}
