/* test_spd.c: the SPD generators against the original programs' NFF output
 * (default sizes) and against counts and rules derived from their source
 * (sizes 1..3, tree 8).  Runs from tests/c; the references live in
 * ../data/spd-reference/. */
#include "check.h"
#include "mprt_internal.h"

#include <stdlib.h>
#include <string.h>

#define REF_DIR "../data/spd-reference/"
#define PI 3.141592653589793
/* Tolerance for values the source defines exactly (wider if built with MPRT_SINGLE). */
#define NEAR (REAL_EPS > 1e-10 ? 1e-5 : 1e-12)

static const char *const names[6] = {"balls", "gears", "mount", "rings", "tetra", "tree"};
static const int default_size[6] = {4, 4, 6, 7, 6, 11};
static const int max_size[6] = {8, 69, 12, 135, 12, 23};

/* ---- helpers -------------------------------------------------------------- */

/* Deviation of a from b: relative, with an absolute floor near zero.
 * The references are %g text (6 significant digits). */
static double dev(double a, double b)
{
    double d = fabs(a - b), m = fmax(fabs(a), fabs(b));
    if (d <= 1e-9) return 0.0;
    return d / m;
}

#define TOL 1e-5

static double worst; /* largest deviation seen in the current comparison */

#define CHECK_CLOSE(a, b, what, idx)                                                   \
    do {                                                                               \
        double a_ = (double)(a), b_ = (double)(b), d_ = dev(a_, b_);                   \
        if (d_ > worst) worst = d_;                                                    \
        CHECK_MSG(d_ <= TOL, "%s %lld: %.9g vs reference %.9g", what, (long long)(idx), \
                  a_, b_);                                                             \
    } while (0)

static void check_vec(vec3 a, vec3 b, const char *what, long long idx)
{
    CHECK_CLOSE(a.x, b.x, what, idx);
    CHECK_CLOSE(a.y, b.y, what, idx);
    CHECK_CLOSE(a.z, b.z, what, idx);
}

static mprt_scene *gen(const char *name, int size)
{
    mprt_scene *s = NULL;
    int st;
    CHECK(mprt_scene_create(&s) == MPRT_OK);
    if (!s) return NULL;
    st = mprt_scene_spd(s, name, size);
    CHECK_MSG(st == MPRT_OK, "spd %s %d: %s", name, size, mprt_scene_errmsg(s));
    if (st != MPRT_OK) {
        mprt_scene_destroy(s);
        return NULL;
    }
    return s;
}

static long long ipow(long long b, int e)
{
    long long r = 1;
    while (e-- > 0) r *= b;
    return r;
}

/* Exact double test for view and light constants (no rounding involved). */
static void check_v3(vec3 v, double x, double y, double z, const char *what)
{
    CHECK_MSG(fabs(v.x - x) <= NEAR && fabs(v.y - y) <= NEAR && fabs(v.z - z) <= NEAR,
              "%s is (%.17g %.17g %.17g), expected (%.17g %.17g %.17g)", what, (double)v.x,
              (double)v.y, (double)v.z, x, y, z);
}

/* ---- comparison with the reference NFF files ------------------------------ */

