/* test_scene_state.c: a scene with grids refuses changes, a mark and
 * rollback undo everything added since the mark, and a primitive of unknown
 * kind (a corrupted scene) fails every call that meets it with a message. */
#include "check.h"
#include "mprt_internal.h"

#include <stdlib.h>
#include <string.h>

static const double origin[3] = {0, 0, 0}, unit_x[3] = {1, 0, 0}, up_z[3] = {0, 0, 1};
static const double tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, tri_normals[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};

static mprt_scene *small_scene(void)
{
    mprt_scene *s;
    double c[3] = {0, 0, 3};
    mprt_scene_create(&s);
    CHECK(mprt_scene_add_sphere(s, c, 1) == MPRT_OK);
    CHECK(mprt_scene_add_polygon(s, 3, tri, NULL) == MPRT_OK);
    CHECK(mprt_scene_add_cone(s, origin, 1, unit_x, 0.5) == MPRT_OK);
    return s;
}

/* The scene as NFF text (malloc'd). */
static char *nff_text(const mprt_scene *s)
{
    size_t need = 0;
    char *buf;
    CHECK(mprt_scene_write_nff(s, NULL, 0, &need) == MPRT_ERR_CAPACITY);
    buf = malloc(need);
    CHECK(mprt_scene_write_nff(s, buf, need, &need) == MPRT_OK);
    return buf;
}

enum { NCALLS = 10 };

/* Call number k of the calls that change a scene; returns its status. */
static int change(mprt_scene *s, int k)
{
    static const char text[] = "s 5 5 5 1\n";
    switch (k) {
    case 0: return mprt_scene_add_sphere(s, unit_x, 1);
    case 1: return mprt_scene_add_polygon(s, 3, tri, NULL);
    case 2: return mprt_scene_add_cone(s, origin, 1, up_z, 1);
    case 3: return mprt_scene_add_light(s, unit_x, NULL);
    case 4: return mprt_scene_set_material(s, unit_x, 1, 0, 0, 0, 1);
    case 5: return mprt_scene_set_view(s, unit_x, origin, up_z, 30, 0, 8, 8);
    case 6: return mprt_scene_set_background(s, unit_x);
    case 7: return mprt_scene_parse_nff(s, text, strlen(text), "t.nff");
    case 8: return mprt_scene_load_nff(s, "../data/spd-reference/balls.nff");
    default: return mprt_scene_spd(s, "tetra", 1);
    }
}

static const char *const call_name[NCALLS] = {"add_sphere", "add_polygon", "add_cone", "add_light", "set_material",
                                              "set_view", "set_background", "parse_nff", "load_nff", "spd"};

static void test_a_scene_with_grids_refuses_every_change(void)
{
    mprt_scene *s = small_scene();
    mprt_grid *g1, *g2;
    char *before, *after;
    int k;
    CHECK(mprt_grid_create(s, 2, 2, 2, 0, &g1) == MPRT_OK);
    CHECK(mprt_grid_create(s, 3, 3, 3, 0, &g2) == MPRT_OK);
    before = nff_text(s);
    for (k = 0; k < NCALLS; k++) {
        CHECK_MSG(change(s, k) == MPRT_ERR_STATE, "%s", call_name[k]);
        CHECK_MSG(strstr(mprt_scene_errmsg(s), call_name[k]) && strstr(mprt_scene_errmsg(s), "2 grids"),
                  "%s: '%s'", call_name[k], mprt_scene_errmsg(s));
    }
    after = nff_text(s);
    CHECK(strcmp(before, after) == 0);
    free(after);
    /* Still refused with one grid left, allowed with none */
    mprt_grid_destroy(g1);
    CHECK(change(s, 0) == MPRT_ERR_STATE);
    CHECK(strstr(mprt_scene_errmsg(s), "1 grid;") != NULL);
    mprt_grid_destroy(g2);
    for (k = 0; k < NCALLS; k++) CHECK_MSG(change(s, k) == MPRT_OK, "%s: %s", call_name[k], mprt_scene_errmsg(s));
    free(before);
    mprt_scene_destroy(s);
}

/* A grid that failed to build does not hold the scene. */
static void test_a_failed_grid_does_not_lock_the_scene(void)
{
    mprt_scene *s = small_scene();
    mprt_grid *g;
    CHECK(mprt_grid_create(s, 0, 2, 2, 0, &g) == MPRT_ERR_INVALID_ARG);
    CHECK(change(s, 0) == MPRT_OK);
    mprt_grid_destroy(g);
    CHECK(change(s, 0) == MPRT_OK);
    mprt_scene_destroy(s);
}

/* Entities added after a mark, arrays grown past their capacity, view,
 * background, material and warnings all go back; the scene stays usable. */
