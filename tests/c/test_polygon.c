/* test_polygon.c: planar polygons (prim_polygon.c): preparation, hits, normals.
 *
 * Every randomised case seeds its own generator, so a failure reproduces. */
#include "geom.h"

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

int main(void)
{
    RUN(test_polygon_prepare);
    RUN(test_polygon_printed);
    RUN(test_polygon_spd_files);
    RUN(test_polygon_plane);
    RUN(test_polygon_concave);
    RUN(test_polygon_normal);
    return CHECK_DONE();
}
