/* record.c: trace records of a tile and the sum of counters.  Records past a
 * buffer's capacity are counted but not written, so the caller learns the
 * sizes the tile needs. */
#include "record.h"

/* Narrow v into a record field of limit; flags the recorder when it does not fit. */
static int64_t fit(mprt__recorder *recorder, int64_t v, int64_t limit)
{
    return mprt__record_fit(recorder, v, limit);
}

void mprt__record_visit(mprt__recorder *recorder, const mprt__visit *visit)
{
    mprt__record_visit_here(recorder, visit);
}

int64_t mprt__record_ray(mprt__recorder *recorder, int64_t parent, int kind, int depth, int sample, int light,
                         double contribution)
{
    size_t at = recorder->nrays++;
    int64_t id = recorder->base + (int64_t)at;
    if (at < recorder->cap_rays) {
        mprt_trace_ray *out = &recorder->rays[at];
        out->id = id;
        out->parent = parent;
        out->pixel = sample;
        out->light = (int16_t)fit(recorder, light, INT16_MAX);
        out->kind = (uint8_t)kind;
        out->depth = (uint8_t)(depth > UINT8_MAX ? UINT8_MAX : depth); /* max_depth <= 255 */
        out->contribution = contribution;
    }
    return id;
}

void mprt__counters_add(mprt_counters *counters, const mprt_counters *more)
{
    int k;
    counters->eye_rays += more->eye_rays;
    counters->eye_hits += more->eye_hits;
    counters->reflect_rays += more->reflect_rays;
    counters->refract_rays += more->refract_rays;
    counters->shadow_rays += more->shadow_rays;
    counters->suppressed_rays += more->suppressed_rays;
    counters->voxels_traversed += more->voxels_traversed;
    for (k = 0; k < MPRT_NKINDS; k++) counters->tests[k] += more->tests[k];
    counters->polygon_vertices += more->polygon_vertices;
    counters->hits += more->hits;
    counters->os_visits += more->os_visits;
    counters->ic_visits += more->ic_visits;
    counters->sc_visits += more->sc_visits;
    counters->tir += more->tir;
}
