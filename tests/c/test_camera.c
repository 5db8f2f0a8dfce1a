/* test_camera.c: the render queries a caller uses instead of re-deriving the
 * renderer's rules: resolved descriptions, tile rectangles, eye rays and
 * pixels from samples, each checked against what a render or a trace does. */
#include "check.h"
#include "mprt.h"

#include <stdlib.h>
#include <string.h>

#define PI 3.141592653589793
#define VIEW_W 40
#define VIEW_H 30

static mprt_scene *balls;
static mprt_grid *grid;

static void desc_for(mprt_render_desc *d, int rules, int w, int h, int tile)
{
    mprt_render_desc_init(d);
    d->rules = rules;
    d->width = w;
    d->height = h;
    d->tile = tile;
}

static void test_resolve_desc_takes_zeros_from_the_view_and_the_rules(void)
{
    mprt_render_desc d, r;
    mprt_render_desc_init(&d);
    d.width = 0;
    d.height = 0;
    d.threads = 0;
    d.tile = 0;
    CHECK(mprt_grid_resolve_desc(grid, &d, &r) == MPRT_OK);
    CHECK(r.width == VIEW_W && r.height == VIEW_H);
    CHECK(r.max_depth == 64); /* paper rules: the 3MPRT tree depth */
    CHECK(r.threads == 1);
    CHECK(r.tile == 16);
    CHECK(r.threshold == d.threshold && r.ambient == d.ambient && r.mailbox == d.mailbox);
    d.rules = MPRT_RULES_SPD;
    CHECK(mprt_grid_resolve_desc(grid, &d, &r) == MPRT_OK);
    CHECK(r.max_depth == 5); /* the SPD test procedure's depth */
}

static void test_resolve_desc_keeps_given_values_and_may_alias(void)
{
    mprt_render_desc d;
    desc_for(&d, MPRT_RULES_SPD, 7, 9, 3);
    d.max_depth = 11;
    d.threads = 3;
    CHECK(mprt_grid_resolve_desc(grid, &d, &d) == MPRT_OK);
    CHECK(d.width == 7 && d.height == 9 && d.tile == 3 && d.max_depth == 11 && d.threads == 3);
    CHECK(d.rules == MPRT_RULES_SPD);
}

/* Each bad field fails resolve and render alike, with a message naming it. */
static void test_resolve_desc_rejects_what_render_rejects(void)
{
    static const char *const field[] = {"resolution", "rule set", "threshold", "ambient", "max_depth", "threads"};
    enum { NCASES = 6 };
    float rgb[3 * 4 * 4];
    int k;
    for (k = 0; k < NCASES; k++) {
        mprt_render_desc d, r;
        char msg[512];
        desc_for(&d, MPRT_RULES_PAPER, 4, 4, 16);
        if (k == 0) d.width = -1;
        if (k == 1) d.rules = MPRT_RULES_PAPER1992 + 1;
        if (k == 2) d.threshold = 1;
        if (k == 3) d.ambient = -0.5;
        if (k == 4) d.max_depth = 256;
        if (k == 5) d.threads = 65;
        CHECK_MSG(mprt_grid_resolve_desc(grid, &d, &r) == MPRT_ERR_INVALID_ARG, "case %s", field[k]);
        CHECK_MSG(strstr(mprt_grid_errmsg(grid), field[k]) != NULL, "'%s' lacks '%s'", mprt_grid_errmsg(grid),
                  field[k]);
        strcpy(msg, mprt_grid_errmsg(grid));
        CHECK(mprt_grid_render(grid, &d, rgb, sizeof rgb / sizeof *rgb, NULL) == MPRT_ERR_INVALID_ARG);
        CHECK_MSG(strcmp(msg, mprt_grid_errmsg(grid)) == 0, "'%s' vs '%s'", msg, mprt_grid_errmsg(grid));
    }
}

