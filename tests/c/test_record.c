/* test_record.c: the counters of a render are the sums over the trace
 * records of its tiles (each visit and ray is emitted once, to both), and a
 * trace refuses values its record fields cannot hold. */
#include "check.h"
#include "mprt.h"

#include <stdlib.h>
#include <string.h>

enum { W = 20, H = 18, TILE = 7, CAP_RAYS = 1 << 16, CAP_VISITS = 1 << 19 };

/* Counters rebuilt from records alone. */
static void count_records(const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits, size_t nvisits,
                          mprt_counters *c)
{
    size_t i;
    int k;
    for (i = 0; i < nrays; i++) {
        switch (rays[i].kind) {
        case MPRT_RAY_PRIMARY: c->eye_rays++; break;
        case MPRT_RAY_REFLECT: c->reflect_rays++; break;
        case MPRT_RAY_REFRACT: c->refract_rays++; break;
        case MPRT_RAY_SHADOW: c->shadow_rays++; break;
        default: CHECK_MSG(0, "ray %zu has kind %d", i, rays[i].kind);
        }
    }
    for (i = 0; i < nvisits; i++) {
        const mprt_trace_visit *v = &visits[i];
        if (v->stage == MPRT_STAGE_OS) {
            c->os_visits++;
            c->voxels_traversed += v->steps;
        } else if (v->stage == MPRT_STAGE_IC) {
            c->ic_visits++;
            for (k = 0; k < MPRT_NKINDS; k++) c->tests[k] += v->tests[k];
            c->polygon_vertices += v->vertices;
        } else {
            c->sc_visits++;
            c->suppressed_rays += v->suppressed;
        }
        if (v->outcome == MPRT_OUT_HIT || v->outcome == MPRT_OUT_BLOCKED || v->outcome == MPRT_OUT_LATE_HIT) {
            c->hits++;
            if (v->ray < (int64_t)nrays && rays[v->ray].kind == MPRT_RAY_PRIMARY) c->eye_hits++;
        }
    }
}

static void check_counts_match(mprt_grid *g, int rules, const char *what)
{
    mprt_render_desc d;
    mprt_counters rendered, from_records, from_tiles, tile;
    mprt_trace_ray *rays = malloc(CAP_RAYS * sizeof *rays);
    mprt_trace_visit *visits = malloc(CAP_VISITS * sizeof *visits);
    double samples[TILE * TILE * 3];
    float rgb[W * H * 3];
    int tx, ty, t;
    size_t nr, nv;
    mprt_render_desc_init(&d);
    d.width = W;
    d.height = H;
    d.tile = TILE;
    d.rules = rules;
    memset(&from_records, 0, sizeof from_records);
    memset(&from_tiles, 0, sizeof from_tiles);
    CHECK(mprt_grid_render(g, &d, rgb, W * H * 3, &rendered) == MPRT_OK);
    CHECK(mprt_grid_tiling(g, &d, NULL, NULL, &tx, &ty) == MPRT_OK);
    for (t = 0; t < tx * ty; t++) {
        int st = mprt_grid_trace_tile(g, &d, t, samples, TILE * TILE * 3, rays, CAP_RAYS, &nr, visits, CAP_VISITS,
                                      &nv, &tile);
        CHECK_MSG(st == MPRT_OK, "%s tile %d: %s", what, t, mprt_grid_errmsg(g));
        if (st != MPRT_OK) break;
        count_records(rays, nr, visits, nv, &from_records);
        {
            /* every field of mprt_counters is a long long */
            long long *sum = (long long *)&from_tiles, *add = (long long *)&tile;
            size_t k;
            for (k = 0; k < sizeof tile / sizeof(long long); k++) sum[k] += add[k];
        }
    }
    from_records.tir = rendered.tir; /* the one counter the records do not hold */
    CHECK_MSG(memcmp(&rendered, &from_records, sizeof rendered) == 0, "%s: render counters differ from the records",
              what);
    CHECK_MSG(memcmp(&rendered, &from_tiles, sizeof rendered) == 0, "%s: render counters differ from the tiles'",
              what);
    CHECK(rendered.eye_rays == (long long)(W + rules) * (H + rules));
    CHECK(rendered.os_visits > rendered.eye_rays && rendered.ic_visits > 0 && rendered.sc_visits > 0);
    free(rays);
    free(visits);
}

static void test_counters_are_sums_over_the_records(void)
{
    static const char *const names[] = {"balls", "gears", "rings", "tree"};
    int n, rules;
    for (n = 0; n < 4; n++) {
        mprt_scene *s;
        mprt_grid *g;
        mprt_scene_create(&s);
        CHECK(mprt_scene_spd(s, names[n], 1) == MPRT_OK);
        CHECK(mprt_grid_create(s, 7, 5, 6, 0, &g) == MPRT_OK);
        for (rules = MPRT_RULES_PAPER; rules <= MPRT_RULES_SPD; rules++) {
            char what[64];
            snprintf(what, sizeof what, "%s rules %d", names[n], rules);
            check_counts_match(g, rules, what);
        }
        mprt_grid_destroy(g);
        mprt_scene_destroy(s);
    }
}

/* 300 lights: an SC visit makes more shadow rays than a visit record holds. */
static void test_a_trace_refuses_more_rays_than_a_record_holds(void)
{
    enum { LIGHTS = 300 };
    mprt_scene *s;
    mprt_grid *g;
    mprt_render_desc d;
    mprt_trace_ray *rays = malloc(CAP_RAYS * sizeof *rays);
    mprt_trace_visit *visits = malloc(CAP_VISITS * sizeof *visits);
    double samples[3], from[3] = {0, 0, 5}, at[3] = {0, 0, 0}, up[3] = {0, 1, 0}, pos[3], rgb[3] = {0.01, 0.01, 0.01};
    size_t nr, nv;
    int i;
    mprt_scene_create(&s);
    CHECK(mprt_scene_add_sphere(s, at, 1) == MPRT_OK);
    for (i = 0; i < LIGHTS; i++) {
        pos[0] = i % 20 - 10;
        pos[1] = i / 20 - 7;
        pos[2] = 10;
        CHECK(mprt_scene_add_light(s, pos, rgb) == MPRT_OK);
    }
    CHECK(mprt_scene_set_view(s, from, at, up, 10, 0, 1, 1) == MPRT_OK);
    CHECK(mprt_grid_create(s, 2, 2, 2, 0, &g) == MPRT_OK);
    mprt_render_desc_init(&d);
    d.threshold = 0; /* every light gets its shadow ray */
    CHECK(mprt_grid_trace_tile(g, &d, 0, samples, 3, rays, CAP_RAYS, &nr, visits, CAP_VISITS, &nv, NULL) ==
          MPRT_ERR_STATE);
    CHECK_MSG(strstr(mprt_grid_errmsg(g), "255") != NULL, "%s", mprt_grid_errmsg(g));
    CHECK(nr == 1 + LIGHTS);
    mprt_grid_destroy(g);
    mprt_scene_destroy(s);
    free(rays);
    free(visits);
}

int main(void)
{
    RUN(test_counters_are_sums_over_the_records);
    RUN(test_a_trace_refuses_more_rays_than_a_record_holds);
    return CHECK_DONE();
}
