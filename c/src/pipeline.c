/* pipeline.c: the 3MPRT loop.  Every ray moves through the paper's three
 * stages: OS (object search) walks voxels with the 3DDDA until one holds
 * primitives and hands the ray to IC; IC (intersection calculation) tests
 * that voxel's primitives and either sends the ray to SC (a hit), kills it
 * (a blocked shadow ray) or returns it to OS; SC (shading calculation,
 * shade.c) shades, makes the shadow, reflection and refraction rays and
 * sends them to OS.  A ray leaving the grid at OS dies (primary and
 * secondary rays: the background) or, for a shadow ray, reaches its light
 * and goes to SC.  Every stage visit is emitted once (record.h).
 *
 * Grid independence: IC keeps the nearest hit it has found so far, also when
 * that hit lies beyond the current voxel's stretch of the ray, and accepts
 * it only in the voxel whose stretch reaches it.  Ties in t go to the lower
 * primitive id.  The accepted hit is therefore the nearest hit over all
 * primitives, whatever the subdivision, and so are the image and every ray
 * count. */
#include "walk.h"

#define INF_REAL ((real)INFINITY)

int mprt__os_ic(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, int shadow, int use_mailbox,
                mprt__hit *best, mprt__sink *sink, int64_t ray_id, int ray_kind)
{
    return mprt__os_ic_accept(g, ray, tmin, tmax, shadow, use_mailbox, 0, best, sink, ray_id, ray_kind);
}

int mprt__os_ic_accept(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, int shadow, int use_mailbox,
                       int accept_listed, mprt__hit *best, mprt__sink *sink, int64_t ray_id, int ray_kind)
{
    if (sink->recorder)
        return mprt__os_ic_trace(g, ray, tmin, tmax, shadow, use_mailbox, accept_listed, best, sink, ray_id, ray_kind);
    return os_ic_walk(g, ray, tmin, tmax, shadow, use_mailbox, accept_listed, best, sink, ray_id, ray_kind, 0);
}

/* ---- A sample's ray tree -------------------------------------------------- */

void mprt__trace_sample(const mprt__render_setup *setup, mprt__tree_ray eye, int sample, double rgb[3],
                        mprt__tree_ray *stack, mprt__sink *sink)
{
    const mprt_scene *s = setup->scene;
    int top = 0;
    long long rays = 1; /* made for this sample, against the budget */
    eye.id = mprt__emit_ray(sink, -1, MPRT_RAY_PRIMARY, 1, sample, -1, 1.0);
    stack[top++] = eye;
    rgb[0] = rgb[1] = rgb[2] = 0;
    while (top > 0) {
        mprt__tree_ray tree_ray = stack[--top];
        mprt__ray ray;
        mprt__hit hit;
        int shadow = tree_ray.kind == MPRT_RAY_SHADOW;
        mprt__ray_prepare(&ray, tree_ray.origin, tree_ray.dir);
        if (mprt__os_ic_accept(setup->grid, &ray, tree_ray.tmin, tree_ray.tmax, shadow, setup->desc.mailbox,
                               setup->desc.accept == MPRT_ACCEPT_LISTED, &hit, sink, tree_ray.id, tree_ray.kind)) {
            int before = top;
            if (shadow) continue; /* blocked shadow ray dies at IC */
            mprt__sc_shade(setup, &tree_ray, hit, sample, rgb, stack, &top, sink);
            rays += top - before;
            if (rays > setup->desc.max_rays) {
                /* The tree outgrew the budget: abandon the sample (an error) */
                sink->over_budget = sample;
                return;
            }
        } else if (shadow) {
            /* unblocked shadow ray: OS -> SC, adds its light */
            mprt__visit sc;
            mprt__visit_init(&sc, tree_ray.id, tree_ray.kind, MPRT_STAGE_SC, MPRT_OUT_LIT);
            mprt__emit_visit(sink, &sc);
            rgb[0] += tree_ray.light_rgb[0];
            rgb[1] += tree_ray.light_rgb[1];
            rgb[2] += tree_ray.light_rgb[2];
        } else {
            /* left the space: the background */
            rgb[0] += tree_ray.contribution * s->background[0];
            rgb[1] += tree_ray.contribution * s->background[1];
            rgb[2] += tree_ray.contribution * s->background[2];
        }
    }
}

/* ---- Batch closest hit ------------------------------------------------------ */

int mprt_grid_intersect(mprt_grid *g, size_t n, const double *org, const double *dir, double *t, int32_t *prim,
                        mprt_counters *counters)
{
    size_t i;
    mprt__sink sink;
    if (!g) return MPRT_ERR_INVALID_ARG;
    if (g->failed) return MPRT_ERR_STATE;
    if (n && (!org || !dir || !t || !prim)) return MPRT_ERR_INVALID_ARG;
    mprt__sink_init(&sink, NULL);
    for (i = 0; i < n; i++) {
        mprt__ray ray;
        mprt__hit hit;
        const double *o = org + 3 * i, *d = dir + 3 * i;
        if (!(isfinite(o[0]) && isfinite(o[1]) && isfinite(o[2]) && isfinite(d[0]) && isfinite(d[1]) &&
              isfinite(d[2])) ||
            (d[0] == 0 && d[1] == 0 && d[2] == 0)) {
            return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG,
                                   "intersect: ray %zu has a NaN or infinite component or a zero direction", i);
        }
        mprt__ray_prepare(&ray, v3((real)o[0], (real)o[1], (real)o[2]), v3((real)d[0], (real)d[1], (real)d[2]));
        if (mprt__os_ic(g, &ray, 0, INF_REAL, 0, 1, &hit, &sink, 0, MPRT__RAY_QUERY)) {
            t[i] = (double)hit.t;
            prim[i] = hit.prim;
        } else {
            t[i] = INFINITY;
            prim[i] = -1;
        }
    }
    if (sink.bad_prim >= 0)
        return mprt__grid_fail(g, MPRT_ERR_STATE, "intersect: " MPRT__UNKNOWN_KIND, (long long)sink.bad_prim,
                               g->scene->prims[sink.bad_prim].kind);
    if (counters) *counters = sink.counters;
    return MPRT_OK;
}
