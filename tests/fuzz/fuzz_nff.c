/* fuzz_nff.c: the fuzz target over the library's whole path from scene text
 * to pixels: NFF parse -> write -> parse again -> two grids -> tiny renders
 * under every rule set and a traced tile -> batch intersection.
 *
 * Besides crashes, hangs and sanitizer reports, it aborts when
 *   - a failed parse changes the scene it was parsing into;
 *   - the text the writer makes does not read back to the same scene (every
 *     table equal, bit for bit), or writing it again gives other text;
 *   - a render differs between 1 and 2 threads, or between two grids (the
 *     image and every count that does not describe the grid);
 *   - a traced tile's counts differ from the render's, or a reflection or
 *     refraction ray carries more than the ray that made it;
 *   - the grid's nearest hit of a ray differs from the nearest over every
 *     primitive tested one by one.
 *
 * Built two ways: with clang and libFuzzer (make fuzz), and with gcc and the
 * sanitizers as a replay of tests/fuzz/corpus and tests/fuzz/crashes in the
 * normal test suite (tests/fuzz/replay.c, make fuzz-replay). */
#include "mprt_internal.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* A broken property: say which and stop, so the fuzzer keeps the input. */
#define FAIL(...)                                                                                  \
    do {                                                                                           \
        fprintf(stderr, "fuzz_nff: ");                                                             \
        fprintf(stderr, __VA_ARGS__);                                                              \
        fputc('\n', stderr);                                                                       \
        abort();                                                                                   \
    } while (0)

enum {
    WIDTH = 4,            /* paper rules: 4x4 pixel centres; spd: 3x3 pixels, 4x4 corners */
    MAX_RAYS = 256,       /* ray budget of a sample: keeps every input fast */
    NQUERY = 24,          /* rays of the intersection check */
    GRID_BYTES = 64 << 20 /* memory bound of a grid */
};

/* The scene's NFF text, malloc'd (NULL only when the writer fails). */
static char *write_nff(const mprt_scene *s)
{
    size_t need = 0, again = 0;
    char *text;
    if (mprt_scene_write_nff(s, NULL, 0, &need) != MPRT_ERR_CAPACITY) FAIL("writer: no size for an empty buffer");
    text = malloc(need);
    if (!text) abort();
    if (mprt_scene_write_nff(s, text, need, &again) != MPRT_OK || again != need)
        FAIL("writer: %zu bytes needed, then %zu", need, again);
    return text;
}

static int same_bits(const void *a, const void *b, size_t n) { return n == 0 || memcmp(a, b, n) == 0; }

/* Every table of the two scenes holds the same bits (the used entries). */
static void check_same_scene(const mprt_scene *a, const mprt_scene *b)
{
    long long i;
    if (a->nprims != b->nprims || a->nspheres != b->nspheres || a->npolygons != b->npolygons ||
        a->ncones != b->ncones || a->ncylinders != b->ncylinders || a->nverts != b->nverts ||
        a->npatches != b->npatches || a->nmaterials != b->nmaterials || a->nlights != b->nlights ||
        a->material != b->material)
        FAIL("round trip: counts differ (prims %lld/%lld, vertices %lld/%lld, materials %lld/%lld)", a->nprims,
             b->nprims, a->nverts, b->nverts, a->nmaterials, b->nmaterials);
    if (!same_bits(&a->from, &b->from, sizeof a->from) || !same_bits(&a->at, &b->at, sizeof a->at) ||
        !same_bits(&a->up, &b->up, sizeof a->up) || !same_bits(&a->angle, &b->angle, sizeof a->angle) ||
        !same_bits(&a->hither, &b->hither, sizeof a->hither) || a->width != b->width || a->height != b->height ||
        !same_bits(a->background, b->background, sizeof a->background))
        FAIL("round trip: view or background differs");
    if (!same_bits(a->prims, b->prims, (size_t)a->nprims * sizeof *a->prims)) FAIL("round trip: primitive table");
    if (!same_bits(a->spheres, b->spheres, (size_t)a->nspheres * sizeof *a->spheres)) FAIL("round trip: spheres");
    if (!same_bits(a->cones, b->cones, (size_t)a->ncones * sizeof *a->cones)) FAIL("round trip: cones");
    if (!same_bits(a->verts, b->verts, (size_t)a->nverts * sizeof *a->verts)) FAIL("round trip: vertices");
    for (i = 0; i < a->npolygons; i++) {
        const mprt__polygon *p = &a->polygons[i], *q = &b->polygons[i];
        if (p->first != q->first || p->n != q->n || p->has_normals != q->has_normals ||
            !same_bits(&p->normal, &q->normal, sizeof p->normal) || !same_bits(&p->d, &q->d, sizeof p->d))
            FAIL("round trip: polygon %lld", i);
        if (p->has_normals &&
            !same_bits(a->vnormals + p->first, b->vnormals + q->first, (size_t)p->n * sizeof *a->vnormals))
            FAIL("round trip: normals of polygon patch %lld", i);
    }
    for (i = 0; i < a->nmaterials; i++)
        if (!same_bits(&a->materials[i], &b->materials[i], sizeof a->materials[i])) FAIL("round trip: material %lld", i);
    for (i = 0; i < a->nlights; i++) {
        const mprt__light *p = &a->lights[i], *q = &b->lights[i];
        if (!same_bits(&p->pos, &q->pos, sizeof p->pos) || p->has_rgb != q->has_rgb ||
            (p->has_rgb && !same_bits(p->rgb, q->rgb, sizeof p->rgb)))
            FAIL("round trip: light %lld", i);
    }
}

