/* test_nff.c: the NFF reader and writer (c/src/nff.c).  Run from tests/c. */
#include "mprt_internal.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"

#define REF "../data/spd-reference/"

/* ---- Helpers ------------------------------------------------------------ */

/* Parse text (NUL-terminated) into a new scene; OUT: status. */
static mprt_scene *parse_text(const char *text, const char *name, int *status)
{
    mprt_scene *s = NULL;
    int st;
    mprt_scene_create(&s);
    st = mprt_scene_parse_nff(s, text, strlen(text), name);
    if (status) *status = st;
    return s;
}

/* Parse text that must be valid. */
static mprt_scene *parse_ok(const char *text)
{
    int st;
    mprt_scene *s = parse_text(text, "t.nff", &st);
    CHECK_MSG(st == MPRT_OK, "status %d: %s", st, mprt_scene_errmsg(s));
    return s;
}

/* Whole file into a malloc'd buffer of exactly *len bytes (no NUL). */
static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    char *buf;
    long n;
    *len = 0;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    n = ftell(f);
    fseek(f, 0, SEEK_SET);
    buf = malloc(n > 0 ? (size_t)n : 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    if (buf) *len = (size_t)n;
    return buf;
}

/* Write a scene to a malloc'd NUL-terminated string. */
static char *write_text(const mprt_scene *s)
{
    size_t need = 0, need2 = 0;
    char *buf;
    int st = mprt_scene_write_nff(s, NULL, 0, &need);
    CHECK(st == MPRT_ERR_CAPACITY);
    CHECK(need > 0);
    buf = malloc(need);
    if (!buf) return NULL;
    st = mprt_scene_write_nff(s, buf, need, &need2);
    CHECK(st == MPRT_OK);
    CHECK(need2 == need);
    CHECK(strlen(buf) + 1 == need);
    return buf;
}

static int same_real(real a, real b) { return memcmp(&a, &b, sizeof a) == 0; }
static int same_double(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }
static int same_vec(vec3 a, vec3 b) { return same_real(a.x, b.x) && same_real(a.y, b.y) && same_real(a.z, b.z); }
static int near_vec(vec3 a, vec3 b, double tol)
{
    return fabs((double)(a.x - b.x)) <= tol && fabs((double)(a.y - b.y)) <= tol &&
           fabs((double)(a.z - b.z)) <= tol;
}

/* The scene tables of a and b hold the same bits.  Patch normals are compared
 * to ntol only: the scene normalises them when they are added, and
 * normalising a unit vector again can move its last bit. */
static void check_same_scene(const char *what, const mprt_scene *a, const mprt_scene *b, double ntol)
{
    long long i;
    int j, bad = 0;
    CHECK_MSG(a->nprims == b->nprims, "%s: prims %lld vs %lld", what, a->nprims, b->nprims);
    CHECK_MSG(a->nspheres == b->nspheres && a->npolygons == b->npolygons && a->ncones == b->ncones &&
                  a->nverts == b->nverts && a->ncylinders == b->ncylinders && a->npatches == b->npatches,
              "%s: counts differ", what);
    CHECK_MSG(a->nmaterials == b->nmaterials && a->material == b->material, "%s: materials %lld vs %lld", what,
              a->nmaterials, b->nmaterials);
    CHECK_MSG(a->nlights == b->nlights, "%s: lights", what);
    if (a->nprims != b->nprims || a->nspheres != b->nspheres || a->npolygons != b->npolygons ||
        a->ncones != b->ncones || a->nverts != b->nverts || a->nmaterials != b->nmaterials ||
        a->nlights != b->nlights)
        return;
    CHECK_MSG(same_vec(a->from, b->from) && same_vec(a->at, b->at) && same_vec(a->up, b->up) &&
                  same_double(a->angle, b->angle) && same_double(a->hither, b->hither) &&
                  a->width == b->width && a->height == b->height,
              "%s: view", what);
    for (j = 0; j < 3; j++) CHECK_MSG(same_double(a->background[j], b->background[j]), "%s: background", what);
    for (i = 0; i < a->nprims; i++)
        if (a->prims[i].kind != b->prims[i].kind || a->prims[i].index != b->prims[i].index ||
            a->prims[i].material != b->prims[i].material)
            bad++;
    for (i = 0; i < a->nspheres; i++)
        if (!same_vec(a->spheres[i].c, b->spheres[i].c) || !same_real(a->spheres[i].r, b->spheres[i].r)) bad++;
    for (i = 0; i < a->npolygons; i++) {
        const mprt__polygon *p = &a->polygons[i], *q = &b->polygons[i];
        if (p->first != q->first || p->n != q->n || p->has_normals != q->has_normals ||
            !same_vec(p->normal, q->normal) || !same_real(p->d, q->d))
            bad++;
    }
    for (i = 0; i < a->nverts; i++)
        if (!same_vec(a->verts[i], b->verts[i])) bad++;
    for (i = 0; i < a->npolygons; i++) {
        const mprt__polygon *p = &a->polygons[i];
        if (!p->has_normals || !a->vnormals || !b->vnormals) continue;
        for (j = 0; j < p->n; j++)
            if (!near_vec(a->vnormals[p->first + j], b->vnormals[p->first + j], ntol)) bad++;
    }
    CHECK_MSG(!a->vnormals == !b->vnormals, "%s: vnormals allocated in one scene only", what);
    for (i = 0; i < a->ncones; i++) {
        const mprt__cone *p = &a->cones[i], *q = &b->cones[i];
        if (!same_vec(p->base, q->base) || !same_vec(p->apex, q->apex) || !same_real(p->rb, q->rb) ||
            !same_real(p->ra, q->ra) || !same_vec(p->w, q->w) || !same_vec(p->u, q->u) ||
            !same_vec(p->v, q->v) || !same_real(p->len, q->len) || !same_real(p->slope, q->slope))
            bad++;
    }
    for (i = 0; i < a->nmaterials; i++) {
        const mprt__material *p = &a->materials[i], *q = &b->materials[i];
        if (!same_double(p->rgb[0], q->rgb[0]) || !same_double(p->rgb[1], q->rgb[1]) ||
            !same_double(p->rgb[2], q->rgb[2]) || !same_double(p->kd, q->kd) || !same_double(p->ks, q->ks) ||
            !same_double(p->shine, q->shine) || !same_double(p->t, q->t) || !same_double(p->ior, q->ior))
            bad++;
    }
    for (i = 0; i < a->nlights; i++) {
        const mprt__light *p = &a->lights[i], *q = &b->lights[i];
        if (!same_vec(p->pos, q->pos) || p->has_rgb != q->has_rgb || !same_double(p->rgb[0], q->rgb[0]) ||
            !same_double(p->rgb[1], q->rgb[1]) || !same_double(p->rgb[2], q->rgb[2]))
            bad++;
    }
    CHECK_MSG(bad == 0, "%s: %d table entries differ", what, bad);
}

