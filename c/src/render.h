/* render.h: what the stages of a render share (internal).  A sample's ray
 * tree is traced depth first: pipeline.c runs OS and IC for each ray and
 * hands hits to SC (shade.c), which makes the children; render.c splits the
 * samples into tiles and the tiles between threads. */
#ifndef MPRT_RENDER_H
#define MPRT_RENDER_H

#include "camera.h"
#include "grid.h"
#include "record.h"

/* A ray of a sample's ray tree, waiting for OS, with what SC needs when it
 * comes back. */
typedef struct {
    vec3 origin, dir;       /* dir is unit length */
    real tmin, tmax;        /* the stretch of the ray searched for hits */
    double contribution;    /* how much the ray can still add to its sample */
    double light_rgb[3];    /* shadow rays: light it carries to the sample */
    int kind;               /* mprt_ray_kind */
    int depth;              /* ray tree level, the eye ray is 1 */
    int64_t id;             /* the ray's number in the trace records (tracing) */
} mprt__tree_ray;

/* The nearest hit found so far. */
typedef struct {
    real t;
    int32_t prim;           /* -1: none */
} mprt__hit;

/* What every ray of one render shares; read-only while rendering. */
typedef struct {
    const mprt_grid *grid;
    const mprt_scene *scene;
    mprt_render_desc desc;  /* resolved (mprt_grid_resolve_desc) */
    mprt__camera camera;
    double light_rgb_default; /* intensity of lights without colour */
} mprt__render_setup;

/* Rays a sample's tree may hold waiting at once: each level holds at most one
 * SC visit's children (a shadow ray per light, a reflection, a refraction). */
size_t mprt__tree_stack_size(const mprt__render_setup *setup);

/* OS and IC for one ray (pipeline.c): the 3DDDA walk hands each voxel that
 * holds primitives to IC until IC accepts a hit, or the ray leaves the grid.
 * shadow: any hit in (tmin, tmax] blocks the ray.  Returns 1 with *best set
 * when a hit was accepted (a shadow ray: blocked), 0 when the ray left. */
int mprt__os_ic(const mprt_grid *grid, const mprt__ray *ray, real tmin, real tmax, int shadow, int use_mailbox,
                mprt__hit *best, mprt__sink *sink, int64_t ray_id, int ray_kind);
/* The same with IC's acceptance convention: accept_listed 1 accepts the
 * nearest hit of a voxel's list wherever it lies (MPRT_ACCEPT_LISTED). */
int mprt__os_ic_accept(const mprt_grid *grid, const mprt__ray *ray, real tmin, real tmax, int shadow, int use_mailbox,
                       int accept_listed, mprt__hit *best, mprt__sink *sink, int64_t ray_id, int ray_kind);

/* mprt__os_ic_accept compiled for tracing (pipeline_trace.c): sink->recorder is set. */
int mprt__os_ic_trace(const mprt_grid *grid, const mprt__ray *ray, real tmin, real tmax, int shadow, int use_mailbox,
                      int accept_listed, mprt__hit *best, mprt__sink *sink, int64_t ray_id, int ray_kind);

/* Trace the whole ray tree of the sample whose eye ray is eye; its colour
 * goes to rgb.  stack holds mprt__tree_stack_size rays. */
void mprt__trace_sample(const mprt__render_setup *setup, mprt__tree_ray eye, int sample, double rgb[3],
                        mprt__tree_ray *stack, mprt__sink *sink);

/* SC for ray, which hit hit (shade.c): add its direct light to rgb and push
 * its children (shadow, reflection and refraction rays) on stack at *top,
 * in reverse, so they are traced in the order made. */
void mprt__sc_shade(const mprt__render_setup *setup, const mprt__tree_ray *ray, mprt__hit hit, int sample,
                    double rgb[3], mprt__tree_ray *stack, int *top, mprt__sink *sink);

#endif
