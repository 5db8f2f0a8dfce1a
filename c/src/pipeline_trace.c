/* pipeline_trace.c: the walk of pipeline.c compiled for tracing (walk.h):
 * each stage visit counted and its record written inline, in place. */
#include "walk.h"

int mprt__os_ic_trace(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, int shadow, int use_mailbox,
                      int accept_listed, mprt__hit *best, mprt__sink *sink, int64_t ray_id, int ray_kind)
{
    return os_ic_walk(g, ray, tmin, tmax, shadow, use_mailbox, accept_listed, best, sink, ray_id, ray_kind, 1);
}
