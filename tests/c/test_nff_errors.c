/* test_nff_errors.c: the NFF reader (nff.c, nff_lex.c) on bad input: a
 * message naming file, line and problem, a scene left unchanged, dropped
 * polygons, random mutations of real files, and the parse speed.  Run from
 * tests/c. */
#include "nff_check.h"

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
    for (f = 0; f < NREFS; f++) {
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
    RUN(test_bad_input);
    RUN(test_nul_byte_in_text);
    RUN(test_failed_parse_changes_nothing);
    RUN(test_zero_area_polygon_dropped);
    RUN(test_fuzz);
    RUN(test_parse_speed);
    return CHECK_DONE();
}
