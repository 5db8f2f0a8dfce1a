/* test_workload.c: what a scene may hold and how much work a sample may
 * make: material weights in range (a hit's child never carries more than
 * its parent), clear messages for a scene whose primitives were all
 * dropped and for a directory given as a scene, and the ray budget that
 * stops a ray tree that does not end, whatever the thread count. */
#include "check.h"
#include "mprt_internal.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

/* Parse NUL-terminated text named t.nff into a new scene. OUT: status. */
static mprt_scene *parse_text(const char *text, int *status)
{
    mprt_scene *s = NULL;
    mprt_scene_create(&s);
    *status = mprt_scene_parse_nff(s, text, strlen(text), "t.nff");
    return s;
}

/* Parse text that must be valid. */
static mprt_scene *parse_ok(const char *text)
{
    int st;
    mprt_scene *s = parse_text(text, &st);
    CHECK_MSG(st == MPRT_OK, "status %d: %s", st, mprt_scene_errmsg(s));
    return s;
}

/* The message of a parse that must fail holds want. */
static void check_parse_fails(const char *text, int status, const char *want)
{
    int st;
    mprt_scene *s = parse_text(text, &st);
    CHECK_MSG(st == status, "'%s': status %d, expected %d", text, st, status);
    CHECK_MSG(strstr(mprt_scene_errmsg(s), want) != NULL, "'%s': message '%s' lacks '%s'", text,
              mprt_scene_errmsg(s), want);
    CHECK(s->nprims == 0 && s->nmaterials == 0 && s->nlights == 0);
    mprt_scene_destroy(s);
}

static void test_material_weights_out_of_range_are_rejected_with_the_line(void)
{
    /* An input a fuzzer found hanging the tracer (Ks 5 and T 9) */
    check_parse_fails("f 1 1 1 1 5 5 9 5\ns 0 0 0 1\n", MPRT_ERR_PARSE,
                      "t.nff:1: material: Kd 1, Ks 5 and T 9 must each be in [0, 1]");
    /* (Ks + T = 1.4, the other, is read since issue 20: see test_nff_found.c) */
    check_parse_fails("f 1 1 1 1.5 0 0 0 1\n", MPRT_ERR_PARSE, "t.nff:1: material: Kd 1.5");
    check_parse_fails("s 0 0 0 1\nf 1 1 1 0.5 0 0 -0.25 1\n", MPRT_ERR_PARSE, "t.nff:2: material:");
    check_parse_fails("f 1 1 1 0.5 0 3 0.5 0\n", MPRT_ERR_PARSE, "t.nff:1: material: index of refraction 0");
    check_parse_fails("f 1 1 1 0.5 0 -3 0 1\n", MPRT_ERR_PARSE, "t.nff:1: material: Shine -3 is negative");
}

static void test_material_weights_in_range_are_accepted(void)
{
    /* Ks + T = 1 in decimal (SPD mount's glass: 0.1 + 0.9; 0.3 + 0.7), the
     * index of refraction 0 of SPD's opaque materials, colours over 1 */
    mprt_scene *s = parse_ok("f 1 1 1 0.1 0.1 101 0.9 1.5\nf 1 1 1 0 0.3 5 0.7 1.1\nf 2 3 4 1 1 0 0 0\n"
                             "f 1 1 1 0 0 0 1 1\ns 0 0 0 1\n");
    CHECK(s->nmaterials == 4 && s->nprims == 1);
    mprt_scene_destroy(s);
}

/* A sphere of radius 1.1e301 was "hit" at t = inf (a fuzz finding): values
 * whose squares would overflow are refused. */
