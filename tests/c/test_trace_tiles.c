/* test_trace_tiles.c: mprt_grid_trace_tiles writes the records of a run of
 * tiles in place, numbered on from first_ray, exactly as the tiles traced
 * one by one and renumbered; it stops before a tile that does not fit what
 * is left (and the caller resumes with the tiles left), refuses a first tile
 * that does not fit with the sizes it needs, and bad tile numbers. */
#include "check.h"
#include "mprt.h"

#include <stdlib.h>
#include <string.h>

enum { W = 23, H = 17, TILE = 5, CAP_RAYS = 1 << 16, CAP_VISITS = 1 << 19, FIRST = 1000 };

typedef struct {
    mprt_trace_ray *rays;
    mprt_trace_visit *visits;
    size_t nrays, nvisits;
    double *samples; /* the whole sample image */
} records;

static void records_init(records *r, size_t nsamples)
{
    r->rays = malloc(CAP_RAYS * sizeof *r->rays);
    r->visits = malloc(CAP_VISITS * sizeof *r->visits);
    r->samples = calloc(nsamples * 3, sizeof *r->samples);
    r->nrays = r->nvisits = 0;
}

static void records_free(records *r)
{
    free(r->rays);
    free(r->visits);
    free(r->samples);
}

/* The reference: each tile by mprt_grid_trace_tile, renumbered from first by hand. */
static void one_by_one(mprt_grid *g, const mprt_render_desc *d, const int *tiles, int ntiles, int sw, records *out)
{
    double tile_samples[TILE * TILE * 3];
    int t;
    for (t = 0; t < ntiles; t++) {
        mprt_trace_ray *r = out->rays + out->nrays;
        mprt_trace_visit *v = out->visits + out->nvisits;
        size_t nr, nv, i;
        int rect[4], x, y;
        int64_t offset = FIRST + (int64_t)out->nrays;
        CHECK(mprt_grid_trace_tile(g, d, tiles[t], tile_samples, sizeof tile_samples / sizeof *tile_samples, r,
                                   CAP_RAYS - out->nrays, &nr, v, CAP_VISITS - out->nvisits, &nv, NULL) == MPRT_OK);
        for (i = 0; i < nr; i++) {
            r[i].id += offset;
            if (r[i].parent >= 0) r[i].parent += offset;
        }
        for (i = 0; i < nv; i++) v[i].ray += offset;
        out->nrays += nr;
        out->nvisits += nv;
        CHECK(mprt_grid_tile_rect(g, d, tiles[t], rect) == MPRT_OK);
        for (y = rect[1]; y < rect[3]; y++)
            for (x = rect[0]; x < rect[2]; x++)
                memcpy(out->samples + 3 * ((size_t)y * (size_t)sw + (size_t)x),
                       tile_samples + 3 * ((size_t)(y - rect[1]) * (size_t)(rect[2] - rect[0]) + (size_t)(x - rect[0])),
                       3 * sizeof(double));
    }
}

static int same_records(const records *a, const records *b, size_t nsamples)
{
    return a->nrays == b->nrays && a->nvisits == b->nvisits &&
           memcmp(a->rays, b->rays, a->nrays * sizeof *a->rays) == 0 &&
           memcmp(a->visits, b->visits, a->nvisits * sizeof *a->visits) == 0 &&
           memcmp(a->samples, b->samples, nsamples * 3 * sizeof(double)) == 0;
}