/* The rectangles of all tiles cover every sample exactly once. */
static void test_tile_rects_cover_the_samples_once(void)
{
    static const int sizes[][3] = {{5, 5, 16}, {17, 9, 4}, {24, 24, 5}, {1, 1, 1}, {9, 13, 1000000000}};
    int c, rules;
    for (c = 0; c < 5; c++)
        for (rules = MPRT_RULES_PAPER; rules <= MPRT_RULES_SPD; rules++) {
            mprt_render_desc d;
            int sw, sh, tx, ty, t, x, y, rect[4], bad = 0;
            int *hits;
            desc_for(&d, rules, sizes[c][0], sizes[c][1], sizes[c][2]);
            CHECK(mprt_grid_tiling(grid, &d, &sw, &sh, &tx, &ty) == MPRT_OK);
            CHECK(sw == sizes[c][0] + rules && sh == sizes[c][1] + rules);
            hits = calloc((size_t)(sw * sh), sizeof *hits);
            for (t = 0; t < tx * ty; t++) {
                CHECK(mprt_grid_tile_rect(grid, &d, t, rect) == MPRT_OK);
                CHECK(rect[0] < rect[2] && rect[1] < rect[3]);
                CHECK(rect[2] - rect[0] <= sizes[c][2] && rect[3] - rect[1] <= sizes[c][2]);
                for (y = rect[1]; y < rect[3]; y++)
                    for (x = rect[0]; x < rect[2]; x++) hits[y * sw + x]++;
            }
            for (t = 0; t < sw * sh; t++) bad += hits[t] != 1;
            CHECK_MSG(bad == 0, "case %d rules %d: %d samples not covered once", c, rules, bad);
            free(hits);
            CHECK(mprt_grid_tile_rect(grid, &d, tx * ty, rect) == MPRT_ERR_INVALID_ARG);
            CHECK(strstr(mprt_grid_errmsg(grid), "tile") != NULL);
            CHECK(mprt_grid_tile_rect(grid, &d, -1, rect) == MPRT_ERR_INVALID_ARG);
        }
}

enum { CAP_RAYS = 1 << 15, CAP_VISITS = 1 << 18, IMG = 12, TILE = 5 };

/* Trace every tile of d into samples (samples_w*samples_h*3); calls back
 * per tile with its records. */
typedef void (*tile_fn)(const mprt_render_desc *d, const int rect[4], const mprt_trace_ray *rays, size_t nrays,
                        const mprt_trace_visit *visits, size_t nvisits);
static void trace_all(const mprt_render_desc *d, double *samples, tile_fn fn)
{
    mprt_trace_ray *rays = malloc(CAP_RAYS * sizeof *rays);
    mprt_trace_visit *visits = malloc(CAP_VISITS * sizeof *visits);
    double tile_samples[TILE * TILE * 3];
    int sw, sh, tx, ty, t, rect[4], x, y, k;
    size_t nr, nv;
    CHECK(mprt_grid_tiling(grid, d, &sw, &sh, &tx, &ty) == MPRT_OK);
    for (t = 0; t < tx * ty; t++) {
        int st = mprt_grid_trace_tile(grid, d, t, tile_samples, TILE * TILE * 3, rays, CAP_RAYS, &nr, visits,
                                      CAP_VISITS, &nv, NULL);
        CHECK_MSG(st == MPRT_OK, "%s", mprt_grid_errmsg(grid));
        if (st != MPRT_OK) break;
        CHECK(mprt_grid_tile_rect(grid, d, t, rect) == MPRT_OK);
        for (y = rect[1]; y < rect[3]; y++)
            for (x = rect[0]; x < rect[2]; x++)
                for (k = 0; k < 3; k++)
                    samples[3 * (y * sw + x) + k] =
                        tile_samples[3 * ((y - rect[1]) * (rect[2] - rect[0]) + x - rect[0]) + k];
        if (fn) fn(d, rect, rays, nr, visits, nv);
    }
    free(rays);
    free(visits);
}

/* A tile's primary rays are its rectangle's samples, row by row. */
static void check_primaries_fill_rect(const mprt_render_desc *d, const int rect[4], const mprt_trace_ray *rays,
                                      size_t nrays, const mprt_trace_visit *visits, size_t nvisits)
{
    int sw, x = rect[0], y = rect[1], done = 0;
    size_t i;
    (void)visits;
    (void)nvisits;
    CHECK(mprt_grid_tiling(grid, d, &sw, NULL, NULL, NULL) == MPRT_OK);
    for (i = 0; i < nrays; i++) {
        if (rays[i].kind != MPRT_RAY_PRIMARY) continue;
        CHECK_MSG(!done && rays[i].pixel == y * sw + x, "ray %zu: sample %d, expected %d", i, (int)rays[i].pixel,
                  y * sw + x);
        if (++x == rect[2]) {
            x = rect[0];
            done = ++y == rect[3];
        }
    }
    CHECK(done);
}

static void test_tile_rect_holds_the_eye_rays_of_its_trace(void)
{
    mprt_render_desc d;
    double *samples = malloc((IMG + 1) * (IMG + 1) * 3 * sizeof *samples);
    int rules;
    for (rules = MPRT_RULES_PAPER; rules <= MPRT_RULES_SPD; rules++) {
        desc_for(&d, rules, IMG, IMG - 1, TILE);
        trace_all(&d, samples, check_primaries_fill_rect);
    }
    free(samples);
}