static void test_geometry_beyond_the_coordinate_limit_is_rejected(void)
{
    check_parse_fails("s 0 0 0 11e300\n", MPRT_ERR_PARSE, "t.nff:1: sphere: a value is NaN, infinite or over 1e");
    check_parse_fails("l 0 0 1e200\n", MPRT_ERR_PARSE, "t.nff:1: light: a position value is NaN, infinite or over");
    check_parse_fails("p 3\n0 0 0\n1 0 0\n0 -1e150 0\n", MPRT_ERR_PARSE, "polygon: a value of vertex 3 is");
    check_parse_fails("c 0 0 0 1 0 0 1e101 1\n", MPRT_ERR_PARSE, "t.nff:1: cone: a value is");
    mprt_scene_destroy(parse_ok("s 0 0 0 1e9\ns 1e9 0 0 1e-9\n"));
}

static void test_a_scene_whose_primitives_were_all_dropped_says_which(void)
{
    /* A collinear triangle: dropped with a warning, leaving no primitive */
    mprt_scene *s = parse_ok("l 0 0 5\np 3\n0 0 0\n1 0 0\n2 0 0\n");
    mprt_grid *g = NULL;
    CHECK(s->nprims == 0 && s->dropped == 1);
    CHECK(mprt_grid_create(s, 4, 4, 4, 0, &g) == MPRT_ERR_STATE);
    CHECK_MSG(g && strstr(mprt_grid_errmsg(g), "no primitives: 1 was dropped while reading it "
                                               "(t.nff:2: polygon with zero area dropped)") != NULL,
              "message '%s'", g ? mprt_grid_errmsg(g) : "(no grid)");
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);

    /* Two dropped: the count and the first */
    s = parse_ok("p 3\n0 0 0\n1 0 0\n2 0 0\npp 3\n0 0 0 0 0 1\n0 0 0 0 0 1\n1 1 1 0 0 1\n");
    g = NULL;
    CHECK(mprt_grid_create(s, 2, 2, 2, 0, &g) == MPRT_ERR_STATE);
    CHECK_MSG(g && strstr(mprt_grid_errmsg(g), "2 were dropped while reading it (the first: t.nff:1: polygon") != NULL,
              "message '%s'", g ? mprt_grid_errmsg(g) : "(no grid)");
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

static void test_a_directory_is_not_a_scene(void)
{
    mprt_scene *s;
    mprt_scene_create(&s);
    CHECK(mprt_scene_load_nff(s, ".") == MPRT_ERR_IO);
    CHECK_MSG(strcmp(mprt_scene_errmsg(s), ".: is a directory, not an NFF file") == 0, "message '%s'",
              mprt_scene_errmsg(s));
    CHECK(mprt_scene_load_nff(s, "no-such-file.nff") == MPRT_ERR_IO);
    CHECK_MSG(strstr(mprt_scene_errmsg(s), "no-such-file.nff: cannot open for reading (") != NULL, "message '%s'",
              mprt_scene_errmsg(s));
    /* A file of unknown size (a device) is read to its end: empty here */
    CHECK(mprt_scene_load_nff(s, "/dev/null") == MPRT_OK);
    CHECK(s->nprims == 0);
    mprt_scene_destroy(s);
}

/* Two spheres of glass with Ks + T = 1 and one light, seen along the axis
 * through both: near the axis both children of a hit (the reflection and
 * the refraction) hit a sphere again, so under paper rules at threshold 0
 * the tree doubles at every level down to depth 64. */
static mprt_scene *endless_scene(void)
{
    return parse_ok("v\nfrom 0 0 -3\nat 0 0 0\nup 0 1 0\nangle 10\nhither 0\nresolution 8 8\n"
                    "l 0 0 10\nf 1 1 1 0.1 0.1 50 0.9 5.5\ns 0 0 0 1\ns 0 0 3 1\n");
}