/* parse -> write -> parse gives the same scene, and writing again gives the
 * same text when there are no patches. */
static void check_round_trip(const char *what, const mprt_scene *a)
{
    char *t1 = write_text(a), *t2;
    mprt_scene *b = NULL;
    int st;
    if (!t1) return;
    mprt_scene_create(&b);
    st = mprt_scene_parse_nff(b, t1, strlen(t1), "written.nff");
    CHECK_MSG(st == MPRT_OK, "%s: re-parse failed: %s", what, mprt_scene_errmsg(b));
    check_same_scene(what, a, b, 4 * REAL_EPS);
    t2 = write_text(b);
    if (t2 && a->npatches == 0) CHECK_MSG(strcmp(t1, t2) == 0, "%s: second write differs", what);
    free(t1);
    free(t2);
    mprt_scene_destroy(b);
}

/* A scene using every entity (both cone layouts, both light forms, p, pp). */
static const char *every_entity =
    "# hand-made scene with every entity\n"
    "v\n"
    "from 1.5 -2.25 3\n"
    "at 0 0.5 0\n"
    "up 0 0 1\n"
    "angle 40\n"
    "hither 0.125\n"
    "resolution 320 240\n"
    "b 0.1 0.2 0.3\n"
    "l 4 3 2\n"
    "l -1 -2 5 0.5 0.25 1\n"
    "f 1 0.5 0.25 0.7 0.3 20 0 1\n"
    "s 0.5 -0.5 1 0.75    # trailing comment\n"
    "p 3\n"
    "0 0 0\n"
    "1 0 0\n"
    "0 1 0\n"
    "f 0.2 0.4 0.6 0.5 0.5 3.0827 0.8 1.5\n"
    "pp 4\n"
    "0 0 1 0 0 2\n"
    "1 0 1 0 0.6 0.8\n"
    "1 1 1 1 1 1\n"
    "0 1 1 0 0 1\n"
    "c 0 0 0 0.5 0 0 2 0.25\n"
    "c\n"
    "1 1 1 0.3\n"
    "1 1 3 0.3\n"
    "s 1e-3 2.5E2 -7 0.1\n";

/* ---- Entities ----------------------------------------------------------- */

