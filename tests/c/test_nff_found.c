/* test_nff_found.c: NFF files as they are found outside the project (issue
 * 20, item 3): the classic glass with Ks + T over 1 is read with one note per
 * file and renders to an end, the same bits for any thread count; an unknown
 * entity is an error naming it, and MPRT_NFF_SKIP_UNKNOWN reads the file
 * without it, with a note naming each entity skipped and its count. */
#include "check.h"
#include "mprt_internal.h"

#include <stdlib.h>
#include <string.h>

/* A scene in the manner of the classic glass scenes: two glass spheres
 * (f .9 .9 .9 .1 .9 50 .9 1.33: Ks + T = 1.8) over a floor, seen through one
 * another, under two lights. */
static const char GLASS[] =
    "v\nfrom 0 -6 1.5\nat 0 0 0.5\nup 0 0 1\nangle 35\nhither 0.01\nresolution 24 24\n"
    "b 0.1 0.2 0.5\nl 4 -4 8\nl -5 -2 6\n"
    "f 0.8 0.3 0.2 0.7 0.3 20 0 1\np 4\n-4 -4 0\n4 -4 0\n4 4 0\n-4 4 0\n"
    "f .9 .9 .9 .1 .9 50 .9 1.33\ns 0 0 1 1\ns 0.6 1.8 0.8 0.8\n"
    "f 1 1 1 0 0.5 10 0.9 1.5\ns -1.5 0.5 0.5 0.5\n";

static mprt_scene *parse_flags(const char *text, unsigned flags, int *status)
{
    mprt_scene *s = NULL;
    mprt_scene_create(&s);
    *status = mprt_scene_parse_nff_ex(s, text, strlen(text), "t.nff", flags);
    return s;
}

/* The number of times needle occurs in hay. */
static int occurrences(const char *hay, const char *needle)
{
    int n = 0;
    for (hay = strstr(hay, needle); hay; hay = strstr(hay + 1, needle)) n++;
    return n;
}

static void test_glass_over_one_is_read_with_one_note_per_file(void)
{
    int st;
    mprt_scene *s = parse_flags(GLASS, 0, &st);
    const char *notes = mprt_scene_notes(s);
    CHECK_MSG(st == MPRT_OK, "%s", mprt_scene_errmsg(s));
    CHECK(s->nmaterials == 3 && s->nprims == 4);
    CHECK(s->materials[1].ks == 0.9 && s->materials[1].t == 0.9); /* as written, not clamped */
    CHECK_MSG(occurrences(notes, "\n") == 1, "notes '%s'", notes);
    CHECK_MSG(strstr(notes, "t.nff:17: material: Ks 0.9 + T 0.9 = 1.8 is over 1 (2 such materials in the file)"),
              "notes '%s'", notes);
    CHECK_MSG(strstr(notes, "ray budget"), "notes '%s'", notes);
    /* a second file read into the scene adds its own note */
    CHECK(mprt_scene_parse_nff(s, "f 1 1 1 0 0.6 1 0.6 1.2\n", 24, "u.nff") == MPRT_OK);
    notes = mprt_scene_notes(s);
    CHECK_MSG(occurrences(notes, "\n") == 2 && strstr(notes, "u.nff:1: material: Ks 0.6 + T 0.6 = 1.2"),
              "notes '%s'", notes);
    mprt_scene_destroy(s);
    /* at most 1 (the margin of decimal text included): no note */
    s = parse_flags("f 1 1 1 0 0.3 5 0.7 1.1\nf 1 1 1 0.1 0.1 101 0.9 1.5\ns 0 0 0 1\n", 0, &st);
    CHECK(st == MPRT_OK && mprt_scene_notes(s)[0] == '\0');
    mprt_scene_destroy(s);
    /* each weight on its own must still be a fraction */
    s = parse_flags("f 1 1 1 0.5 1.2 5 0 1\n", 0, &st);
    CHECK(st == MPRT_ERR_PARSE && strstr(mprt_scene_errmsg(s), "t.nff:1: material: Kd 0.5, Ks 1.2 and T 0"));
    mprt_scene_destroy(s);
}

/* Render under the desc with 1, 2 and 3 threads: the same status, message,
 * image and counts each time; returns the status. */