static void test_rollback_restores_the_marked_scene(void)
{
    mprt_scene *s = small_scene();
    mprt__scene_saved saved;
    mprt_grid *g;
    char *before, *after;
    double c[3] = {0, 0, 0};
    int i;
    before = nff_text(s);
    mprt__scene_mark(s, &saved);
    for (i = 0; i < 100; i++) {
        c[0] = i;
        CHECK(mprt_scene_add_sphere(s, c, 0.25) == MPRT_OK);
        CHECK(mprt_scene_add_polygon(s, 3, tri, tri_normals) == MPRT_OK); /* vertex normals appear */
        CHECK(mprt_scene_add_light(s, c, c) == MPRT_OK);
        CHECK(mprt_scene_set_material(s, unit_x, 0.5, 0.5, 2, 0, 1) == MPRT_OK);
    }
    CHECK(mprt_scene_set_view(s, unit_x, origin, up_z, 30, 0.5, 9, 7) == MPRT_OK);
    CHECK(mprt_scene_set_background(s, unit_x) == MPRT_OK);
    mprt__scene_warn(s, "a warning %d", 1);
    mprt__scene_rollback(s, &saved);
    after = nff_text(s);
    CHECK_MSG(strcmp(before, after) == 0, "before:\n%s\nafter:\n%s", before, after);
    CHECK(s->dropped == 0 && s->warning[0] == '\0');
    CHECK(s->npatches == 0 && s->nprims == 3);
    CHECK(mprt_scene_add_sphere(s, unit_x, 2) == MPRT_OK);
    CHECK(mprt_grid_create(s, 4, 4, 4, 0, &g) == MPRT_OK);
    mprt_grid_destroy(g);
    free(before);
    free(after);
    mprt_scene_destroy(s);
}

/* A polygon of zero area is dropped with a warning, and the message of an
 * earlier failed call stays (the parse succeeded). */
static void test_a_dropped_polygon_leaves_the_error_message(void)
{
    mprt_scene *s;
    static const char text[] = "p 3\n0 0 0\n1 0 0\n2 0 0\n";
    char msg[MPRT__ERRMSG];
    mprt_scene_create(&s);
    CHECK(mprt_scene_add_sphere(s, origin, -1) == MPRT_ERR_INVALID_ARG);
    strcpy(msg, mprt_scene_errmsg(s));
    CHECK(mprt_scene_parse_nff(s, text, strlen(text), "flat.nff") == MPRT_OK);
    CHECK(s->dropped == 1 && strstr(s->warning, "flat.nff:1:") != NULL);
    CHECK_MSG(strcmp(msg, mprt_scene_errmsg(s)) == 0, "'%s' became '%s'", msg, mprt_scene_errmsg(s));
    mprt_scene_destroy(s);
}

#define BAD_KIND 9

static int names_bad_prim(const char *msg) { return strstr(msg, "primitive 1 has unknown kind 9") != NULL; }

/* Every call that switches on a primitive's kind fails on an unknown one. */
static void test_an_unknown_kind_fails_loudly(void)
{
    mprt_scene *s = small_scene();
    mprt_grid *g, *bad;
    mprt_scene_info info;
    mprt_render_desc d;
    int32_t kind[3], words[3], mat[3], prim;
    double o[3] = {0.25, 0.25, -5}, dir[3] = {0, 0, 1}, t, samples[4 * 4 * 3];
    float rgb[4 * 4 * 3];
    mprt_trace_ray rays[256];
    mprt_trace_visit visits[1024];
    size_t need, nr, nv;
    char buf[4096];
    CHECK(mprt_grid_create(s, 2, 2, 2, 0, &g) == MPRT_OK);
    s->prims[1].kind = BAD_KIND; /* the polygon */
    CHECK(mprt_grid_create(s, 2, 2, 2, 0, &bad) == MPRT_ERR_STATE);
    CHECK_MSG(names_bad_prim(mprt_grid_errmsg(bad)), "%s", mprt_grid_errmsg(bad));
    mprt_grid_destroy(bad);
    CHECK(mprt_scene_get_info(s, &info) == MPRT_ERR_STATE);
    CHECK(mprt_scene_get_prims(s, kind, words, mat, 3) == MPRT_ERR_STATE);
    CHECK(mprt_scene_write_nff(s, buf, sizeof buf, &need) == MPRT_ERR_STATE);
    /* The grid built before: IC meets the primitive */
    CHECK(mprt_grid_intersect(g, 1, o, dir, &t, &prim, NULL) == MPRT_ERR_STATE);
    CHECK_MSG(names_bad_prim(mprt_grid_errmsg(g)), "%s", mprt_grid_errmsg(g));
    mprt_render_desc_init(&d);
    d.width = d.height = 4;
    d.tile = 4;
    CHECK(mprt_grid_render(g, &d, rgb, sizeof rgb / sizeof *rgb, NULL) == MPRT_ERR_STATE);
    CHECK_MSG(names_bad_prim(mprt_grid_errmsg(g)), "%s", mprt_grid_errmsg(g));
    CHECK(mprt_grid_trace_tile(g, &d, 0, samples, 48, rays, 256, &nr, visits, 1024, &nv, NULL) == MPRT_ERR_STATE);
    CHECK_MSG(names_bad_prim(mprt_grid_errmsg(g)), "%s", mprt_grid_errmsg(g));
    s->prims[1].kind = MPRT_POLYGON;
    CHECK(mprt_grid_render(g, &d, rgb, sizeof rgb / sizeof *rgb, NULL) == MPRT_OK);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_a_scene_with_grids_refuses_every_change);
    RUN(test_a_failed_grid_does_not_lock_the_scene);
    RUN(test_rollback_restores_the_marked_scene);
    RUN(test_a_dropped_polygon_leaves_the_error_message);
    RUN(test_an_unknown_kind_fails_loudly);
    return CHECK_DONE();
}