static void test_every_entity(void)
{
    mprt_scene *s = parse_ok(every_entity);
    const mprt__polygon *pg;
    const mprt__cone *c;
    CHECK(s->from.x == 1.5 && s->from.y == -2.25 && s->from.z == 3);
    CHECK(s->at.x == 0 && s->at.y == R(0.5) && s->at.z == 0);
    CHECK(s->up.x == 0 && s->up.y == 0 && s->up.z == 1);
    CHECK(s->angle == 40 && s->hither == 0.125 && s->width == 320 && s->height == 240);
    CHECK(s->background[0] == 0.1 && s->background[1] == 0.2 && s->background[2] == 0.3);

    CHECK(s->nlights == 2);
    CHECK(s->lights[0].pos.x == 4 && s->lights[0].pos.y == 3 && s->lights[0].pos.z == 2 && !s->lights[0].has_rgb);
    CHECK(s->lights[1].pos.x == -1 && s->lights[1].pos.z == 5 && s->lights[1].has_rgb);
    CHECK(s->lights[1].rgb[0] == 0.5 && s->lights[1].rgb[1] == 0.25 && s->lights[1].rgb[2] == 1);

    CHECK(s->nmaterials == 2);
    CHECK(s->materials[0].rgb[0] == 1 && s->materials[0].rgb[1] == 0.5 && s->materials[0].rgb[2] == 0.25);
    CHECK(s->materials[0].kd == 0.7 && s->materials[0].ks == 0.3 && s->materials[0].shine == 20);
    CHECK(s->materials[0].t == 0 && s->materials[0].ior == 1);
    CHECK(s->materials[1].rgb[2] == 0.6 && s->materials[1].shine == 3.0827 && s->materials[1].t == 0.8 &&
          s->materials[1].ior == 1.5);

    CHECK(s->nprims == 6 && s->nspheres == 2 && s->npolygons == 2 && s->ncones == 2 && s->ncylinders == 1);
    CHECK(s->npatches == 1 && s->nverts == 7);
    CHECK(s->prims[0].kind == MPRT_SPHERE && s->prims[0].material == 0);
    CHECK(s->prims[1].kind == MPRT_POLYGON && s->prims[1].material == 0 && s->prims[1].index == 0);
    CHECK(s->prims[2].kind == MPRT_POLYGON && s->prims[2].material == 1 && s->prims[2].index == 1);
    CHECK(s->prims[3].kind == MPRT_CONE && s->prims[3].material == 1);
    CHECK(s->prims[4].kind == MPRT_CYLINDER && s->prims[4].material == 1);
    CHECK(s->prims[5].kind == MPRT_SPHERE && s->prims[5].index == 1);

    CHECK(s->spheres[0].c.x == R(0.5) && s->spheres[0].c.y == R(-0.5) && s->spheres[0].c.z == 1);
    CHECK(s->spheres[0].r == R(0.75));
    CHECK(s->spheres[1].c.x == R(1e-3) && s->spheres[1].c.y == 250 && s->spheres[1].c.z == -7);
    CHECK(s->spheres[1].r == R(0.1));

    pg = &s->polygons[0];
    CHECK(pg->n == 3 && !pg->has_normals);
    CHECK(s->verts[pg->first + 1].x == 1 && s->verts[pg->first + 2].y == 1);
    pg = &s->polygons[1];
    CHECK(pg->n == 4 && pg->has_normals && pg->first == 3);
    CHECK(s->verts[pg->first + 2].x == 1 && s->verts[pg->first + 2].y == 1 && s->verts[pg->first + 2].z == 1);
    CHECK(s->vnormals != NULL);
    if (s->vnormals) {
        CHECK_NEAR(s->vnormals[pg->first].z, 1, 1e-6);
        CHECK_NEAR(s->vnormals[pg->first + 1].y, 0.6, 1e-6);
        CHECK_NEAR(s->vnormals[pg->first + 1].z, 0.8, 1e-6);
        CHECK_NEAR(s->vnormals[pg->first + 2].x, 1 / sqrt(3.0), 1e-6);
    }

    c = &s->cones[0];
    CHECK(c->base.x == 0 && c->base.z == 0 && c->rb == R(0.5));
    CHECK(c->apex.z == 2 && c->ra == R(0.25));
    c = &s->cones[1];
    CHECK(c->base.x == 1 && c->base.y == 1 && c->base.z == 1 && c->rb == R(0.3));
    CHECK(c->apex.x == 1 && c->apex.z == 3 && c->ra == R(0.3));
    CHECK(s->dropped == 0 && s->warning[0] == '\0');
    mprt_scene_destroy(s);
}

static void test_cone_layouts_equal(void)
{
    mprt_scene *a = parse_ok("c 0.25 -1 2 0.5 3 4.5 -6 0.125\n");
    mprt_scene *b = parse_ok("c\n0.25 -1 2 0.5\n3 4.5 -6 0.125\n");
    mprt_scene *c = parse_ok("c   # three-line layout\n\n# base\n 0.25 -1 2 0.5 \n\t# apex\n3 4.5 -6 0.125");
    CHECK(a->ncones == 1 && a->ncylinders == 0);
    check_same_scene("one line vs three lines", a, b, 0);
    check_same_scene("one line vs three lines with comments", a, c, 0);
    CHECK(a->cones[0].base.x == R(0.25) && a->cones[0].apex.y == R(4.5) && a->cones[0].ra == R(0.125));
    mprt_scene_destroy(a);
    mprt_scene_destroy(b);
    mprt_scene_destroy(c);
}

static void test_comments_and_whitespace(void)
{
    int st;
    mprt_scene *s = parse_ok("# header\n"
                             "   \n"
                             "\t s\t1 2 3 4 # trailing\r\n"
                             "#only a comment\r"
                             "s 5 6 7 8#no space before the comment\n"
                             "\f\v\n"
                             "##\n"
                             "s 9 10 11 12"); /* no final newline */
    CHECK(s->nspheres == 3);
    CHECK(s->spheres[0].c.x == 1 && s->spheres[0].r == 4);
    CHECK(s->spheres[1].c.x == 5 && s->spheres[1].r == 8);
    CHECK(s->spheres[2].c.x == 9 && s->spheres[2].r == 12);
    mprt_scene_destroy(s);

    /* Line numbers count "\n", "\r\n" and a lone "\r" once each. */
    s = parse_text("# 1\r\n# 2\r# 3\n\n q\n", "t.nff", &st);
    CHECK(st == MPRT_ERR_PARSE);
    CHECK_MSG(strstr(mprt_scene_errmsg(s), "t.nff:5: unknown entity 'q'") != NULL, "%s", mprt_scene_errmsg(s));
    mprt_scene_destroy(s);

    /* Empty text and comment-only text are valid and add nothing. */
    s = parse_ok("");
    CHECK(s->nprims == 0);
    mprt_scene_destroy(s);
    s = parse_ok("# nothing\n\n");
    CHECK(s->nprims == 0 && s->nlights == 0);
    mprt_scene_destroy(s);
}