static int render_alike(mprt_grid *g, mprt_render_desc d, mprt_counters *c)
{
    static const int threads[3] = {1, 2, 3};
    static float rgb[3][24 * 24 * 3];
    mprt_counters cs[3];
    char first[MPRT__ERRMSG];
    int st[3], i;
    for (i = 0; i < 3; i++) {
        d.threads = threads[i];
        memset(&cs[i], 0, sizeof cs[i]);
        st[i] = mprt_grid_render(g, &d, rgb[i], 24 * 24 * 3, &cs[i]);
        if (i == 0) snprintf(first, sizeof first, "%s", st[0] == MPRT_OK ? "" : mprt_grid_errmsg(g));
        CHECK(st[i] == st[0]);
        if (st[0] != MPRT_OK) {
            CHECK_MSG(strcmp(first, mprt_grid_errmsg(g)) == 0, "'%s' vs '%s'", first, mprt_grid_errmsg(g));
        } else {
            CHECK(memcmp(rgb[i], rgb[0], sizeof rgb[0]) == 0);
            CHECK(memcmp(&cs[i], &cs[0], sizeof cs[0]) == 0);
        }
    }
    *c = cs[0];
    return st[0];
}

static void test_the_classic_glass_renders_to_an_end_and_the_same_bits(void)
{
    int st;
    mprt_scene *s = parse_flags(GLASS, 0, &st);
    mprt_grid *g = NULL;
    mprt_render_desc d;
    mprt_counters c;
    CHECK(st == MPRT_OK);
    CHECK(mprt_grid_create(s, 5, 5, 3, 0, &g) == MPRT_OK);
    /* SPD rules (depth 5, the rules NFF files were made for): every tree ends */
    mprt_render_desc_init(&d);
    d.rules = MPRT_RULES_SPD;
    d.tile = 5;
    CHECK_MSG(render_alike(g, d, &c) == MPRT_OK, "%s", mprt_grid_errmsg(g));
    CHECK_MSG(c.reflect_rays > 24 * 24 / 4 && c.refract_rays > 24 * 24 / 4, "%lld reflect, %lld refract",
              c.reflect_rays, c.refract_rays);
    /* paper rules to depth 64 at threshold 1/512: .9 of the weight goes on
     * each way, the two glass balls face each other, and a tree outgrows the
     * budget: the render stops there, naming the same sample every time */
    d.rules = MPRT_RULES_PAPER;
    CHECK(render_alike(g, d, &c) == MPRT_ERR_LIMIT);
    CHECK_MSG(strstr(mprt_grid_errmsg(g), "needs more than 65536 rays (max_rays"), "%s", mprt_grid_errmsg(g));
    /* and with a depth limit it ends */
    d.max_depth = 12;
    CHECK_MSG(render_alike(g, d, &c) == MPRT_OK, "%s", mprt_grid_errmsg(g));
    CHECK(c.reflect_rays > 24 * 24 / 4 && c.refract_rays > 24 * 24 / 4);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

/* A file with the extension lines of other tools: fp (with its data on the
 * next lines), Q and Z. */
static const char EXTENDED[] =
    "Q 0\nl 0 0 10\nfp 2\n1 2 3\n4 5 6\nf 1 1 1 1 0 0 0 1\nZ 481\ns 0 0 0 1\nfp 0\nQ 1\nQ 2\ns 3 0 0 1\n";

static void test_an_unknown_entity_is_an_error_naming_it(void)
{
    int st;
    mprt_scene *s = parse_flags(EXTENDED, 0, &st);
    CHECK(st == MPRT_ERR_PARSE);
    CHECK_MSG(strcmp(mprt_scene_errmsg(s), "t.nff:1: unknown entity 'Q'") == 0, "'%s'", mprt_scene_errmsg(s));
    CHECK(s->nprims == 0 && s->nlights == 0 && mprt_scene_notes(s)[0] == '\0');
    mprt_scene_destroy(s);
}

static void test_skip_unknown_reads_without_them_and_counts_each(void)
{
    int st;
    mprt_scene *s = parse_flags(EXTENDED, MPRT_NFF_SKIP_UNKNOWN, &st), *plain = NULL;
    const char *notes = mprt_scene_notes(s);
    CHECK_MSG(st == MPRT_OK, "%s", mprt_scene_errmsg(s));
    CHECK(s->nprims == 2 && s->nlights == 1 && s->nmaterials == 1);
    CHECK_MSG(strstr(notes, "t.nff: 3 'Q' lines skipped (lines 1, 10, 11), with the number lines after each\n"
                            "t.nff: 2 'fp' material lines skipped (lines 3, 9), with the number lines after each: "
                            "the surfaces after them take the last 'f' material before them: the default white "
                            "diffuse material (no 'f' before) for line 3; the 'f' of line 6 for line 9\n"
                            "t.nff: 1 'Z' line skipped (line 7), with the number lines after it\n"),
              "notes '%s'", notes);
    /* the same scene as the file without those lines */
    mprt_scene_create(&plain);
    {
        static const char without[] = "l 0 0 10\nf 1 1 1 1 0 0 0 1\ns 0 0 0 1\ns 3 0 0 1\n";
        CHECK(mprt_scene_parse_nff(plain, without, sizeof without - 1, "p.nff") == MPRT_OK);
    }
    CHECK(plain->nprims == s->nprims && memcmp(plain->spheres, s->spheres, 2 * sizeof *s->spheres) == 0);
    mprt_scene_destroy(plain);
    mprt_scene_destroy(s);
    /* a number line with no unknown entity before it is still an error */
    s = parse_flags("s 0 0 0 1\n1 2 3\n", MPRT_NFF_SKIP_UNKNOWN, &st);
    CHECK(st == MPRT_ERR_PARSE && strstr(mprt_scene_errmsg(s), "t.nff:2: unknown entity '1'"));
    mprt_scene_destroy(s);
    /* a failed read puts the notes back as they were */
    s = parse_flags("Q 0\nf 1 1 1 0 .9 5 .9 1.3\ns 0 0 0 -1\n", MPRT_NFF_SKIP_UNKNOWN, &st);
    CHECK(st == MPRT_ERR_PARSE && mprt_scene_notes(s)[0] == '\0');
    mprt_scene_destroy(s);
    /* unknown flags are refused */
    s = parse_flags("s 0 0 0 1\n", 6, &st);
    CHECK(st == MPRT_ERR_INVALID_ARG && strstr(mprt_scene_errmsg(s), "unknown flags 0x6"));
    mprt_scene_destroy(s);
}

static void test_many_distinct_unknown_entities_are_counted_past_the_names(void)
{
    char text[4096];
    size_t used = 0;
    int i, st;
    mprt_scene *s;
    for (i = 0; i < 12; i++) used += (size_t)snprintf(text + used, sizeof text - used, "x%d 1\nx%d 2\n", i, i);
    s = parse_flags(text, MPRT_NFF_SKIP_UNKNOWN, &st);
    CHECK(st == MPRT_OK);
    CHECK_MSG(strstr(mprt_scene_notes(s), "t.nff: 2 'x7' lines skipped (lines 15, 16), with the number lines after "
                                          "each\nt.nff: 8 more lines of other unknown entities skipped, with their "
                                          "number lines\n"), "'%s'", mprt_scene_notes(s));
    mprt_scene_destroy(s);
}

/* A skipped material line ('fp') says which material the surfaces after it
 * take: the last 'f' before each (grouped), or the one the scene had before
 * the file; past four lines, the rest are counted. */
static void test_a_skipped_material_line_says_what_its_surfaces_take(void)
{
    int st;
    mprt_scene *s = parse_flags("f 1 1 1 1 0 0 0 1\nfp 1\nfp 2\nf 1 0 0 1 0 0 0 1\nfp 1\nfp 1\nfp 1\nfp 1\n"
                                "s 0 0 0 1\n", MPRT_NFF_SKIP_UNKNOWN, &st);
    CHECK(st == MPRT_OK);
    CHECK_MSG(strcmp(mprt_scene_notes(s), "t.nff: 6 'fp' material lines skipped (lines 2, 3, 5, 6 and 2 more), with "
                                          "the number lines after each: the surfaces after them take the last 'f' "
                                          "material before them: the 'f' of line 1 for lines 2, 3; the 'f' of line 4 "
                                          "for lines 5, 6\n") == 0, "'%s'", mprt_scene_notes(s));
    /* a second file read into the scene: before its first 'f', the scene's material */
    CHECK(mprt_scene_parse_nff_ex(s, "fp 1\ns 3 0 0 1\n", 15, "u.nff", MPRT_NFF_SKIP_UNKNOWN) == MPRT_OK);
    CHECK_MSG(strstr(mprt_scene_notes(s), "u.nff: 1 'fp' material line skipped (line 1), with the number lines after "
                                          "it: the surfaces after it take the last 'f' material before it: the "
                                          "material set before this file\n"), "'%s'", mprt_scene_notes(s));
    CHECK(s->prims[1].material == 1); /* as the note says */
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_glass_over_one_is_read_with_one_note_per_file);
    RUN(test_the_classic_glass_renders_to_an_end_and_the_same_bits);
    RUN(test_an_unknown_entity_is_an_error_naming_it);
    RUN(test_skip_unknown_reads_without_them_and_counts_each);
    RUN(test_many_distinct_unknown_entities_are_counted_past_the_names);
    RUN(test_a_skipped_material_line_says_what_its_surfaces_take);
    return CHECK_DONE();
}