/* A parse that fails must leave the scene as it was: its text, its counts
 * its warning and its notes. */
static void check_failed_parse_changes_nothing(const uint8_t *data, size_t size)
{
    static const char base[] = "v\nfrom 0 -5 1\nat 0 0 0\nup 0 0 1\nangle 30\nhither 0.5\nresolution 8 6\n"
                               "b 0.1 0.2 0.3\nl 1 -4 4\nf 1 0.5 0.25 0.6 0.2 10 0.3 1.2\ns 0 0 0 1\n"
                               "p 3\n0 0 0\n1 0 0\n2 0 0\n";
    mprt_scene *s;
    char *before, *after, warning[MPRT__ERRMSG], notes[2 * MPRT__ERRMSG];
    long long dropped;
    int material;
    if (mprt_scene_create(&s) != MPRT_OK) abort();
    if (mprt_scene_parse_nff(s, base, sizeof base - 1, "base.nff") != MPRT_OK) FAIL("base scene: %s", s->errmsg);
    before = write_nff(s);
    dropped = s->dropped;
    material = s->material;
    memcpy(warning, s->warning, sizeof warning);
    memcpy(notes, s->notes, sizeof notes);
    if (mprt_scene_parse_nff(s, (const char *)data, size, "fuzz.nff") != MPRT_OK) {
        after = write_nff(s);
        if (strcmp(before, after) != 0 || s->dropped != dropped || s->material != material ||
            strcmp(warning, s->warning) != 0 || strcmp(notes, s->notes) != 0)
            FAIL("a failed parse changed the scene (%s)", s->errmsg);
        free(after);
    }
    free(before);
    mprt_scene_destroy(s);
}

/* Render desc of the checks: rules, WIDTH x WIDTH (spd: one less), threads. */
static mprt_render_desc check_desc(int rules, int threads)
{
    mprt_render_desc d;
    mprt_render_desc_init(&d);
    d.rules = rules;
    d.width = d.height = rules == MPRT_RULES_SPD ? WIDTH - 1 : WIDTH;
    d.threads = threads;
    d.tile = 2;
    d.max_rays = MAX_RAYS;
    return d;
}

/* The counts that do not describe the grid. */
static int same_ray_counts(const mprt_counters *a, const mprt_counters *b)
{
    return a->eye_rays == b->eye_rays && a->eye_hits == b->eye_hits && a->reflect_rays == b->reflect_rays &&
           a->refract_rays == b->refract_rays && a->shadow_rays == b->shadow_rays &&
           a->suppressed_rays == b->suppressed_rays && a->hits == b->hits && a->sc_visits == b->sc_visits &&
           a->tir == b->tir;
}

/* A traced tile: its counts are the render's, and no hit's secondary rays
 * outweigh it. */