static void compare_with_reference(int which)
{
    const char *name = names[which];
    char path[256];
    mprt_scene *ref = NULL, *s;
    long long i;
    int st;

    snprintf(path, sizeof path, REF_DIR "%s.nff", name);
    CHECK(mprt_scene_create(&ref) == MPRT_OK);
    if (!ref) return;
    st = mprt_scene_load_nff(ref, path);
    CHECK_MSG(st == MPRT_OK, "loading %s: %s", path, mprt_scene_errmsg(ref));
    s = gen(name, 0);
    if (st != MPRT_OK || !s) {
        mprt_scene_destroy(ref);
        mprt_scene_destroy(s);
        return;
    }
    worst = 0.0;

    /* Same entity counts */
    CHECK_MSG(s->nprims == ref->nprims, "%s: %lld primitives, reference %lld", name, s->nprims, ref->nprims);
    CHECK_MSG(s->nspheres == ref->nspheres, "%s: %lld spheres, reference %lld", name, s->nspheres, ref->nspheres);
    CHECK_MSG(s->npolygons == ref->npolygons, "%s: %lld polygons, reference %lld", name, s->npolygons,
              ref->npolygons);
    CHECK_MSG(s->ncones == ref->ncones, "%s: %lld cones, reference %lld", name, s->ncones, ref->ncones);
    CHECK_MSG(s->ncylinders == ref->ncylinders, "%s: %lld cylinders, reference %lld", name, s->ncylinders,
              ref->ncylinders);
    CHECK_MSG(s->nverts == ref->nverts, "%s: %lld vertices, reference %lld", name, s->nverts, ref->nverts);
    CHECK_MSG(s->nlights == ref->nlights, "%s: %lld lights, reference %lld", name, s->nlights, ref->nlights);
    CHECK_MSG(s->nmaterials == ref->nmaterials, "%s: %lld materials, reference %lld", name, s->nmaterials,
              ref->nmaterials);
    CHECK(s->dropped == 0);

    /* View and background */
    check_vec(s->from, ref->from, "from", 0);
    check_vec(s->at, ref->at, "at", 0);
    check_vec(s->up, ref->up, "up", 0);
    CHECK_CLOSE(s->angle, ref->angle, "angle", 0);
    CHECK_CLOSE(s->hither, ref->hither, "hither", 0);
    CHECK(s->width == ref->width && s->height == ref->height);
    for (i = 0; i < 3; i++) CHECK_CLOSE(s->background[i], ref->background[i], "background", i);

    /* Lights, in order, without colour */
    for (i = 0; i < s->nlights && i < ref->nlights; i++) {
        check_vec(s->lights[i].pos, ref->lights[i].pos, "light", i);
        CHECK(s->lights[i].has_rgb == 0 && ref->lights[i].has_rgb == 0);
    }

    /* Every primitive: kind, material, geometry */
    for (i = 0; i < s->nprims && i < ref->nprims; i++) {
        const mprt__prim *p = &s->prims[i], *q = &ref->prims[i];
        const mprt__material *m = &s->materials[p->material], *n = &ref->materials[q->material];
        int k;
        CHECK_MSG(p->kind == q->kind, "%s primitive %lld: kind %d, reference %d", name, i, p->kind, q->kind);
        if (p->kind != q->kind) break;
        CHECK_MSG(p->material == q->material, "%s primitive %lld: material %d, reference %d", name, i,
                  p->material, q->material);
        for (k = 0; k < 3; k++) CHECK_CLOSE(m->rgb[k], n->rgb[k], "material rgb of primitive", i);
        CHECK_CLOSE(m->kd, n->kd, "Kd of primitive", i);
        CHECK_CLOSE(m->ks, n->ks, "Ks of primitive", i);
        CHECK_CLOSE(m->shine, n->shine, "Shine of primitive", i);
        CHECK_CLOSE(m->t, n->t, "T of primitive", i);
        CHECK_CLOSE(m->ior, n->ior, "ior of primitive", i);
        if (p->kind == MPRT_SPHERE) {
            const mprt__sphere *a = &s->spheres[p->index], *b = &ref->spheres[q->index];
            check_vec(a->c, b->c, "sphere centre of primitive", i);
            CHECK_CLOSE(a->r, b->r, "sphere radius of primitive", i);
        } else if (p->kind == MPRT_POLYGON) {
            const mprt__polygon *a = &s->polygons[p->index], *b = &ref->polygons[q->index];
            CHECK_MSG(a->n == b->n, "%s primitive %lld: %d vertices, reference %d", name, i, a->n, b->n);
            CHECK(a->has_normals == 0 && b->has_normals == 0);
            for (k = 0; k < a->n && k < b->n; k++)
                check_vec(s->verts[a->first + k], ref->verts[b->first + k], "polygon vertex of primitive", i);
        } else {
            const mprt__cone *a = &s->cones[p->index], *b = &ref->cones[q->index];
            check_vec(a->base, b->base, "cone base of primitive", i);
            check_vec(a->apex, b->apex, "cone apex of primitive", i);
            CHECK_CLOSE(a->rb, b->rb, "cone base radius of primitive", i);
            CHECK_CLOSE(a->ra, b->ra, "cone apex radius of primitive", i);
        }
        if (check_failures_ > 50) break; /* one broken rule would flood the log */
    }
    printf("%s: %lld primitives match the reference, max relative deviation %.3g\n", name, s->nprims,
           worst);
    mprt_scene_destroy(ref);
    mprt_scene_destroy(s);
}

static void test_balls_matches_reference(void) { compare_with_reference(0); }
static void test_gears_matches_reference(void) { compare_with_reference(1); }
static void test_mount_matches_reference(void) { compare_with_reference(2); }
static void test_rings_matches_reference(void) { compare_with_reference(3); }
static void test_tetra_matches_reference(void) { compare_with_reference(4); }
static void test_tree_matches_reference(void) { compare_with_reference(5); }

/* ---- closed-form counts for other sizes ---------------------------------- */

typedef struct {
    long long spheres, polygons, vertices, cylinders, cones, lights, materials;
} counts;