static void test_light_with_and_without_colour(void)
{
    mprt_scene *s = parse_ok("l 1 2 3\nl 4 5 6 0.5 0.25 1\n");
    char *text;
    CHECK(s->nlights == 2);
    CHECK(!s->lights[0].has_rgb && s->lights[0].pos.y == 2);
    CHECK(s->lights[1].has_rgb && s->lights[1].rgb[1] == 0.25 && s->lights[1].pos.z == 6);
    text = write_text(s);
    if (text) {
        CHECK_MSG(strstr(text, "\nl 1 2 3\n") != NULL, "%s", text);
        CHECK_MSG(strstr(text, "\nl 4 5 6 0.5 0.25 1\n") != NULL, "%s", text);
    }
    free(text);
    mprt_scene_destroy(s);
}

static void test_patch(void)
{
    mprt_scene *s = parse_ok("pp 3\n0 0 0 0 0 2\n1 0 0 0 0.6 0.8\n0 1 0 0 0 1\n");
    mprt_scene_info info;
    char *text;
    CHECK(s->npolygons == 1 && s->npatches == 1 && s->polygons[0].has_normals && s->polygons[0].n == 3);
    CHECK(s->vnormals != NULL);
    if (s->vnormals) {
        CHECK(s->vnormals[0].x == 0 && s->vnormals[0].y == 0 && s->vnormals[0].z == 1);
        CHECK_NEAR(s->vnormals[1].y, 0.6, 1e-6);
        CHECK_NEAR(s->vnormals[1].z, 0.8, 1e-6);
    }
    CHECK(mprt_scene_get_info(s, &info) == MPRT_OK);
    CHECK(info.patches == 1 && info.count[MPRT_POLYGON] == 1 && info.vertices == 3);
    text = write_text(s);
    if (text) CHECK_MSG(strstr(text, "\npp 3\n0 0 0 0 0 1\n") != NULL, "%s", text);
    free(text);
    mprt_scene_destroy(s);
}

static void test_duplicate_vertices_merged(void)
{
    mprt_scene *s = parse_ok("p 6\n0 0 0\n0 0 0\n1 0 0\n1 0 0\n0 1 0\n0 0 0\n");
    CHECK(s->npolygons == 1 && s->polygons[0].n == 3 && s->nverts == 3);
    CHECK(s->verts[1].x == 1 && s->verts[2].y == 1);
    mprt_scene_destroy(s);
    /* In a patch, equal positions with different normals are kept. */
    s = parse_ok("pp 4\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 0 0 0 0.1 1\n0 1 0 0 0 1\n");
    CHECK(s->npolygons == 1 && s->polygons[0].n == 4);
    mprt_scene_destroy(s);
}

/* ---- Reference files ---------------------------------------------------- */

typedef struct {
    const char *file;
    long long spheres, polygons, cylinders, cones, lights, materials;
    double from[3], hither;
} ref_counts;

static const ref_counts refs[6] = {
    {"balls.nff", 7381, 1, 0, 0, 3, 2, {2.1, 1.3, 1.7}, 0.01},
    {"gears.nff", 0, 9345, 0, 0, 5, 65, {-1.1, -2.1, 2.6}, 1},
    {"mount.nff", 4, 8192, 0, 0, 1, 2, {-1.6, 1.6, 1.7}, 0.01},
    {"rings.nff", 4200, 1, 4200, 0, 3, 841, {-1, -2.61313, 0.5}, 1},
    {"tetra.nff", 0, 4096, 0, 0, 1, 1, {1.02285, -3.17715, -2.17451}, 1},
    {"tree.nff", 4095, 1, 0, 4095, 7, 2, {4.5, 0.4, 2}, 1},
};

static mprt_scene *load_ref(const char *file)
{
    char path[256];
    mprt_scene *s = NULL;
    int st;
    snprintf(path, sizeof path, REF "%s", file);
    mprt_scene_create(&s);
    st = mprt_scene_load_nff(s, path);
    CHECK_MSG(st == MPRT_OK, "%s: %s", file, mprt_scene_errmsg(s));
    return s;
}

