/* test_spd_rules.c: the SPD generators against the rules of their source:
 * views and lights, size-dependent geometry (sizes 1..3, tree 8), and the
 * scene name and size arguments. */
#include "spd_check.h"

/* Exact double test for view and light constants (no rounding involved). */
static void check_v3(vec3 v, double x, double y, double z, const char *what)
{
    CHECK_MSG(fabs(v.x - x) <= NEAR && fabs(v.y - y) <= NEAR && fabs(v.z - z) <= NEAR,
              "%s is (%.17g %.17g %.17g), expected (%.17g %.17g %.17g)", what, (double)v.x,
              (double)v.y, (double)v.z, x, y, z);
}

/* ---- view and lights as the source states them --------------------------- */

/* pos: n xyz triples. */
static void check_lights(const mprt_scene *s, const double *pos, int n)
{
    int i;
    CHECK(s->nlights == n);
    for (i = 0; i < n && i < s->nlights; i++) {
        check_v3(s->lights[i].pos, pos[3 * i], pos[3 * i + 1], pos[3 * i + 2], "light");
        CHECK(s->lights[i].has_rgb == 0);
    }
}

static void test_views_and_lights(void)
{
    static const double balls_l[] = {4, 3, 2, 1, -4, 4, -3, 1, 5};
    static const double gears_l[] = {2, 4, 4, -2, 4, 3, 2, -2.5, 2.5, -1, -4, 2, -1.111, -2.121, 2.626};
    static const double mount_l[] = {-100, -100, 100};
    static const double tetra_l[] = {2, -18, -5};
    static const double tree_l[] = {-5, 5, 50, 30, -30, 30, -40, -30, 20, 10, 30, 40, -30, 40, 10, 50, 25, 20, -10, -60, 30};
    double spread = 1.0 / sin(PI / 8.0);
    double rings_l[] = {3, -spread, 3, -4, -spread, 1, 2, -spread, -4};
    /* What each scene's program states: view, hither, lights */
    const struct {
        double from[3], at[3], up[3], hither;
        const double *lights;
        int nlights;
    } view[NSCENES] = {
        {{2.1, 1.3, 1.7}, {0, 0, 0}, {0, 0, 1}, 0.01, balls_l, 3},
        {{-1.1, -2.1, 2.6}, {0, 0, 0}, {0, 0, 1}, 1, gears_l, 5},
        {{-1.6, 1.6, 1.7}, {0, 0, 0}, {0, 0, 1}, 0.01, mount_l, 1},
        {{-1, -spread, 0.5}, {-1, -spread + 1.0, 0.5}, {0, 0, 1}, 1, rings_l, 3},
        {{1.022846, -3.177154, -2.174512}, {-0.004103, -0.004103, 0.216539}, {-0.816497, -0.816497, 0.816497}, 1,
         tetra_l, 1},
        {{4.5, 0.4, 2}, {0, 0, 1.5}, {0, 0, 1}, 1, tree_l, 7},
    };
    int sf, w;
    for (sf = 1; sf <= 3; sf++)
        for (w = 0; w < NSCENES; w++) {
            mprt_scene *s = gen(names[w], sf);
            char what[64];
            if (!s) continue;
            CHECK(s->angle == 45.0 && s->width == 512 && s->height == 512);
            CHECK(fabs(s->background[0] - 0.078) < 1e-12 && fabs(s->background[1] - 0.361) < 1e-12 &&
                  fabs(s->background[2] - 0.753) < 1e-12);
            snprintf(what, sizeof what, "%s from", names[w]);
            check_v3(s->from, view[w].from[0], view[w].from[1], view[w].from[2], what);
            snprintf(what, sizeof what, "%s at", names[w]);
            check_v3(s->at, view[w].at[0], view[w].at[1], view[w].at[2], what);
            snprintf(what, sizeof what, "%s up", names[w]);
            check_v3(s->up, view[w].up[0], view[w].up[1], view[w].up[2], what);
            CHECK_MSG(fabs(s->hither - view[w].hither) < 1e-12, "%s hither %g", names[w], s->hither);
            check_lights(s, view[w].lights, view[w].nlights);
            mprt_scene_destroy(s);
        }
}

