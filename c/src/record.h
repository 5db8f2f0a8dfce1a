/* record.h: the one place where a stage visit or a new ray is recorded
 * (internal).  mprt__emit_visit and mprt__emit_ray feed both the counters
 * of a render and, when tracing, the trace records, so the two cannot
 * disagree: every counter of mprt_counters is a sum over the emitted visits
 * and rays, and all but tir can be rebuilt from the trace records. */
#ifndef MPRT_RECORD_H
#define MPRT_RECORD_H

#include "mprt_internal.h"

#include <stdint.h>
#include <string.h>

/* A ray that belongs to no ray tree (mprt_grid_intersect's rays). */
#define MPRT__RAY_QUERY (-1)

/* What one stage visit did: the fields of mprt_trace_visit, in full width. */
typedef struct {
    int64_t ray;            /* the ray's number (mprt__record_ray; 0 when not tracing) */
    int ray_kind;           /* mprt_ray_kind, or MPRT__RAY_QUERY */
    int stage;              /* mprt_stage */
    int outcome;            /* mprt_outcome */
    int64_t voxel_id;       /* OS: voxel handed to IC, IC: voxel tested; else -1 */
    int32_t steps;          /* OS: voxels the 3DDDA entered during the visit */
    int32_t tests[MPRT_NKINDS]; /* IC: intersection tests by primitive kind */
    int32_t vertices;       /* IC: polygon vertices touched by the tests */
    int32_t prim;           /* IC/SC: primitive hit, or -1 */
    int made;               /* SC: rays made */
    int suppressed;         /* SC: rays not made (threshold or depth) */
    int tir;                /* SC: 1 when total internal reflection left no refraction
                             * ray (counted in mprt_counters.tir; not in trace records) */
} mprt__visit;

/* Fill a visit with its identity and no counts. */
static inline void mprt__visit_init(mprt__visit *v, int64_t ray, int ray_kind, int stage, int outcome)
{
    int k;
    v->ray = ray;
    v->ray_kind = ray_kind;
    v->stage = stage;
    v->outcome = outcome;
    v->voxel_id = -1;
    v->steps = 0;
    for (k = 0; k < MPRT_NKINDS; k++) v->tests[k] = 0;
    v->vertices = 0;
    v->prim = -1;
    v->made = 0;
    v->suppressed = 0;
    v->tir = 0;
}

/* The trace records of one tile (mprt_grid_trace_tile's buffers, or the
 * stretch of mprt_grid_trace_tiles' buffers after the tiles before it).
 * Records past a buffer's capacity are counted but not written, so the
 * caller learns the sizes the tile needs. */
typedef struct {
    mprt_trace_ray *rays;
    size_t cap_rays, nrays;     /* nrays counts every ray, also past cap_rays */
    mprt_trace_visit *visits;
    size_t cap_visits, nvisits; /* likewise */
    int64_t base;               /* the number of the tile's first ray (ids are base + the tile-local number) */
    int too_wide;               /* 1 when a value did not fit its record field */
} mprt__recorder;

/* Where the visits and rays of a tile go. */
typedef struct {
    mprt_counters counters;     /* in the sink itself: one pointer less on the hot path */
    mprt__recorder *recorder;   /* NULL unless tracing */
    int64_t bad_prim;           /* -1, or a primitive of unknown kind met (an error) */
    int64_t over_budget;        /* -1, or the first sample whose tree needed more rays
                                 * than the budget (an error; the sample was abandoned) */
} mprt__sink;

/* A sink with no counts and no error yet. */
static inline void mprt__sink_init(mprt__sink *sink, mprt__recorder *recorder)
{
    memset(&sink->counters, 0, sizeof sink->counters);
    sink->recorder = recorder;
    sink->bad_prim = -1;
    sink->over_budget = -1;
}

/* Narrow v into a record field of limit; flags the recorder when it does not fit. */
static inline int64_t mprt__record_fit(mprt__recorder *recorder, int64_t v, int64_t limit)
{
    if (v > limit) {
        recorder->too_wide = 1;
        return limit;
    }
    return v;
}

/* Append a visit's record, written once, in place. */
static inline void mprt__record_visit_here(mprt__recorder *recorder, const mprt__visit *visit)
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
    out->made = (uint8_t)mprt__record_fit(recorder, visit->made, UINT8_MAX);
    out->suppressed = (uint8_t)mprt__record_fit(recorder, visit->suppressed, UINT8_MAX);
}

/* The same out of line (record.c), so that the emit functions stay small where
 * nothing is recorded; and a ray's record, returning its number
 * (recorder->base + the tile-local number). */
void mprt__record_visit(mprt__recorder *recorder, const mprt__visit *visit);
int64_t mprt__record_ray(mprt__recorder *recorder, int64_t parent, int kind, int depth, int sample, int light,
                         double contribution);

/* A stage visit added to the counters (every visit, traced or not). */
static inline void mprt__count_visit(mprt_counters *counters, const mprt__visit *v)
{
    int k;
    switch (v->stage) {
    case MPRT_STAGE_OS:
        counters->os_visits++;
        counters->voxels_traversed += v->steps;
        break;
    case MPRT_STAGE_IC:
        counters->ic_visits++;
        for (k = 0; k < MPRT_NKINDS; k++) counters->tests[k] += v->tests[k];
        counters->polygon_vertices += v->vertices;
        break;
    default: /* MPRT_STAGE_SC */
        counters->sc_visits++;
        counters->suppressed_rays += v->suppressed;
        counters->tir += v->tir;
        break;
    }
    /* A hit ends the ray's search: IC accepts it (a shadow ray is blocked),
     * or OS finds it held when the walk ends */
    if (v->outcome == MPRT_OUT_HIT || v->outcome == MPRT_OUT_BLOCKED || v->outcome == MPRT_OUT_LATE_HIT) {
        counters->hits++;
        if (v->ray_kind == MPRT_RAY_PRIMARY) counters->eye_hits++;
    }
}

/* A stage visit counted, in code compiled apart for tracing (1: recorded in
 * place, inline) and for rendering (0: nothing recorded); the hot loop
 * (pipeline.c's walk) has one copy of each. */
static inline void mprt__emit_visit_as(mprt__sink *sink, const mprt__visit *v, const int tracing)
{
    mprt__count_visit(&sink->counters, v);
    if (tracing) mprt__record_visit_here(sink->recorder, v);
}

/* A stage visit: counted, and recorded when tracing. */
static inline void mprt__emit_visit(mprt__sink *sink, const mprt__visit *v)
{
    mprt__count_visit(&sink->counters, v);
    if (sink->recorder) {
        /* A copy, so that the caller's visit can live in registers when not tracing */
        mprt__visit copy = *v;
        mprt__record_visit(sink->recorder, &copy);
    }
}

/* A new ray: counted by kind, and recorded when tracing.  Returns its
 * number (0 when not tracing). */
static inline int64_t mprt__emit_ray(mprt__sink *sink, int64_t parent, int kind, int depth, int sample, int light,
                                     double contribution)
{
    mprt_counters *counters = &sink->counters;
    switch (kind) {
    case MPRT_RAY_PRIMARY: counters->eye_rays++; break;
    case MPRT_RAY_REFLECT: counters->reflect_rays++; break;
    case MPRT_RAY_REFRACT: counters->refract_rays++; break;
    default: /* MPRT_RAY_SHADOW */ counters->shadow_rays++; break;
    }
    return sink->recorder ? mprt__record_ray(sink->recorder, parent, kind, depth, sample, light, contribution) : 0;
}

/* counters += more, field by field. */
void mprt__counters_add(mprt_counters *counters, const mprt_counters *more);

#endif