static void test_reference_counts(void)
{
    int i;
    for (i = 0; i < 6; i++) {
        const ref_counts *r = &refs[i];
        mprt_scene *s = load_ref(r->file);
        mprt_scene_info info;
        CHECK(mprt_scene_get_info(s, &info) == MPRT_OK);
        CHECK_MSG(info.count[MPRT_SPHERE] == r->spheres, "%s spheres %lld", r->file, info.count[MPRT_SPHERE]);
        CHECK_MSG(info.count[MPRT_POLYGON] == r->polygons, "%s polygons %lld", r->file, info.count[MPRT_POLYGON]);
        CHECK_MSG(info.count[MPRT_CYLINDER] == r->cylinders, "%s cylinders %lld", r->file, info.count[MPRT_CYLINDER]);
        CHECK_MSG(info.count[MPRT_CONE] == r->cones, "%s cones %lld", r->file, info.count[MPRT_CONE]);
        CHECK_MSG(info.prims == r->spheres + r->polygons + r->cylinders + r->cones, "%s prims", r->file);
        CHECK_MSG(info.patches == 0 && info.dropped == 0, "%s patches/dropped", r->file);
        CHECK_MSG(info.lights == r->lights, "%s lights %lld", r->file, info.lights);
        CHECK_MSG(info.materials == r->materials, "%s materials %lld", r->file, info.materials);
        CHECK_MSG(info.background[0] == 0.078 && info.background[1] == 0.361 && info.background[2] == 0.753,
                  "%s background", r->file);
        CHECK(info.from[0] == R(r->from[0]) && info.from[1] == R(r->from[1]) && info.from[2] == R(r->from[2]));
        CHECK(info.hither == r->hither && info.angle == 45 && info.width == 512 && info.height == 512);
        mprt_scene_destroy(s);
    }
}

static void test_reference_details(void)
{
    mprt_scene *s = load_ref("gears.nff");
    long long i, big = 0;
    for (i = 0; i < s->npolygons; i++) big += s->polygons[i].n == 144;
    CHECK_MSG(big == 128, "144-gons: %lld", big);
    mprt_scene_destroy(s);
    s = load_ref("tree.nff");
    CHECK(s->ncones == 4095 && s->cones[0].rb == R(0.15) && s->cones[0].ra == R(0.1005));
    mprt_scene_destroy(s);
}

static void test_round_trip(void)
{
    int i;
    mprt_scene *s;
    static const double w[3] = {0.1 + 0.2, 1.0 / 3, 2.0 / 3};
    static const double p0[3] = {1.0 / 3, -2.0 / 7, 1e-30};
    static const double p1[3] = {-0.0, 1e30, 123456789.123456789};
    static const double quad[12] = {0, 0, 0.1, 1.0 / 3, 0, 0.1, 1.0 / 3, 1.0 / 7, 0.1, 0, 1.0 / 7, 0.1};
    static const double nrm[12] = {0.1, 0.2, 1, 0, 0, 3, 1.0 / 3, 1, 1, -0.1, 0, 1};
    for (i = 0; i < 6; i++) {
        s = load_ref(refs[i].file);
        check_round_trip(refs[i].file, s);
        mprt_scene_destroy(s);
    }
    s = parse_ok(every_entity);
    check_round_trip("every entity", s);
    mprt_scene_destroy(s);

    /* Built through the API: numbers that need 17 digits, a default material
     * before the first set_material, unused materials between and after. */
    mprt_scene_create(&s);
    CHECK(mprt_scene_set_view(s, p0, p1, w, 33.3, 1.0 / 9, 7, 5) == MPRT_OK);
    CHECK(mprt_scene_set_background(s, w) == MPRT_OK);
    CHECK(mprt_scene_add_light(s, p0, NULL) == MPRT_OK);
    CHECK(mprt_scene_add_light(s, p1, w) == MPRT_OK);
    CHECK(mprt_scene_add_sphere(s, p0, 1e-30) == MPRT_OK);
    CHECK(mprt_scene_set_material(s, w, 0.1, 0.7, 1.0 / 3, 0, 0) == MPRT_OK);
    CHECK(mprt_scene_set_material(s, w, 0.3, 0.7, 1.0 / 3, 0.2, 1.0 / 3) == MPRT_OK);
    CHECK(mprt_scene_add_cone(s, p0, 0.1 + 0.2, p1, 0.1 + 0.2) == MPRT_OK);
    CHECK(mprt_scene_add_polygon(s, 4, quad, nrm) == MPRT_OK);
    CHECK(mprt_scene_add_polygon(s, 4, quad, NULL) == MPRT_OK);
    CHECK(mprt_scene_set_material(s, w, 1, 0, 0, 0, 1) == MPRT_OK);
    CHECK(s->nmaterials == 4 && s->nprims == 4);
    check_round_trip("API scene", s);
    mprt_scene_destroy(s);
}

/* ---- Bad input ---------------------------------------------------------- */

typedef struct {
    const char *text;
    const char *where;   /* "t.nff:LINE:" */
    const char *what;    /* a fragment of the message */
} bad_case;

