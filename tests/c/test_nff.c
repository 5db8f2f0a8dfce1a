/* test_nff.c: the NFF reader and writer (nff*.c) on good input: every
 * entity, the SPD reference files, round trips and the writer.  Run from
 * tests/c. */
#include "nff_check.h"

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
    for (i = 0; i < NREFS; i++) {
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
    static const double p1[3] = {-0.0, 1e15, 123456789.123456789}; /* (coordinates stay under 1e18) */
    static const double quad[12] = {0, 0, 0.1, 1.0 / 3, 0, 0.1, 1.0 / 3, 1.0 / 7, 0.1, 0, 1.0 / 7, 0.1};
    static const double nrm[12] = {0.1, 0.2, 1, 0, 0, 3, 1.0 / 3, 1, 1, -0.1, 0, 1};
    for (i = 0; i < NREFS; i++) {
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
    RUN(test_writer_capacity);
    RUN(test_writer_emits_materials_on_change);
    return CHECK_DONE();
}
