/* test_overlap.c: reintersection from a hit point, and the conservative box tests and bounds of every primitive (prim_*.c).
 *
 * Every randomised case seeds its own generator, so a failure reproduces. */
#include "geom.h"

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

/* ---- Reintersection --------------------------------------------------------- */

/* Shapes of the random cases. */
enum { SPHERE_SHAPE, CYLINDER_SHAPE, CONE_SHAPE, FRUSTUM_SHAPE };

/* A ray leaving a convex surface outward from its hit point never hits it again. */
static void test_reintersect(void)
{
    rng r;
    int i, bad = 0, tried = 0;
    rng_seed(&r, 14);
    for (i = 0; i < 30000; i++) {
        int shape = i % 3; /* SPHERE_SHAPE, CYLINDER_SHAPE or CONE_SHAPE */
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
        c = mkcone(cen, scale, vadd(cen, vscale(rnd_unit(&r), (real)(2 * scale))), shape == CYLINDER_SHAPE ? scale : 0.3 * scale);
        o = vadd(cen, vscale(rnd_unit(&r), (real)(scale * rnd_in(&r, 4, 20))));
        d = vsub(shape == SPHERE_SHAPE ? vadd(cen, vscale(rnd_unit(&r), (real)(0.9 * scale)))
                           : cone_point(&c, rnd_in(&r, 0.05, 0.95), rnd_in(&r, 0, 2 * PI)),
                 o);
        ray = mkray(o, d);
        h = shape == SPHERE_SHAPE ? mprt__sphere_hit(&s, &ray, 0, REAL_MAX, &t) : cone_any_hit(&c, &ray, 0, REAL_MAX, &t);
        if (!h) continue;
        p = vmadd(o, d, t);
        n = shape == SPHERE_SHAPE ? mprt__sphere_normal(&s, p) : mprt__cone_normal(&c, p);
        if (shape != SPHERE_SHAPE && vdot(n, d) > 0) continue; /* reached the inside of the cone first */
        /* a random direction in the outer hemisphere, not grazing */
        do d2 = rnd_unit(&r);
        while (vdot(d2, n) < R(0.05));
        tried++;
        tmin = (real)(256 * EPS * (dmag(p) + 3 * scale));
        ray = mkray(p, d2);
        h = shape == SPHERE_SHAPE ? mprt__sphere_hit(&s, &ray, tmin, REAL_MAX, &t) : cone_any_hit(&c, &ray, tmin, REAL_MAX, &t);
        if (h && bad++ < 5) fprintf(stderr, "  reintersect %d (shape %d): t %.9g tmin %.9g\n", i, shape, (double)t, (double)tmin);
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
        int shape = CYLINDER_SHAPE + i % 3; /* or CONE_SHAPE (pointed) or FRUSTUM_SHAPE */
        double sc = pow(10.0, rnd_in(&r, -4, 4)), len = sc * rnd_in(&r, 0.5, 3), rb = sc * rnd_in(&r, 0.3, 1);
        double ra = shape == CYLINDER_SHAPE ? rb : shape == CONE_SHAPE ? 0 : rb * rnd_in(&r, 0.2, 2), f, rr, g;
        vec3 base = vscale(rnd_unit(&r), (real)(sc * rnd_in(&r, 0, 5))), lo, hi, p;
        mprt__cone c = mkcone(base, rb, vadd(base, vscale(rnd_unit(&r), (real)len)), ra);
        f = rnd(&r);
        if (rnd(&r) < 0.1) f = rnd(&r) < 0.5 ? 0 : 1; /* on a rim */
        p = cone_point(&c, f, rnd_in(&r, 0, 2 * PI));
        box_around(&r, p, sc, &lo, &hi);
        if (!mprt__cone_box(&c, lo, hi)) {
            if (miss++ < 5) fprintf(stderr, "  cone box missed (shape %d, f %g)\n", shape, f);
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
                if (wrong++ < 5) fprintf(stderr, "  cone box wrongly reported (shape %d)\n", shape);
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
    RUN(test_reintersect);
    RUN(test_sphere_box);
    RUN(test_polygon_box);
    RUN(test_cone_box);
    RUN(test_cone_bounds);
    return CHECK_DONE();
}
