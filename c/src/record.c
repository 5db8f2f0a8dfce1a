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

/* Records copied a block at a time, then their ray numbers patched in the copy and
 * its CRC taken while the block is still in cache (mprt_trace_records_shift). */
#define SHIFT_BLOCK 256

static void shift_field(unsigned char *rec, size_t at, int64_t offset, int keep_negative)
{
    int64_t v;
    memcpy(&v, rec + at, sizeof v);
    if (!(keep_negative && v < 0)) v += offset;
    memcpy(rec + at, &v, sizeof v);
}

void mprt_trace_records_shift(int visits, void *dst, const void *src, size_t n, int64_t offset, uint32_t *crc_out)
{
    size_t size = visits ? sizeof(mprt_trace_visit) : sizeof(mprt_trace_ray);
    unsigned char *d = dst;
    const unsigned char *s = src;
    while (n) {
        size_t k = n < SHIFT_BLOCK ? n : SHIFT_BLOCK, i;
        memcpy(d, s, k * size);
        if (offset) {
            for (i = 0; i < k; i++) {
                unsigned char *rec = d + i * size;
                if (visits) {
                    shift_field(rec, offsetof(mprt_trace_visit, ray), offset, 0);
                } else {
                    shift_field(rec, offsetof(mprt_trace_ray, id), offset, 0);
                    shift_field(rec, offsetof(mprt_trace_ray, parent), offset, 1);
                }
            }
        }
        if (crc_out) *crc_out = mprt_crc32_copy(NULL, d, k * size, *crc_out);
        d += k * size;
        s += k * size;
        n -= k;
    }
}