/* ---- size-dependent rules from the source --------------------------------- */

/* balls: sphere radii 0.5/3^k, 9^k of each; every child touches its parent. */
static void test_balls_rules(void)
{
    int sf;
    for (sf = 1; sf <= 3; sf++) {
        mprt_scene *s = gen("balls", sf);
        long long per[4] = {0, 0, 0, 0}, i;
        int k;
        if (!s) continue;
        for (i = 0; i < s->nspheres; i++) {
            double r = s->spheres[i].r;
            for (k = 0; k <= sf; k++)
                if (fabs(r - 0.5 / pow(3.0, k)) < NEAR) per[k]++;
        }
        for (k = 0; k <= sf; k++) CHECK_MSG(per[k] == ipow(9, k), "balls %d: %lld spheres of level %d", sf, per[k], k);
        /* first child of the root touches it and is a third its size */
        if (s->nspheres > 1) {
            vec3 d = vsub(s->spheres[1].c, s->spheres[0].c);
            CHECK(fabs(vlen(d) - (0.5 + 0.5 / 3.0)) < NEAR);
        }
        /* the floor is the first primitive: a 24 x 24 square at z = -0.5 */
        CHECK(s->prims[0].kind == MPRT_POLYGON && s->verts[0].z == -0.5 && s->verts[0].x == 12.0);
        mprt_scene_destroy(s);
    }
}

/* gears: each gear's top face at its layer height, the bottom one thickness
 * min(0.1, 1/(2 sf)) lower; gears with (4 ix + 2 iy + iz) % 5 == 0 are glass. */
static void test_gears_rules(void)
{
    int sf;
    for (sf = 1; sf <= 3; sf++) {
        mprt_scene *s = gen("gears", sf);
        double thick = fmin(0.1, 1.0 / (2.0 * sf));
        long long g, clear = 0, want_clear = 0;
        int ix, iy, iz;
        if (!s) continue;
        for (iz = 0; iz < sf; iz++)
            for (iy = 0; iy < sf; iy++)
                for (ix = 0; ix < sf; ix++) want_clear += (ix * 4 + iy * 2 + iz) % 5 == 0;
        for (g = 0; g < (long long)sf * sf * sf; g++) {
            long long top = 1 + g * 146, bottom = top + 145;
            const mprt__polygon *pt, *pb;
            double ztop = 1.0 - (double)(g / (sf * sf)) / sf;
            if (bottom >= s->nprims) break;
            pt = &s->polygons[s->prims[top].index];
            pb = &s->polygons[s->prims[bottom].index];
            CHECK(pt->n == 144 && pb->n == 144);
            CHECK(fabs(s->verts[pt->first].z - ztop) < NEAR);
            CHECK(fabs(s->verts[pb->first].z - (ztop - thick)) < NEAR);
            clear += s->materials[s->prims[top].material].t > 0;
        }
        CHECK_MSG(clear == want_clear, "gears %d: %lld transmissive gears, expected %lld", sf, clear, want_clear);
        mprt_scene_destroy(s);
    }
}

/* mount: spheres fixed; triangle corners on the 2^sf grid over [-1,1]^2, with
 * the four outer corners at height 0. */
