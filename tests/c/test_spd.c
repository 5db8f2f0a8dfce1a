/* test_spd.c: the SPD generators against the original programs' NFF output
 * (default sizes) and against primitive counts derived from their source
 * (sizes 1..3).  Runs from tests/c; the references live in
 * ../data/spd-reference/. */
#include "spd_check.h"

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

static void test_balls_matches_reference(void) { compare_with_reference(BALLS); }
static void test_gears_matches_reference(void) { compare_with_reference(GEARS); }
static void test_mount_matches_reference(void) { compare_with_reference(MOUNT); }
static void test_rings_matches_reference(void) { compare_with_reference(RINGS); }
static void test_tetra_matches_reference(void) { compare_with_reference(TETRA); }
static void test_tree_matches_reference(void) { compare_with_reference(TREE); }

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
    case BALLS: /* balls: sum_{k=0}^{sf} 9^k spheres, floor square */
        for (k = 0; k <= sf; k++) c.spheres += ipow(9, (int)k);
        c.polygons = 1; c.vertices = 4; c.lights = 3; c.materials = 2;
        break;
    case GEARS: /* gears: sf^3 gears of 2 faces (144-gons) + 144 side quads, ground */
        c.polygons = 1 + n3 * (2 + 144);
        c.vertices = 4 + n3 * (2 * 144 + 144 * 4);
        c.lights = 5; c.materials = 1 + n3;
        break;
    case MOUNT: /* mount: 2*4^sf triangles, 4 spheres */
        c.spheres = 4; c.polygons = 2 * ipow(4, sf); c.vertices = 3 * c.polygons;
        c.lights = 1; c.materials = 2;
        break;
    case RINGS: /* rings: sum_{k=1}^{sf} k^2 objects of 30 cylinders + 30 spheres, 6 surfaces */
        c.spheres = c.cylinders = 30 * sq; c.polygons = 1; c.vertices = 4;
        c.lights = 3; c.materials = 1 + 6 * sq;
        break;
    case TETRA: /* tetra: 4^sf triangles */
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
    for (w = 0; w < NSCENES; w++)
        for (sf = 1; sf <= 3; sf++) check_counts(w, sf);
    check_counts(5, 8);
}

static void test_default_counts(void)
{
    /* The README's table for the default sizes */
    static const long long prims[NSCENES] = {7382, 9345, 8196, 8401, 4096, 8191};
    int w;
    for (w = 0; w < NSCENES; w++) {
        counts e = expected_counts(w, default_size[w]);
        CHECK(e.spheres + e.polygons + e.cylinders + e.cones == prims[w]);
        check_counts(w, default_size[w]);
    }
}

/* The maxima keep the primitive count under 50 million and allow one more
 * size than the one before it would exceed it. */
static void test_max_sizes_bound_primitives(void)
{
    int w;
    for (w = 0; w < NSCENES; w++) {
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
    RUN(test_max_sizes_bound_primitives);
    return CHECK_DONE();
}