/* Counts the SPD source implies for a scene at size factor sf. */
static counts expected_counts(int which, int sf)
{
    counts c;
    long long n3 = (long long)sf * sf * sf, k, sq = (long long)sf * (sf + 1) * (2 * sf + 1) / 6;
    memset(&c, 0, sizeof c);
    switch (which) {
    case 0: /* balls: sum_{k=0}^{sf} 9^k spheres, floor square */
        for (k = 0; k <= sf; k++) c.spheres += ipow(9, (int)k);
        c.polygons = 1; c.vertices = 4; c.lights = 3; c.materials = 2;
        break;
    case 1: /* gears: sf^3 gears of 2 faces (144-gons) + 144 side quads, ground */
        c.polygons = 1 + n3 * (2 + 144);
        c.vertices = 4 + n3 * (2 * 144 + 144 * 4);
        c.lights = 5; c.materials = 1 + n3;
        break;
    case 2: /* mount: 2*4^sf triangles, 4 spheres */
        c.spheres = 4; c.polygons = 2 * ipow(4, sf); c.vertices = 3 * c.polygons;
        c.lights = 1; c.materials = 2;
        break;
    case 3: /* rings: sum_{k=1}^{sf} k^2 objects of 30 cylinders + 30 spheres, 6 surfaces */
        c.spheres = c.cylinders = 30 * sq; c.polygons = 1; c.vertices = 4;
        c.lights = 3; c.materials = 1 + 6 * sq;
        break;
    case 4: /* tetra: 4^sf triangles */
        c.polygons = ipow(4, sf); c.vertices = 3 * c.polygons; c.lights = 1; c.materials = 1;
        break;
    default: /* tree: 2^(sf+1)-1 branches, each a cone and a sphere, field square */
        c.spheres = c.cones = ipow(2, sf + 1) - 1; c.polygons = 1; c.vertices = 4;
        c.lights = 7; c.materials = 2;
        break;
    }
    return c;
}

static void check_counts(int which, int sf)
{
    counts e = expected_counts(which, sf);
    mprt_scene *s = gen(names[which], sf);
    if (!s) return;
    CHECK_MSG(s->nspheres == e.spheres, "%s %d: %lld spheres, expected %lld", names[which], sf, s->nspheres, e.spheres);
    CHECK_MSG(s->npolygons == e.polygons, "%s %d: %lld polygons, expected %lld", names[which], sf, s->npolygons,
              e.polygons);
    CHECK_MSG(s->nverts == e.vertices, "%s %d: %lld vertices, expected %lld", names[which], sf, s->nverts, e.vertices);
    CHECK_MSG(s->ncylinders == e.cylinders, "%s %d: %lld cylinders, expected %lld", names[which], sf, s->ncylinders,
              e.cylinders);
    CHECK_MSG(s->ncones - s->ncylinders == e.cones, "%s %d: %lld cones, expected %lld", names[which], sf,
              s->ncones - s->ncylinders, e.cones);
    CHECK_MSG(s->nlights == e.lights, "%s %d: %lld lights, expected %lld", names[which], sf, s->nlights, e.lights);
    CHECK_MSG(s->nmaterials == e.materials, "%s %d: %lld materials, expected %lld", names[which], sf, s->nmaterials,
              e.materials);
    CHECK(s->nprims == e.spheres + e.polygons + e.cylinders + e.cones);
    CHECK(s->npatches == 0 && s->dropped == 0);
    mprt_scene_destroy(s);
}

static void test_counts_sizes_1_to_3(void)
{
    int w, sf;
    for (w = 0; w < 6; w++)
        for (sf = 1; sf <= 3; sf++) check_counts(w, sf);
    check_counts(5, 8);
}

