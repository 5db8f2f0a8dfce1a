/* test_cone.c: cones and cylinders (prim_cone.c).
 *
 * Every randomised case seeds its own generator, so a failure reproduces. */
#include "geom.h"

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

/* Shapes of the random cones (apex radius), and where their rays aim. */
enum { CYLINDER, POINTED, ANY_CONE, FRUSTUM, NSHAPES };
enum { NEAR_SURFACE, APEX_CENTRE, ALONG_AXIS, ALONG_GENERATOR, NAIMS };

/* Random rays at random cones, frustums and cylinders agree with a long-double
 * reference, including rays through the apex, near the axis and near generators. */
static void test_cone_random(void)
{
    rng r;
    int i, bad = 0, n = 0, hits = 0;
    rng_seed(&r, 12);
    for (i = 0; i < 60000; i++) {
        int shape = i % NSHAPES;
        vec3 base = vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 3)), w = rnd_unit(&r), o, d;
        double len = rnd_in(&r, 0.2, 3), rb = rnd_in(&r, 0.1, 1.5);
        double ra = shape == CYLINDER ? rb : shape == POINTED ? 0 : shape == ANY_CONE ? rnd_in(&r, 0, 2) : rnd_in(&r, 0.1, 1.5);
        mprt__cone c = mkcone(base, rb, vadd(base, vscale(w, (real)len)), ra);
        mprt__ray ray;
        real t = 0;
        double tr = 0;
        int h, hr, amb, aim_at = rnd_int(&r, 0, NAIMS - 1);
        vec3 aim = cone_point(&c, rnd_in(&r, -0.2, 1.2), rnd_in(&r, 0, 2 * PI));
        if (aim_at == NEAR_SURFACE) {
            aim = vadd(aim, vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.3)));
            o = vadd(aim, vscale(rnd_unit(&r), (real)rnd_in(&r, 0.5, 8)));
            d = vsub(aim, o);
        } else if (aim_at == APEX_CENTRE) {
            o = vadd(c.apex, vscale(rnd_unit(&r), (real)rnd_in(&r, 0.5, 8)));
            d = vsub(c.apex, o);
        } else if (aim_at == ALONG_AXIS) {
            o = vadd(vmadd(base, w, (real)rnd_in(&r, -5, -1)), vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.5)));
            d = vadd(w, vscale(rnd_unit(&r), (real)rnd_in(&r, 0, 0.05)));
        } else { /* ALONG_GENERATOR, from outside or inside */
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
                    fprintf(stderr, "  cone ray %d (shape %d aim %d): hit off the surface: rho %.9g r %.9g z %.9g len %.9g t %.9g\n",
                            i, shape, aim_at, sqrt(x * x + y * y), rr, z, (double)c.len, (double)t);
                continue;
            }
        }
        if (amb) continue;
        n++;
        if (h != hr || (h && fabs((double)t - tr) > 1e2 * TOL * (fabs(tr) + 1))) {
            if (bad++ < 5)
                fprintf(stderr, "  cone ray %d (shape %d aim %d): hit %d/%d t %.17g ref %.17g\n", i, shape,
                        aim_at, h, hr, (double)t, tr);
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

int main(void)
{
    RUN(test_cone_prepare);
    RUN(test_cylinder_analytic);
    RUN(test_cone_analytic);
    RUN(test_cone_random);
    RUN(test_cone_scaled);
    return CHECK_DONE();
}