/* The first hit of each traced eye ray is the hit of the camera ray. */
static void check_eye_ray_hits(const mprt_render_desc *d, const int rect[4], const mprt_trace_ray *rays,
                               size_t nrays, const mprt_trace_visit *visits, size_t nvisits)
{
    size_t i, v = 0;
    (void)rect;
    for (i = 0; i < nrays; i++) {
        double o[3], dir[3], t;
        int32_t traced = -1, prim;
        if (rays[i].kind != MPRT_RAY_PRIMARY) continue;
        while (v < nvisits && visits[v].ray != rays[i].id) v++;
        for (; v < nvisits && visits[v].ray == rays[i].id; v++)
            if (visits[v].outcome == MPRT_OUT_HIT || visits[v].outcome == MPRT_OUT_LATE_HIT) traced = visits[v].prim;
        CHECK(mprt_grid_camera_rays(grid, d, (size_t)rays[i].pixel, 1, o, dir) == MPRT_OK);
        CHECK(mprt_grid_intersect(grid, 1, o, dir, &t, &prim, NULL) == MPRT_OK);
        CHECK_MSG(prim == traced, "sample %d: camera ray hits %d, traced eye ray %d", (int)rays[i].pixel, (int)prim,
                  (int)traced);
    }
}

static void test_camera_rays_hit_what_the_traced_eye_rays_hit(void)
{
    mprt_render_desc d;
    double *samples = malloc((IMG + 1) * (IMG + 1) * 3 * sizeof *samples);
    int rules;
    for (rules = MPRT_RULES_PAPER; rules <= MPRT_RULES_SPD; rules++) {
        desc_for(&d, rules, IMG, IMG, TILE);
        trace_all(&d, samples, check_eye_ray_hits);
    }
    free(samples);
}

static double angle_between(const double *a, const double *b)
{
    double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return acos(dot > 1 ? 1 : dot) * 180 / PI;
}

/* NFF's angle spans the centres of the top and bottom rows; pixel corners
 * lie half a pixel further out. */
static void test_camera_rays_span_the_view_angle(void)
{
    mprt_scene_info info;
    mprt_render_desc d;
    double o[3 * 3], dir[3 * 3], eye[3], len = 0, half;
    int w = 9, h = 7, k, mid = 4;
    CHECK(mprt_scene_get_info(balls, &info) == MPRT_OK);
    for (k = 0; k < 3; k++) len += (info.at[k] - info.from[k]) * (info.at[k] - info.from[k]);
    for (k = 0; k < 3; k++) eye[k] = (info.at[k] - info.from[k]) / sqrt(len);
    desc_for(&d, MPRT_RULES_PAPER, w, h, 16);
    CHECK(mprt_grid_camera_rays(grid, &d, (size_t)(0 * w + mid), 1, o, dir) == MPRT_OK);
    CHECK(mprt_grid_camera_rays(grid, &d, (size_t)((h - 1) * w + mid), 1, o + 3, dir + 3) == MPRT_OK);
    CHECK(mprt_grid_camera_rays(grid, &d, (size_t)(3 * w + mid), 1, o + 6, dir + 6) == MPRT_OK);
    CHECK_NEAR(angle_between(dir, dir + 3), info.angle, 1e-5);
    CHECK_NEAR(angle_between(dir + 6, eye), 0, 1e-5); /* the centre sample looks at 'at' */
    for (k = 0; k < 9; k++) CHECK(o[k] == info.from[k % 3]);
    for (k = 0; k < 3; k++) CHECK_NEAR(dir[3 * k] * dir[3 * k] + dir[3 * k + 1] * dir[3 * k + 1] +
                                       dir[3 * k + 2] * dir[3 * k + 2], 1, 1e-6);
    /* SPD rules: samples w+1 by h+1; top and bottom corner rows span h pixels */
    desc_for(&d, MPRT_RULES_SPD, w - 1, h, 16);
    CHECK(mprt_grid_camera_rays(grid, &d, (size_t)mid, 1, o, dir) == MPRT_OK);
    CHECK(mprt_grid_camera_rays(grid, &d, (size_t)(h * w + mid), 1, o + 3, dir + 3) == MPRT_OK);
    half = atan(tan(info.angle * PI / 360) * h / (h - 1)) * 180 / PI;
    CHECK_NEAR(angle_between(dir, dir + 3), 2 * half, 1e-5);
}