static const bad_case bad[] = {
    {"s 0 0 0 1\nq 1 2\n", "t.nff:2:", "unknown entity 'q'"},
    {"\n\ns 1 2 3\n", "t.nff:3:", "expected 4 numbers after 's' (x y z radius), found 3"},
    {"s 1 2 3 4 5\n", "t.nff:1:", "expected 4 numbers after 's' (x y z radius), found 5"},
    {"s\n", "t.nff:1:", "found 0"},
    {"b 0 0 0\ns 1 2x 3 4\n", "t.nff:2:", "expected a number after 's' (x y z radius), found '2x'"},
    {"s 1 2 3 4,\n", "t.nff:1:", "found '4,'"},
    {"s 1 2 3 0x\n", "t.nff:1:", "found '0x'"},
    {"s 1 2 3 1234567890123456789012345678901234567890123456789012345678901234567890123456789012345678901234"
     "5678901234567890123456789012345678901234567890\n",
     "t.nff:1:", "expected a number"},
    {"# nan\ns nan 0 0 1\n", "t.nff:2:", "expected a finite number after 's' (x y z radius), found 'nan'"},
    {"l inf 0 0\n", "t.nff:1:", "expected a finite number after 'l' (x y z [r g b]), found 'inf'"},
    {"b 0 -INFINITY 0\n", "t.nff:1:", "finite number"},
    {"s 0 0 1e999 1\n", "t.nff:1:", "expected a finite number after 's' (x y z radius), found '1e999'"},
    {"s 0 0 0 0\n", "t.nff:1:", "sphere: radius 0 is not positive"},
    {"s 0 0 0 1\ns 0 0 0 -1\n", "t.nff:2:", "sphere: radius -1 is not positive"},
    {"p 4\n0 0 0\n1 0 0\n1 1 1\n0 1 0\n", "t.nff:1:", "polygon"},
    {"s 0 0 0 1\nc 1 2 3 1 1 2 3 0.5\n", "t.nff:2:", "cone:"},
    {"c\n1 2 3 1\n1 2 3 0.5\n", "t.nff:1:", "cone:"},
    {"# x\np 5\n0 0 0\n1 0 0\n", "t.nff:4:",
     "expected 3 more vertices of the polygon started at line 2, found end of file"},
    {"p 3\n0 0 0\n1 0 0\n\n# end\n", "t.nff:5:",
     "expected 1 more vertex of the polygon started at line 1, found end of file"},
    {"p 4\n0 0 0\n1 0 0\n1 1 0\ns 0 0 0 1\n", "t.nff:5:",
     "expected 3 numbers for vertex 4 of 4 of the polygon started at line 1 (x y z), found 's'"},
    {"p 3\n0 0 0\n1 0\n0 1 0\n", "t.nff:3:", "expected 3 numbers for vertex 2 of 3 of the polygon started at line 1"},
    {"p 3\n0 0 0\n1 0 0 1\n0 1 0\n", "t.nff:3:", "found 4"},
    {"pp 3\n0 0 0 0 0 1\n1 0 0\n0 1 0 0 0 1\n", "t.nff:3:",
     "expected 6 numbers for vertex 2 of 3 of the polygon patch started at line 1 (x y z nx ny nz), found 3"},
    {"pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n", "t.nff:3:", "polygon patch started at line 1, found end of file"},
    {"pp 3\n0 0 0 0 0 0\n1 0 0 0 0 1\n0 1 0 0 0 1\n", "t.nff:1:", "zero normal"},
    {"p 0\n", "t.nff:1:", "expected a positive integer vertex count after 'p', found '0'"},
    {"p -3\n", "t.nff:1:", "found '-3'"},
    {"p 3.5\n", "t.nff:1:", "found '3.5'"},
    {"p x\n", "t.nff:1:", "found 'x'"},
    {"p 99999999999999999999\n", "t.nff:1:", "vertex count"},
    {"p\n0 0 0\n", "t.nff:1:", "expected 1 number after 'p' (vertex count), found 0"},
    {"p 3 4\n", "t.nff:1:", "found 2"},
    {"p 2\n0 0 0\n1 0 0\n", "t.nff:1:", "at least 3"},
    {"f 1 1 1 1 0 0 0\n", "t.nff:1:", "expected 8 numbers after 'f' (r g b Kd Ks Shine T ior), found 7"},
    {"f 1 1 1 -1 0 0 0 1\n", "t.nff:1:", "material:"},
    {"l 1 2 3 4\n", "t.nff:1:", "expected 3 or 6 numbers after 'l' (x y z [r g b]), found 4"},
    {"b 1 1\n", "t.nff:1:", "expected 3 numbers after 'b' (r g b), found 2"},
    {"c 1 2 3 4 5\n", "t.nff:1:", "expected 8 numbers after 'c'"},
    {"c\n0 0 0 1\n", "t.nff:2:", "expected the apex line (x y z radius) of the cone started at line 1, found end of file"},
    {"c\n0 0 0 1\n0 0 1\n", "t.nff:3:", "expected 4 numbers for the apex of the cone started at line 1 (x y z radius), found 3"},
    {"c\ns 0 0 0 1\n", "t.nff:2:", "for the base of the cone started at line 1 (x y z radius), found 's'"},
    {"v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nresolution 10 10\n", "t.nff:6:",
     "expected 'hither' in the view started at line 1, found 'resolution'"},
    {"\nv\nfrom 0 0 5\n", "t.nff:3:", "expected the 'at' line of the view started at line 2, found end of file"},
    {"v\nfrom 0 0\n", "t.nff:2:", "expected 3 numbers after 'from' (x y z), found 2"},
    {"v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 10.5 10\n", "t.nff:7:",
     "expected an integer after 'resolution' (width height), found '10.5'"},
    {"v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 10\n", "t.nff:7:",
     "expected 2 integers after 'resolution' (width height), found 1"},
    {"s 0 0 0 1\nv\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 200\nhither 1\nresolution 10 10\n", "t.nff:2:",
     "view: angle 200"},
    {"v 1\n", "t.nff:1:", "expected nothing after 'v'"},
    {"from 0 0 1\n", "t.nff:1:", "unknown entity 'from'"},
    {"S 0 0 0 1\n", "t.nff:1:", "unknown entity 'S'"},
    {"s0 0 0 1\n", "t.nff:1:", "unknown entity 's0'"},
    {"\x01\xff x\n", "t.nff:1:", "unknown entity '\\x01\\xff'"},
};