static void test_mount_rules(void)
{
    int sf;
    for (sf = 1; sf <= 3; sf++) {
        mprt_scene *s = gen("mount", sf);
        double cell = 2.0 / (double)(1 << sf);
        long long i, corners = 0;
        if (!s) continue;
        check_v3(s->spheres[0].c, -0.8, 0.8, 1.0 + 0.17 * sqrt(1.5), "mount top sphere");
        for (i = 0; i < 4 && i < s->nspheres; i++) CHECK(s->spheres[i].r == R(0.17));
        for (i = 0; i < s->nverts; i++) {
            vec3 v = s->verts[i];
            double gx = (v.x + 1.0) / cell, gy = (v.y + 1.0) / cell;
            CHECK(fabs(gx - floor(gx + 0.5)) < 1e3 * NEAR && fabs(gy - floor(gy + 0.5)) < 1e3 * NEAR);
            if (fabs(v.x) == 1.0 && fabs(v.y) == 1.0) {
                corners++;
                CHECK(v.z == 0.0);
            }
        }
        CHECK(corners > 0);
        mprt_scene_destroy(s);
    }
}

/* rings: backdrop at y = spread (sf+1) sized to the view plus 1%; ring
 * colours cycle R G B C M Y; every cylinder and sphere has radius 0.07412. */
static void test_rings_rules(void)
{
    static const double cyc[6][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 1, 1}, {1, 0, 1}, {1, 1, 0}};
    double spread = 1.0 / sin(PI / 8.0);
    int sf;
    for (sf = 1; sf <= 3; sf++) {
        mprt_scene *s = gen("rings", sf);
        double y = spread * (sf + 1), half = 1.01 * (y + spread) * tan(PI / 8.0);
        long long i;
        if (!s) continue;
        CHECK(s->prims[0].kind == MPRT_POLYGON);
        check_v3(s->verts[0], half - 1.0, y, half + 0.5, "rings wall corner");
        for (i = 1; i < s->nmaterials; i++) {
            const double *c = cyc[(i - 1) % 6];
            const mprt__material *m = &s->materials[i];
            CHECK(m->rgb[0] == c[0] && m->rgb[1] == c[1] && m->rgb[2] == c[2]);
        }
        for (i = 0; i < s->ncones; i++) CHECK(s->cones[i].rb == R(0.07412) && s->cones[i].ra == R(0.07412));
        for (i = 0; i < s->nspheres; i++) CHECK(s->spheres[i].r == R(0.07412));
        mprt_scene_destroy(s);
    }
}

/* tetra: 4^(sf-1) tetrahedra of edge 2 sqrt(2) / 2^(sf-1). */
static void test_tetra_rules(void)
{
    int sf;
    for (sf = 1; sf <= 3; sf++) {
        mprt_scene *s = gen("tetra", sf);
        double edge = 2.0 * sqrt(2.0) / (double)(1 << (sf - 1));
        long long i;
        int k;
        if (!s) continue;
        for (i = 0; i < s->npolygons; i++) {
            const mprt__polygon *p = &s->polygons[i];
            for (k = 0; k < 3; k++) {
                vec3 d = vsub(s->verts[p->first + k], s->verts[p->first + (k + 1) % 3]);
                CHECK(fabs(vlen(d) - edge) < 1e3 * NEAR);
            }
        }
        mprt_scene_destroy(s);
    }
}

/* tree: trunk from the origin to (0,0,1), radii 0.15 * 0.67^k at depth k,
 * 2^k branches at depth k. */
static void test_tree_rules(void)
{
    static const int sizes[4] = {1, 2, 3, 8};
    int t;
    for (t = 0; t < 4; t++) {
        int sf = sizes[t], k;
        mprt_scene *s = gen("tree", sf);
        long long per[9], i;
        if (!s) continue;
        memset(per, 0, sizeof per);
        check_v3(s->cones[0].base, 0, 0, 0, "trunk base");
        check_v3(s->cones[0].apex, 0, 0, 1, "trunk apex");
        for (i = 0; i < s->ncones; i++) {
            const mprt__cone *c = &s->cones[i];
            CHECK(fabs(c->ra - c->rb * 0.67) < NEAR);
            for (k = 0; k <= sf; k++)
                if (fabs(c->rb - 0.15 * pow(0.67, k)) < NEAR * 0.15 * pow(0.67, k)) per[k]++;
        }
        for (k = 0; k <= sf; k++) CHECK_MSG(per[k] == ipow(2, k), "tree %d: %lld branches at depth %d", sf, per[k], k);
        /* each branch's sphere sits on its tip with the tip radius */
        for (i = 0; i + 2 < s->nprims; i += 2) {
            const mprt__prim *pc = &s->prims[i + 1], *ps = &s->prims[i + 2];
            CHECK(pc->kind == MPRT_CONE && ps->kind == MPRT_SPHERE);
            if (pc->kind != MPRT_CONE || ps->kind != MPRT_SPHERE) break;
            CHECK(vlen(vsub(s->cones[pc->index].apex, s->spheres[ps->index].c)) == 0 &&
                  s->cones[pc->index].ra == s->spheres[ps->index].r);
        }
        mprt_scene_destroy(s);
    }
}