static void test_camera_rays_refuse_samples_outside_the_image(void)
{
    mprt_render_desc d;
    double o[6], dir[6];
    desc_for(&d, MPRT_RULES_PAPER, 4, 3, 16);
    CHECK(mprt_grid_camera_rays(grid, &d, 10, 2, o, dir) == MPRT_OK);
    CHECK(mprt_grid_camera_rays(grid, &d, 11, 2, o, dir) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_grid_errmsg(grid), "0..11") != NULL);
    CHECK(mprt_grid_camera_rays(grid, &d, (size_t)-1, 2, o, dir) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_grid_camera_rays(grid, &d, 0, 1, NULL, dir) == MPRT_ERR_INVALID_ARG);
}

/* Traced samples made into pixels are the rendered image, bit for bit. */
static void test_samples_to_image_equals_the_render(void)
{
    mprt_render_desc d;
    double *samples = malloc((IMG + 1) * (IMG + 1) * 3 * sizeof *samples);
    float a[IMG * IMG * 3], b[IMG * IMG * 3];
    int rules, sw, sh;
    for (rules = MPRT_RULES_PAPER; rules <= MPRT_RULES_SPD; rules++) {
        desc_for(&d, rules, IMG, IMG, TILE);
        trace_all(&d, samples, NULL);
        CHECK(mprt_grid_tiling(grid, &d, &sw, &sh, NULL, NULL) == MPRT_OK);
        CHECK(mprt_samples_to_image(rules, sw, sh, samples, a, IMG * IMG * 3) == MPRT_OK);
        CHECK(mprt_grid_render(grid, &d, b, IMG * IMG * 3, NULL) == MPRT_OK);
        CHECK_MSG(memcmp(a, b, sizeof a) == 0, "rules %d", rules);
    }
    free(samples);
}

static void test_samples_to_image_means_four_corners_under_spd_rules(void)
{
    /* 3 x 2 corner samples make 2 x 1 pixels; channel k of corner i is i + 10 k */
    double s[3 * 2 * 3];
    float rgb[2 * 3], big[3 * 2 * 3];
    int i, k;
    for (i = 0; i < 6; i++)
        for (k = 0; k < 3; k++) s[3 * i + k] = i + 10 * k;
    CHECK(mprt_samples_to_image(MPRT_RULES_SPD, 3, 2, s, rgb, 6) == MPRT_OK);
    for (k = 0; k < 3; k++) {
        CHECK(rgb[k] == (float)(0.25 * ((0 + 1 + 3 + 4) + 40 * k)));
        CHECK(rgb[3 + k] == (float)(0.25 * ((1 + 2 + 4 + 5) + 40 * k)));
    }
    CHECK(mprt_samples_to_image(MPRT_RULES_PAPER, 3, 2, s, big, 18) == MPRT_OK);
    for (i = 0; i < 18; i++) CHECK(big[i] == (float)s[i]);
    CHECK(mprt_samples_to_image(MPRT_RULES_SPD, 3, 2, s, rgb, 5) == MPRT_ERR_CAPACITY);
    CHECK(mprt_samples_to_image(MPRT_RULES_PAPER, 3, 2, s, big, 17) == MPRT_ERR_CAPACITY);
    CHECK(mprt_samples_to_image(MPRT_RULES_PAPER1992 + 1, 3, 2, s, rgb, 6) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_samples_to_image(MPRT_RULES_SPD, 1, 2, s, rgb, 6) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_samples_to_image(MPRT_RULES_PAPER, 0, 2, s, rgb, 6) == MPRT_ERR_INVALID_ARG);
}

int main(void)
{
    static const double from[3] = {2.1, 1.3, 1.7}, at[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    mprt_scene_create(&balls);
    mprt_scene_spd(balls, "balls", 1);
    mprt_scene_set_view(balls, from, at, up, 45, 0.01, VIEW_W, VIEW_H);
    if (mprt_grid_create(balls, 6, 6, 6, 0, &grid) != MPRT_OK) {
        fprintf(stderr, "grid: %s\n", mprt_grid_errmsg(grid));
        return 1;
    }
    RUN(test_resolve_desc_takes_zeros_from_the_view_and_the_rules);
    RUN(test_resolve_desc_keeps_given_values_and_may_alias);
    RUN(test_resolve_desc_rejects_what_render_rejects);
    RUN(test_tile_rects_cover_the_samples_once);
    RUN(test_tile_rect_holds_the_eye_rays_of_its_trace);
    RUN(test_camera_rays_hit_what_the_traced_eye_rays_hit);
    RUN(test_camera_rays_span_the_view_angle);
    RUN(test_camera_rays_refuse_samples_outside_the_image);
    RUN(test_samples_to_image_equals_the_render);
    RUN(test_samples_to_image_means_four_corners_under_spd_rules);
    mprt_grid_destroy(grid);
    mprt_scene_destroy(balls);
    return CHECK_DONE();
}
