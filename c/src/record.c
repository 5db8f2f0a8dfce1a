/* record.c: the sum of counters (the records are written by record.h's
 * inline functions). */
#include "record.h"

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
