/* test_watertight.c: the watertight polygon test (prim_polygon.c): closed meshes let no ray through.
 *
 * Every randomised case seeds its own generator, so a failure reproduces. */
#include "geom.h"

/* Number of faces hit in (tmin, tmax]. */
static int mesh_hits(const mesh *m, const mprt__ray *ray, real tmin, real tmax)
{
    int i, n = 0;
    real t;
    for (i = 0; i < m->np; i++) n += mprt__polygon_hit(&m->p[i], m->v, ray, tmin, tmax, &t);
    return n;
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

enum { QUAD, SPLIT_AC, SPLIT_BD };

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
                /* a quad, or two triangles split along a-c or along b-d */
                int split = field ? SPLIT_AC + rnd_int(&r, 0, 1) : rnd_int(&r, 0, 2);
                diag_ac[i][j] = split == SPLIT_AC;
                if (split == QUAD) {
                    f[0] = a;
                    f[1] = b;
                    f[2] = c;
                    f[3] = d;
                    CHECK(mesh_add(&m, 4, f, rnd(&r) < 0.5) == 0);
                } else if (split == SPLIT_AC) {
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

int main(void)
{
    RUN(test_watertight_octahedron);
    RUN(test_watertight_sphere_mesh);
    RUN(test_watertight_grids);
    return CHECK_DONE();
}