static void check_trace(mprt_grid *g, int rules, const mprt_counters *rendered)
{
    mprt_render_desc d = check_desc(rules, 1);
    size_t cap_rays = 4096, cap_visits = 1 << 16, nr = 0, nv = 0, i;
    mprt_trace_ray *rays = NULL;
    mprt_trace_visit *visits = NULL;
    double samples[WIDTH * WIDTH * 3];
    mprt_counters c;
    int st;
    d.tile = WIDTH; /* one tile: the whole image */
    for (;;) {
        rays = realloc(rays, cap_rays * sizeof *rays);
        visits = realloc(visits, cap_visits * sizeof *visits);
        if (!rays || !visits) abort();
        st = mprt_grid_trace_tile(g, &d, 0, samples, WIDTH * WIDTH * 3, rays, cap_rays, &nr, visits, cap_visits, &nv,
                                  &c);
        if (st != MPRT_ERR_CAPACITY) break;
        cap_rays = nr > cap_rays ? nr : cap_rays;
        cap_visits = nv > cap_visits ? nv : cap_visits;
    }
    if (st != MPRT_OK) FAIL("trace: %s (the render succeeded)", mprt_grid_errmsg(g));
    if (!same_ray_counts(&c, rendered) || c.voxels_traversed != rendered->voxels_traversed)
        FAIL("trace: counts differ from the render's");
    /* Each reflection or refraction ray carries no more than its parent (Ks
     * and T are fractions; their sum may exceed 1, so the sum of the two may
     * exceed the parent's weight, but no path grows) */
    for (i = 0; i < nr; i++)
        if ((rays[i].kind == MPRT_RAY_REFLECT || rays[i].kind == MPRT_RAY_REFRACT) && rays[i].parent >= 0 &&
            rays[i].contribution > rays[rays[i].parent].contribution * (1 + 1e-12))
            FAIL("trace: ray %zu carries %.17g, more than its parent's %.17g", i, rays[i].contribution,
                 rays[rays[i].parent].contribution);
    free(rays);
    free(visits);
}

/* Renders under one rule set: 1 and 2 threads agree bit for bit, and so do
 * the two grids (image and ray counts). */
static void check_renders(mprt_grid *a, mprt_grid *b, int rules)
{
    float img[3][WIDTH * WIDTH * 3];
    mprt_counters c[3];
    mprt_render_desc d1 = check_desc(rules, 1), d2 = check_desc(rules, 2);
    size_t n = (size_t)d1.width * (size_t)d1.height * 3;
    int st[3];
    st[0] = mprt_grid_render(a, &d1, img[0], n, &c[0]);
    st[1] = mprt_grid_render(a, &d2, img[1], n, &c[1]);
    st[2] = mprt_grid_render(b, &d1, img[2], n, &c[2]);
    if (st[0] != MPRT_OK && st[0] != MPRT_ERR_LIMIT) FAIL("render: %s", mprt_grid_errmsg(a));
    if (st[1] != st[0] || st[2] != st[0])
        FAIL("render (rules %d): status %d with 1 thread, %d with 2, %d on the other grid", rules, st[0], st[1], st[2]);
    if (st[0] != MPRT_OK) return;
    if (!same_bits(img[0], img[1], n * sizeof(float)) || !same_bits(&c[0], &c[1], sizeof c[0]))
        FAIL("render (rules %d): 1 and 2 threads differ", rules);
    if (!same_bits(img[0], img[2], n * sizeof(float)) || !same_ray_counts(&c[0], &c[2]))
        FAIL("render (rules %d): the two grids give different images or ray counts", rules);
    check_trace(a, rules, &c[0]);
}

/* Nearest hit over every primitive, tested one by one (ties: lower id). */
static void brute_hit(const mprt_scene *s, const mprt__ray *ray, real *t, int32_t *prim)
{
    long long i;
    *t = (real)INFINITY;
    *prim = -1;
    for (i = 0; i < s->nprims; i++) {
        const mprt__prim *p = &s->prims[i];
        real ti;
        int hit = 0;
        switch (p->kind) {
        case MPRT_SPHERE: hit = mprt__sphere_hit(&s->spheres[p->index], ray, 0, *t, &ti); break;
        case MPRT_POLYGON: hit = mprt__polygon_hit(&s->polygons[p->index], s->verts, ray, 0, *t, &ti); break;
        case MPRT_CYLINDER: hit = mprt__cylinder_hit(&s->cones[p->index], ray, 0, *t, &ti); break;
        default: hit = mprt__cone_hit(&s->cones[p->index], ray, 0, *t, &ti); break;
        }
        /* the grid's rule: nearer, or as near with a lower id (so a "hit" at
         * t = inf is none) */
        if (hit && (ti < *t || (ti == *t && (int32_t)i < *prim))) {
            *t = ti;
            *prim = (int32_t)i;
        }
    }
}

/* Rays from the eye through the view and from the box's centre toward
 * primitives: the grid's nearest hits are the brute-force ones. */