static void test_tiles_in_one_call_match_tiles_one_by_one(void)
{
    static const char *const names[] = {"balls", "rings", "tree"};
    int n, rules;
    for (n = 0; n < 3; n++) {
        mprt_scene *s;
        mprt_grid *g;
        mprt_scene_create(&s);
        CHECK(mprt_scene_spd(s, names[n], 1) == MPRT_OK);
        CHECK(mprt_grid_create(s, 6, 7, 5, 0, &g) == MPRT_OK);
        for (rules = MPRT_RULES_PAPER; rules <= MPRT_RULES_SPD; rules++) {
            mprt_render_desc d;
            mprt_counters all, part;
            records ref, got, resumed;
            int sw, sh, tx, ty, t, *tiles;
            size_t nsamples, done, nr, nv, calls = 0;
            mprt_render_desc_init(&d);
            d.width = W;
            d.height = H;
            d.tile = TILE;
            d.rules = rules;
            CHECK(mprt_grid_tiling(g, &d, &sw, &sh, &tx, &ty) == MPRT_OK);
            nsamples = (size_t)sw * (size_t)sh;
            tiles = malloc((size_t)(tx * ty) * sizeof *tiles);
            for (t = 0; t < tx * ty; t++) tiles[t] = (t * 7) % (tx * ty); /* any order */
            records_init(&ref, nsamples);
            records_init(&got, nsamples);
            records_init(&resumed, nsamples);
            one_by_one(g, &d, tiles, tx * ty, sw, &ref);
            /* all in one call */
            CHECK(mprt_grid_trace_tiles(g, &d, tiles, (size_t)(tx * ty), got.samples, nsamples * 3, FIRST, got.rays,
                                        CAP_RAYS, &got.nrays, got.visits, CAP_VISITS, &got.nvisits, &done,
                                        &all) == MPRT_OK);
            CHECK(done == (size_t)(tx * ty));
            CHECK_MSG(same_records(&ref, &got, nsamples), "%s rules %d: one call differs from tile by tile",
                      names[n], rules);
            CHECK(all.eye_rays == (long long)nsamples && all.os_visits + all.ic_visits + all.sc_visits ==
                                                             (long long)got.nvisits);
            /* in a buffer too small for all: calls resume where the last stopped */
            for (done = 0; done < (size_t)(tx * ty); calls++) {
                size_t k;
                int st = mprt_grid_trace_tiles(g, &d, tiles + done, (size_t)(tx * ty) - done, resumed.samples,
                                               nsamples * 3, FIRST + (int64_t)resumed.nrays,
                                               resumed.rays + resumed.nrays, ref.nrays / 5 + 64, &nr,
                                               resumed.visits + resumed.nvisits, ref.nvisits / 5 + 256, &nv, &k, &part);
                CHECK_MSG(st == MPRT_OK && k > 0, "%s rules %d: %s", names[n], rules, mprt_grid_errmsg(g));
                if (st != MPRT_OK || k == 0) break;
                CHECK(part.eye_rays > 0 && part.os_visits + part.ic_visits + part.sc_visits == (long long)nv);
                resumed.nrays += nr;
                resumed.nvisits += nv;
                done += k;
            }
            CHECK(calls > 5);
            CHECK_MSG(same_records(&ref, &resumed, nsamples), "%s rules %d: resumed calls differ", names[n], rules);
            records_free(&ref);
            records_free(&got);
            records_free(&resumed);
            free(tiles);
        }
        mprt_grid_destroy(g);
        mprt_scene_destroy(s);
    }
}

static void test_a_first_tile_that_does_not_fit_gives_its_sizes(void)
{
    mprt_scene *s;
    mprt_grid *g;
    mprt_render_desc d;
    records r;
    int tiles[2] = {3, 4}, sw, sh;
    size_t nr, nv, done, need_r, need_v;
    double one[TILE * TILE * 3];
    mprt_scene_create(&s);
    CHECK(mprt_scene_spd(s, "balls", 1) == MPRT_OK);
    CHECK(mprt_grid_create(s, 4, 4, 4, 0, &g) == MPRT_OK);
    mprt_render_desc_init(&d);
    d.width = W;
    d.height = H;
    d.tile = TILE;
    CHECK(mprt_grid_tiling(g, &d, &sw, &sh, NULL, NULL) == MPRT_OK);
    records_init(&r, (size_t)sw * (size_t)sh);
    CHECK(mprt_grid_trace_tile(g, &d, 3, one, sizeof one / sizeof *one, r.rays, CAP_RAYS, &need_r, r.visits,
                               CAP_VISITS, &need_v, NULL) == MPRT_OK);
    CHECK(mprt_grid_trace_tiles(g, &d, tiles, 2, r.samples, (size_t)sw * (size_t)sh * 3, 0, r.rays, need_r, &nr,
                                r.visits, need_v - 1, &nv, &done, NULL) == MPRT_ERR_CAPACITY);
    CHECK(done == 0 && nr == need_r && nv == need_v);
    /* exactly the first tile's size: it is recorded, the second is not */
    CHECK(mprt_grid_trace_tiles(g, &d, tiles, 2, r.samples, (size_t)sw * (size_t)sh * 3, 0, r.rays, need_r, &nr,
                                r.visits, need_v, &nv, &done, NULL) == MPRT_OK);
    CHECK(done == 1 && nr == need_r && nv == need_v);
    tiles[1] = 10000;
    CHECK(mprt_grid_trace_tiles(g, &d, tiles, 2, r.samples, (size_t)sw * (size_t)sh * 3, 0, r.rays, CAP_RAYS, &nr,
                                r.visits, CAP_VISITS, &nv, &done, NULL) == MPRT_ERR_INVALID_ARG);
    CHECK_MSG(strstr(mprt_grid_errmsg(g), "tiles[1] = 10000") != NULL, "%s", mprt_grid_errmsg(g));
    CHECK(mprt_grid_trace_tiles(g, &d, tiles, 1, r.samples, 3, 0, r.rays, CAP_RAYS, &nr, r.visits, CAP_VISITS, &nv,
                                &done, NULL) == MPRT_ERR_CAPACITY); /* the sample image is too small */
    CHECK(mprt_grid_trace_tiles(g, &d, tiles, 1, r.samples, (size_t)sw * (size_t)sh * 3, -1, r.rays, CAP_RAYS, &nr,
                                r.visits, CAP_VISITS, &nv, &done, NULL) == MPRT_ERR_INVALID_ARG);
    records_free(&r);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_tiles_in_one_call_match_tiles_one_by_one);
    RUN(test_a_first_tile_that_does_not_fit_gives_its_sizes);
    return CHECK_DONE();
}
