/* record.c: trace records of a tile and the sum of counters.  Records past a
 * buffer's capacity are counted but not written, so the caller learns the
 * sizes the tile needs. */
#include "record.h"

/* Narrow v into a record field of limit; flags the recorder when it does not fit. */
static int64_t fit(mprt__recorder *recorder, int64_t v, int64_t limit)
{
    if (v > limit) {
        recorder->too_wide = 1;
        return limit;
    }
    return v;
}

void mprt__record_visit(mprt__recorder *recorder, const mprt__visit *visit)
{
    size_t at = recorder->nvisits++;
    mprt_trace_visit *out;
    int k;
    if (at >= recorder->cap_visits) return;
    out = &recorder->visits[at];
    out->ray = visit->ray;
    out->voxel_id = visit->voxel_id;
    out->steps = visit->steps;
    for (k = 0; k < MPRT_NKINDS; k++) out->tests[k] = visit->tests[k];
    out->vertices = visit->vertices;
    out->prim = visit->prim;
    out->stage = (uint8_t)visit->stage;
    out->outcome = (uint8_t)visit->outcome;
    out->made = (uint8_t)fit(recorder, visit->made, UINT8_MAX);
    out->suppressed = (uint8_t)fit(recorder, visit->suppressed, UINT8_MAX);
}

int64_t mprt__record_ray(mprt__recorder *recorder, int64_t parent, int kind, int depth, int sample, int light,
                         double contribution)
{
    int64_t id = (int64_t)recorder->nrays++;
    if ((size_t)id < recorder->cap_rays) {
        mprt_trace_ray *out = &recorder->rays[id];
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