static void check_intersect(mprt_grid *g, const mprt_scene *s)
{
    double org[NQUERY * 3], dir[NQUERY * 3], t[NQUERY];
    int32_t prim[NQUERY];
    mprt_render_desc d = check_desc(MPRT_RULES_PAPER, 1);
    vec3 lo, hi, c;
    long long bad = -1;
    size_t n = WIDTH * WIDTH, i;
    if (mprt_grid_camera_rays(g, &d, 0, n, org, dir) != MPRT_OK) FAIL("camera rays: %s", mprt_grid_errmsg(g));
    if (mprt__scene_bounds(s, &lo, &hi, &bad) != MPRT_OK) FAIL("bounds: primitive %lld", bad);
    c = vscale(vadd(lo, hi), R(0.5));
    for (i = 0; n < NQUERY && (long long)i < s->nprims; i++, n++) {
        vec3 plo, phi, to;
        mprt__prim_bounds(s, (long long)i, &plo, &phi);
        to = vsub(vscale(vadd(plo, phi), R(0.5)), c);
        if (vdot(to, to) == 0) to = v3(R(0.3), R(-0.5), R(0.8));
        org[3 * n] = (double)c.x, org[3 * n + 1] = (double)c.y, org[3 * n + 2] = (double)c.z;
        dir[3 * n] = (double)to.x, dir[3 * n + 1] = (double)to.y, dir[3 * n + 2] = (double)to.z;
    }
    if (mprt_grid_intersect(g, n, org, dir, t, prim, NULL) != MPRT_OK) FAIL("intersect: %s", mprt_grid_errmsg(g));
    for (i = 0; i < n; i++) {
        mprt__ray ray;
        real bt;
        int32_t bp;
        mprt__ray_prepare(&ray, v3((real)org[3 * i], (real)org[3 * i + 1], (real)org[3 * i + 2]),
                          v3((real)dir[3 * i], (real)dir[3 * i + 1], (real)dir[3 * i + 2]));
        brute_hit(s, &ray, &bt, &bp);
        if (bp != prim[i] || (bp >= 0 && (double)bt != t[i]))
            FAIL("intersect: ray %zu hits primitive %d at %.17g in the grid, %d at %.17g tested one by one", i,
                 prim[i], t[i], bp, (double)bt);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    mprt_scene *s, *again;
    mprt_grid *a = NULL, *b = NULL;
    char *text, *text2;
    int st;
    check_failed_parse_changes_nothing(data, size);
    if (mprt_scene_create(&s) != MPRT_OK) abort();
    if (mprt_scene_parse_nff(s, (const char *)data, size, "fuzz.nff") != MPRT_OK) {
        if (s->nprims || s->nlights || s->nmaterials || s->dropped || s->notes[0])
            FAIL("a failed parse left entities behind");
        /* the same text with unknown entities skipped (and noted) */
        if (mprt_scene_parse_nff_ex(s, (const char *)data, size, "fuzz.nff", MPRT_NFF_SKIP_UNKNOWN) != MPRT_OK) {
            if (s->nprims || s->nlights || s->nmaterials || s->dropped || s->notes[0])
                FAIL("a failed parse left entities behind");
            mprt_scene_destroy(s);
            return 0;
        }
    }
    /* Written text reads back to the same scene, and writes the same again */
    text = write_nff(s);
    if (mprt_scene_create(&again) != MPRT_OK) abort();
    if (mprt_scene_parse_nff(again, text, strlen(text), "written.nff") != MPRT_OK)
        FAIL("the written text does not read back: %s", again->errmsg);
    check_same_scene(s, again);
    text2 = write_nff(again);
    if (strcmp(text, text2) != 0) FAIL("writing the scene read back gives other text");
    free(text);
    free(text2);
    mprt_scene_destroy(again);

    /* Two grids of different shapes */
    st = mprt_grid_create(s, 2, 3, 4, GRID_BYTES, &a);
    if (st == MPRT_OK) st = mprt_grid_create(s, 5, 5, 5, GRID_BYTES, &b);
    if (st == MPRT_OK) {
        check_renders(a, b, MPRT_RULES_PAPER);
        check_renders(a, b, MPRT_RULES_SPD);
        check_renders(a, b, MPRT_RULES_PAPER1992);
        check_intersect(a, s);
    } else if (s->nprims > 0 && st != MPRT_ERR_OUT_OF_MEMORY) {
        FAIL("grid: %s", mprt_grid_errmsg(a && *mprt_grid_errmsg(a) ? a : b));
    }
    mprt_grid_destroy(a);
    mprt_grid_destroy(b);
    mprt_scene_destroy(s);
    return 0;
}