static void test_default_counts(void)
{
    /* The README's table for the default sizes */
    static const long long prims[6] = {7382, 9345, 8196, 8401, 4096, 8191};
    int w;
    for (w = 0; w < 6; w++) {
        counts e = expected_counts(w, default_size[w]);
        CHECK(e.spheres + e.polygons + e.cylinders + e.cones == prims[w]);
        check_counts(w, default_size[w]);
    }
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
    static const double balls_l[3][3] = {{4, 3, 2}, {1, -4, 4}, {-3, 1, 5}};
    static const double gears_l[5][3] = {{2, 4, 4}, {-2, 4, 3}, {2, -2.5, 2.5}, {-1, -4, 2}, {-1.111, -2.121, 2.626}};
    static const double mount_l[1][3] = {{-100, -100, 100}};
    static const double tetra_l[1][3] = {{2, -18, -5}};
    static const double tree_l[7][3] = {{-5, 5, 50}, {30, -30, 30}, {-40, -30, 20}, {10, 30, 40},
                                        {-30, 40, 10}, {50, 25, 20}, {-10, -60, 30}};
    double spread = 1.0 / sin(PI / 8.0), rings_l[3][3];
    int sf;
    rings_l[0][0] = 3; rings_l[0][1] = -spread; rings_l[0][2] = 3;
    rings_l[1][0] = -4; rings_l[1][1] = -spread; rings_l[1][2] = 1;
    rings_l[2][0] = 2; rings_l[2][1] = -spread; rings_l[2][2] = -4;

    for (sf = 1; sf <= 3; sf++) {
        mprt_scene *s;
        int w;
        for (w = 0; w < 6; w++) {
            s = gen(names[w], sf);
            if (!s) continue;
            CHECK(s->angle == 45.0 && s->width == 512 && s->height == 512);
            CHECK(fabs(s->background[0] - 0.078) < 1e-12 && fabs(s->background[1] - 0.361) < 1e-12 &&
                  fabs(s->background[2] - 0.753) < 1e-12);
            switch (w) {
            case 0:
                check_v3(s->from, 2.1, 1.3, 1.7, "balls from");
                check_v3(s->at, 0, 0, 0, "balls at");
                check_v3(s->up, 0, 0, 1, "balls up");
                CHECK(fabs(s->hither - 0.01) < 1e-12);
                check_lights(s, &balls_l[0][0], 3);
                break;
            case 1:
                check_v3(s->from, -1.1, -2.1, 2.6, "gears from");
                check_v3(s->at, 0, 0, 0, "gears at");
                check_v3(s->up, 0, 0, 1, "gears up");
                CHECK(s->hither == 1.0);
                check_lights(s, &gears_l[0][0], 5);
                break;
            case 2:
                check_v3(s->from, -1.6, 1.6, 1.7, "mount from");
                check_v3(s->at, 0, 0, 0, "mount at");
                check_v3(s->up, 0, 0, 1, "mount up");
                CHECK(fabs(s->hither - 0.01) < 1e-12);
                check_lights(s, &mount_l[0][0], 1);
                break;
            case 3:
                check_v3(s->from, -1, -spread, 0.5, "rings from");
                check_v3(s->at, -1, -spread + 1.0, 0.5, "rings at");
                check_v3(s->up, 0, 0, 1, "rings up");
                CHECK(s->hither == 1.0);
                check_lights(s, &rings_l[0][0], 3);
                break;
            case 4:
                check_v3(s->from, 1.022846, -3.177154, -2.174512, "tetra from");
                check_v3(s->at, -0.004103, -0.004103, 0.216539, "tetra at");
                check_v3(s->up, -0.816497, -0.816497, 0.816497, "tetra up");
                CHECK(s->hither == 1.0);
                check_lights(s, &tetra_l[0][0], 1);
                break;
            default:
                check_v3(s->from, 4.5, 0.4, 2, "tree from");
                check_v3(s->at, 0, 0, 1.5, "tree at");
                check_v3(s->up, 0, 0, 1, "tree up");
                CHECK(s->hither == 1.0);
                check_lights(s, &tree_l[0][0], 7);
                break;
            }
            mprt_scene_destroy(s);
        }
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
    for (w = 0; w < 6; w++) {
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

/* The maxima keep the primitive count under 50 million and allow one more
 * size than the one before it would exceed it. */
static void test_max_sizes_bound_primitives(void)
{
    int w;
    for (w = 0; w < 6; w++) {
        counts at = expected_counts(w, max_size[w]), above = expected_counts(w, max_size[w] + 1);
        long long n = at.spheres + at.polygons + at.cylinders + at.cones;
        long long m = above.spheres + above.polygons + above.cylinders + above.cones;
        CHECK_MSG(n < 50000000LL && m >= 50000000LL, "%s: %lld at the maximum, %lld above", names[w], n, m);
    }
}

int main(void)
{
    RUN(test_balls_matches_reference);
    RUN(test_gears_matches_reference);
    RUN(test_mount_matches_reference);
    RUN(test_rings_matches_reference);
    RUN(test_tetra_matches_reference);
    RUN(test_tree_matches_reference);
    RUN(test_counts_sizes_1_to_3);
    RUN(test_default_counts);
    RUN(test_views_and_lights);
    RUN(test_balls_rules);
    RUN(test_gears_rules);
    RUN(test_mount_rules);
    RUN(test_rings_rules);
    RUN(test_tetra_rules);
    RUN(test_tree_rules);
    RUN(test_bad_name);
    RUN(test_sizes_default_and_limits);
    RUN(test_max_sizes_bound_primitives);
    return CHECK_DONE();
}