/* ---- arguments ---------------------------------------------------------------- */

static void test_bad_name(void)
{
    mprt_scene *s = NULL;
    CHECK(mprt_scene_create(&s) == MPRT_OK);
    if (!s) return;
    CHECK(mprt_scene_spd(s, "teapot", 0) == MPRT_ERR_INVALID_ARG);
    CHECK_MSG(strstr(mprt_scene_errmsg(s), "teapot") && strstr(mprt_scene_errmsg(s), "unknown"), "message '%s'",
              mprt_scene_errmsg(s));
    CHECK(mprt_scene_spd(s, "Balls", 1) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_scene_spd(s, "", 1) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_scene_spd(s, NULL, 1) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_scene_spd(NULL, "balls", 1) == MPRT_ERR_INVALID_ARG);
    CHECK(s->nprims == 0 && s->nlights == 0);
    mprt_scene_destroy(s);
}

static void test_sizes_default_and_limits(void)
{
    int w;
    for (w = 0; w < NSCENES; w++) {
        mprt_scene *a = gen(names[w], 0), *b = gen(names[w], -3), *c = gen(names[w], default_size[w]);
        mprt_scene *s = NULL;
        char want[64];
        if (a && b && c) {
            CHECK_MSG(a->nprims == c->nprims && b->nprims == c->nprims && a->nmaterials == c->nmaterials,
                      "%s: size 0 gives %lld primitives, -3 gives %lld, default %d gives %lld", names[w], a->nprims,
                      b->nprims, default_size[w], c->nprims);
            CHECK(a->nprims > 0 && a->nverts == c->nverts && a->nspheres == c->nspheres);
        }
        mprt_scene_destroy(a);
        mprt_scene_destroy(b);
        mprt_scene_destroy(c);

        /* one above the maximum is refused with a message naming size and scene */
        CHECK(mprt_scene_create(&s) == MPRT_OK);
        if (!s) continue;
        CHECK(mprt_scene_spd(s, names[w], max_size[w] + 1) == MPRT_ERR_INVALID_ARG);
        snprintf(want, sizeof want, "size %d", max_size[w] + 1);
        CHECK_MSG(strstr(mprt_scene_errmsg(s), want) && strstr(mprt_scene_errmsg(s), names[w]) &&
                      strstr(mprt_scene_errmsg(s), "too large"),
                  "message '%s'", mprt_scene_errmsg(s));
        CHECK(mprt_scene_spd(s, names[w], 1 << 30) == MPRT_ERR_INVALID_ARG);
        CHECK(s->nprims == 0 && s->nlights == 0 && s->nmaterials == 0);
        mprt_scene_destroy(s);
    }
}

int main(void)
{
    RUN(test_views_and_lights);
    RUN(test_balls_rules);
    RUN(test_gears_rules);
    RUN(test_mount_rules);
    RUN(test_rings_rules);
    RUN(test_tetra_rules);
    RUN(test_tree_rules);
    RUN(test_bad_name);
    RUN(test_sizes_default_and_limits);
    return CHECK_DONE();
}