static void test_a_tree_that_does_not_end_fails_at_the_budget(void)
{
    static const int threads[3] = {1, 2, 3};
    mprt_scene *s = endless_scene();
    mprt_grid *g = NULL;
    mprt_render_desc d;
    float rgb[8 * 8 * 3];
    char first[MPRT__ERRMSG];
    clock_t t0 = clock();
    int i;
    CHECK(mprt_grid_create(s, 4, 4, 4, 0, &g) == MPRT_OK);
    mprt_render_desc_init(&d);
    d.threshold = 0;
    d.tile = 3;
    for (i = 0; i < 3; i++) {
        d.threads = threads[i];
        CHECK(mprt_grid_render(g, &d, rgb, 8 * 8 * 3, NULL) == MPRT_ERR_LIMIT);
        /* the same sample is named with any thread count */
        if (i == 0) snprintf(first, sizeof first, "%s", mprt_grid_errmsg(g));
        else CHECK_MSG(strcmp(first, mprt_grid_errmsg(g)) == 0, "'%s' vs '%s'", first, mprt_grid_errmsg(g));
    }
    CHECK_MSG(strstr(first, "render: sample (") && strstr(first, "needs more than 65536 rays (max_rays"),
              "message '%s'", first);
    /* the default threshold ends every tree of this scene */
    d.threshold = 1.0 / 512;
    CHECK(mprt_grid_render(g, &d, rgb, 8 * 8 * 3, NULL) == MPRT_OK);
    CHECK_MSG((double)(clock() - t0) / CLOCKS_PER_SEC < 10, "the budget took %.1f s to stop the render",
              (double)(clock() - t0) / CLOCKS_PER_SEC);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

static void test_the_budget_is_a_parameter(void)
{
    mprt_scene *s;
    mprt_grid *g = NULL;
    mprt_render_desc d;
    mprt_counters c;
    float rgb[16 * 16 * 3], ref[16 * 16 * 3];
    double samples[16 * 16 * 3];
    mprt_trace_ray rays[4096];
    mprt_trace_visit visits[1 << 14];
    size_t nr, nv;
    mprt_scene_create(&s);
    CHECK(mprt_scene_spd(s, "balls", 1) == MPRT_OK);
    CHECK(mprt_grid_create(s, 6, 6, 6, 0, &g) == MPRT_OK);
    mprt_render_desc_init(&d);
    d.width = d.height = 16;
    CHECK(mprt_grid_render(g, &d, ref, sizeof ref / sizeof *ref, &c) == MPRT_OK);
    /* balls' eye rays all hit and make 3 shadow rays at least: 2 rays are too few */
    d.max_rays = 2;
    CHECK(mprt_grid_render(g, &d, rgb, sizeof rgb / sizeof *rgb, NULL) == MPRT_ERR_LIMIT);
    CHECK_MSG(strstr(mprt_grid_errmsg(g), "render: sample (0, 0) needs more than 2 rays"), "message '%s'",
              mprt_grid_errmsg(g));
    /* a trace fails the same way (not as a buffer too small) */
    d.tile = 16;
    CHECK(mprt_grid_trace_tile(g, &d, 0, samples, sizeof samples / sizeof *samples, rays, 4096, &nr, visits, 1 << 14,
                               &nv, NULL) == MPRT_ERR_LIMIT);
    CHECK_MSG(strstr(mprt_grid_errmsg(g), "trace: sample (0, 0) needs more than 2 rays"), "message '%s'",
              mprt_grid_errmsg(g));
    /* a budget the scene fits changes nothing */
    d.max_rays = 1000;
    CHECK(mprt_grid_render(g, &d, rgb, sizeof rgb / sizeof *rgb, NULL) == MPRT_OK);
    CHECK(memcmp(rgb, ref, sizeof rgb) == 0);
    d.max_rays = -1;
    CHECK(mprt_grid_render(g, &d, rgb, sizeof rgb / sizeof *rgb, NULL) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_grid_errmsg(g), "max_rays -1 is negative") != NULL);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_material_weights_out_of_range_are_rejected_with_the_line);
    RUN(test_material_weights_in_range_are_accepted);
    RUN(test_geometry_beyond_the_coordinate_limit_is_rejected);
    RUN(test_a_scene_whose_primitives_were_all_dropped_says_which);
    RUN(test_a_directory_is_not_a_scene);
    RUN(test_a_tree_that_does_not_end_fails_at_the_budget);
    RUN(test_the_budget_is_a_parameter);
    return CHECK_DONE();
}