static void test_bad_input(void)
{
    size_t i;
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int st;
        mprt_scene *s = parse_text(bad[i].text, "t.nff", &st);
        const char *msg = mprt_scene_errmsg(s);
        CHECK_MSG(st == MPRT_ERR_PARSE, "case %d: status %d", (int)i, st);
        CHECK_MSG(strncmp(msg, bad[i].where, strlen(bad[i].where)) == 0, "case %d: '%s' does not start with '%s'",
                  (int)i, msg, bad[i].where);
        CHECK_MSG(strstr(msg, bad[i].what) != NULL, "case %d: '%s' lacks '%s'", (int)i, msg, bad[i].what);
        mprt_scene_destroy(s);
    }
}

static void test_nul_byte_in_text(void)
{
    static const char text[] = "s 0 0 0 1\ns 0 0\0 0 1\n";
    mprt_scene *s = NULL;
    int st;
    mprt_scene_create(&s);
    st = mprt_scene_parse_nff(s, text, sizeof text - 1, "nul.nff");
    CHECK(st == MPRT_ERR_PARSE);
    CHECK_MSG(strstr(mprt_scene_errmsg(s), "nul.nff:2: expected a number after 's' (x y z radius), found '0\\x00'"),
              "%s", mprt_scene_errmsg(s));
    mprt_scene_destroy(s);
}

static void test_failed_parse_changes_nothing(void)
{
    mprt_scene *s = parse_ok(every_entity), *orig = parse_ok(every_entity);
    static const char more[] =
        "b 1 1 1\nl 0 0 9\nf 0 0 0 1 0 0 0 1\ns 9 9 9 1\npp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n"
        "0 1 0 0 0 1\np 3\n0 0 0\n1 0 0\n2 0 0\nv\nfrom 1 1 1\nat 0 0 0\nup 0 0 1\nangle 30\n"
        "hither 0\nresolution 8 8\ns 0 0 0 bad\n";
    int st = mprt_scene_parse_nff(s, more, strlen(more), "more.nff");
    CHECK(st == MPRT_ERR_PARSE);
    CHECK_MSG(strstr(mprt_scene_errmsg(s), "more.nff:20:") != NULL, "%s", mprt_scene_errmsg(s));
    check_same_scene("after a failed parse", orig, s, 0);
    CHECK(s->dropped == 0 && s->warning[0] == '\0');
    mprt_scene_destroy(s);
    mprt_scene_destroy(orig);
}

static void test_zero_area_polygon_dropped(void)
{
    mprt_scene *s = parse_ok("s 0 0 0 1\n"
                             "p 3\n0 0 0\n1 0 0\n2 0 0\n"        /* collinear: zero area */
                             "s 1 1 1 1\n"
                             "p 3\n1 1 1\n1 1 1\n1 1 1\n"        /* one point after merging */
                             "pp 3\n0 0 0 0 0 1\n0 0 0 0 0 1\n5 5 5 0 0 1\n"
                             "p 3\n0 0 0\n1 0 0\n0 1 0\n");
    mprt_scene_info info;
    CHECK(mprt_scene_get_info(s, &info) == MPRT_OK);
    CHECK_MSG(info.dropped == 3, "dropped %lld", info.dropped);
    CHECK(info.count[MPRT_SPHERE] == 2 && info.count[MPRT_POLYGON] == 1 && info.vertices == 3);
    CHECK_MSG(strcmp(mprt_scene_warning(s), "t.nff:2: polygon with zero area dropped") == 0, "%s",
              mprt_scene_warning(s));
    CHECK_MSG(mprt_scene_errmsg(s)[0] == '\0', "%s", mprt_scene_errmsg(s));
    mprt_scene_destroy(s);
}

/* ---- Writer ------------------------------------------------------------- */

static void test_writer_capacity(void)
{
    mprt_scene *s = parse_ok(every_entity);
    size_t need = 0, need2 = 0, i;
    char *buf;
    int st = mprt_scene_write_nff(s, NULL, 0, &need);
    CHECK(st == MPRT_ERR_CAPACITY && need > 100);
    buf = malloc(need + 16);
    if (buf) {
        memset(buf, 'Z', need + 16);
        st = mprt_scene_write_nff(s, buf, need - 1, &need2);
        CHECK(st == MPRT_ERR_CAPACITY && need2 == need);
        for (i = need - 1; i < need + 16; i++) CHECK(buf[i] == 'Z');
        memset(buf, 'Z', need + 16);
        st = mprt_scene_write_nff(s, buf, 10, &need2);
        CHECK(st == MPRT_ERR_CAPACITY && need2 == need);
        for (i = 10; i < need + 16; i++) CHECK(buf[i] == 'Z');
        st = mprt_scene_write_nff(s, buf, need, &need2);
        CHECK(st == MPRT_OK && need2 == need && strlen(buf) == need - 1 && buf[need] == 'Z');
        CHECK(strstr(buf, "\nc 1 1 1 0.3 1 1 3 0.3\n") != NULL);
        CHECK(strstr(buf, "\nv\nfrom 1.5 -2.25 3\nat 0 0.5 0\nup 0 0 1\nangle 40\nhither 0.125\n"
                          "resolution 320 240\nb 0.1 0.2 0.3\n") != NULL);
        free(buf);
    }
    CHECK(mprt_scene_write_nff(s, NULL, 0, NULL) == MPRT_ERR_INVALID_ARG);
    mprt_scene_destroy(s);
}

static void test_writer_emits_materials_on_change(void)
{
    mprt_scene *s = parse_ok("f 1 0 0 1 0 0 0 1\ns 0 0 0 1\ns 0 0 1 1\nf 0 1 0 1 0 0 0 1\ns 0 0 2 1\n");
    char *text = write_text(s), *p;
    int nf = 0;
    for (p = text; p && (p = strstr(p, "\nf ")) != NULL; p++) nf++;
    CHECK_MSG(nf == 2, "%d f lines", nf);
    if (text) CHECK(strstr(text, "f 1 0 0 1 0 0 0 1\ns 0 0 0 1\ns 0 0 1 1\nf 0 1 0 1 0 0 0 1\ns 0 0 2 1\n") != NULL);
    free(text);
    mprt_scene_destroy(s);
}

/* ---- Robustness --------------------------------------------------------- */

static unsigned long long rng_state = 0x9e3779b97f4a7c15ULL;
static unsigned long long rng(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return rng_state;
}

/* Parse an exact-length copy (no NUL after it); errors must name the file. */
static void parse_any(const char *text, size_t len)
{
    mprt_scene *s = NULL;
    char *copy = malloc(len ? len : 1);
    int st;
    if (!copy) return;
    memcpy(copy, text, len);
    mprt_scene_create(&s);
    st = mprt_scene_parse_nff(s, copy, len, "fuzz.nff");
    CHECK_MSG(st == MPRT_OK || st == MPRT_ERR_PARSE, "status %d", st);
    if (st != MPRT_OK) CHECK_MSG(strncmp(mprt_scene_errmsg(s), "fuzz.nff:", 9) == 0, "%s", mprt_scene_errmsg(s));
    if (st == MPRT_OK) {
        char *t = write_text(s);
        free(t);
    }
    mprt_scene_destroy(s);
    free(copy);
}

static void mutate(char *buf, size_t len)
{
    static const char pool[] = "\n\r\t #.-+eE0123456789pcsflvbnaix\0\xff";
    int k, flips = 1 + (int)(rng() % 4);
    for (k = 0; k < flips && len; k++) {
        size_t at = (size_t)(rng() % len);
        buf[at] = (rng() & 1) ? pool[rng() % (sizeof pool - 1)] : (char)(rng() & 0xff);
    }
}

static void test_fuzz(void)
{
    size_t n = strlen(every_entity), i, len;
    char *buf = malloc(n), *file;
    int f, k;
    if (!buf) return;
    for (i = 0; i <= n; i++) parse_any(every_entity, i); /* every truncation */
    for (k = 0; k < 3000; k++) {
        memcpy(buf, every_entity, n);
        mutate(buf, n);
        parse_any(buf, rng() % 4 ? n : (size_t)(rng() % (n + 1)));
    }
    free(buf);
    for (f = 0; f < 6; f++) {
        char path[256];
        snprintf(path, sizeof path, REF "%s", refs[f].file);
        file = slurp(path, &len);
        CHECK_MSG(file != NULL, "%s", path);
        if (!file) continue;
        for (k = 0; k < 12; k++) parse_any(file, (size_t)(rng() % (len + 1)));
        buf = malloc(len);
        for (k = 0; buf && k < 12; k++) {
            memcpy(buf, file, len);
            mutate(buf, len);
            parse_any(buf, len);
        }
        free(buf);
        free(file);
    }
}

static void test_parse_speed(void)
{
    size_t len;
    char *text = slurp(REF "gears.nff", &len);
    mprt_scene *s = NULL;
    clock_t t0;
    double ms;
    int st;
    CHECK(text != NULL);
    if (!text) return;
    mprt_scene_create(&s);
    t0 = clock();
    st = mprt_scene_parse_nff(s, text, len, "gears.nff");
    ms = 1000.0 * (double)(clock() - t0) / CLOCKS_PER_SEC;
    CHECK(st == MPRT_OK);
    printf("gears.nff parsed in %.1f ms\n", ms);
    mprt_scene_destroy(s);
    free(text);
}

int main(void)
{
    RUN(test_every_entity);
    RUN(test_cone_layouts_equal);
    RUN(test_comments_and_whitespace);
    RUN(test_light_with_and_without_colour);
    RUN(test_patch);
    RUN(test_duplicate_vertices_merged);
    RUN(test_reference_counts);
    RUN(test_reference_details);
    RUN(test_round_trip);
    RUN(test_bad_input);
    RUN(test_nul_byte_in_text);
    RUN(test_failed_parse_changes_nothing);
    RUN(test_zero_area_polygon_dropped);
    RUN(test_writer_capacity);
    RUN(test_writer_emits_materials_on_change);
    RUN(test_fuzz);
    RUN(test_parse_speed);
    return CHECK_DONE();
}
