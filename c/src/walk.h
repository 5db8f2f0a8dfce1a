/* walk.h: OS and IC for one ray, the 3DDDA walk handing voxels to IC
 * (internal; see pipeline.c).  The walk is compiled twice, each copy in a
 * translation unit of its own so that the compiler inlines as much into each
 * as into one: for rendering (pipeline.c, tracing 0: no code for records in
 * the hot loop) and for tracing (pipeline_trace.c, tracing 1: each visit's
 * record written inline, in place). */
#ifndef MPRT_WALK_H
#define MPRT_WALK_H

#include "dda.h"
#include "render.h"

#include <string.h>

#define WALK_INLINE static inline
#if defined(__GNUC__)
#define EMIT_INLINE static inline __attribute__((always_inline)) /* four calls, each small */
#else
#define EMIT_INLINE static inline
#endif

/* ---- IC: one voxel's primitives ------------------------------------------- */

/* Mailbox: primitive ids this ray has tested, direct-mapped.  A primitive
 * tested once need not be tested again in a later voxel: its hit, if any
 * within the (shrinking) search range, is already the candidate. */
#define MAILBOX_SIZE 64
typedef struct {
    int32_t id[MAILBOX_SIZE];
} mailbox;

/* IC visit: test the voxel's list, counting into ic.  For a shadow ray
 * return 1 on any hit in (tmin, tmax].  Otherwise update the nearest hit
 * *best and return 1 when it lies within this voxel's stretch, or with
 * accept_listed wherever it lies (accepted). */
/* A hit at t on primitive id, found by IC's test within the limit, taken as
 * every ic_visit takes it: none where the scene no longer holds what IC tested
 * (a corrupted scene: an error), a shadow ray's first, else the nearest (ties
 * to the lower id).  Returns 1 when the search ends (a shadow ray's hit). */
WALK_INLINE int ic_take(const mprt_grid *g, int32_t id, real t, int shadow, mprt__hit *best, mprt__sink *sink)
{
    if (g->scene->prims[id].kind != mprt__ic_scene_kind(&g->ic, id)) {
        sink->bad_prim = id;
        return 0;
    }
    if (shadow || t < best->t || (t == best->t && id < best->prim)) {
        best->t = t;
        best->prim = id;
    }
    return shadow;
}

/* ic_visit for a voxel whose triangles are packed (ic_pack.h): the blocks
 * are tested a chunk at a time, then the list is gone through in order as
 * ic_visit goes through it, each triangle's test counted and its result
 * taken from its lane only where ic_visit would test it (the mailbox, a
 * shadow ray's first hit), so that counts, hits and ties stay the same.  A
 * lane's hit lies in (tmin, tmax]; the limit the walk has reached
 * (best->t, at most tmax) is applied here, in list order. */
WALK_INLINE int ic_visit_packed(const mprt_grid *g, long long voxel, uint32_t block, real t_exit,
                                const mprt__ray *ray, real dd, real tmin, real tmax, int shadow, int accept_listed,
                                mprt__hit *best, mailbox *mb, mprt__visit *ic, mprt__sink *sink)
{
    const uint32_t end = g->start[voxel + 1];
    const real *blocks = g->pack.blocks + (size_t)block * MPRT__PACK_BLOCK;
    uint32_t k = g->start[voxel];
    int32_t ntri = 0; /* triangles tested: added to ic's counts once, at the end */
    real tt[MPRT__PACK_CHUNK * MPRT__PACK_W];
    while (k < end) {
        uint32_t j, n = end - k, hits;
        unsigned nb;
        if (n > MPRT__PACK_CHUNK * MPRT__PACK_W) n = MPRT__PACK_CHUNK * MPRT__PACK_W;
        nb = (n + MPRT__PACK_W - 1) / MPRT__PACK_W;
        hits = g->pack.block_test(blocks, nb, ray, tmin, tmax, tt);
        blocks += (size_t)nb * MPRT__PACK_BLOCK;
        for (j = 0; j < n; j++, k++) {
            int32_t id = g->ids[k];
            real t;
            real limit = shadow ? tmax : best->t;
            if (mb) {
                if (mb->id[id & (MAILBOX_SIZE - 1)] == id) continue;
                mb->id[id & (MAILBOX_SIZE - 1)] = id;
            }
            if ((g->ic.ref[id] & ((1u << MPRT__IC_KIND_BITS) - 1)) == MPRT__IC_TRIANGLE) {
                /* mprt__ic_test's count of a triangle, and its result from the lane */
                ntri++;
                if (!((hits >> j) & 1)) continue;
                t = tt[j];
                if (!(t <= limit)) continue;
            } else if (!mprt__ic_test(&g->ic, g->scene, id, ray, dd, tmin, limit, &t, ic->tests, &ic->vertices)) {
                continue;
            }
            if (ic_take(g, id, t, shadow, best, sink)) {
                ic->tests[MPRT_POLYGON] += ntri;
                ic->vertices += 3 * ntri;
                return 1;
            }
        }
    }
    ic->tests[MPRT_POLYGON] += ntri;
    ic->vertices += 3 * ntri;
    return !shadow && best->prim >= 0 && (accept_listed || best->t <= t_exit);
}

/* ic_visit with tests several at a time (ic_pack.h): a stretch of the list
 * at a time, first through the mailbox in list order, gathering the
 * triangles and the balls; then the triangles tested and the balls
 * filtered; then the stretch again in list order, each test counted and its
 * result taken as ic_visit takes it (the limit best->t in order, a shadow
 * ray's first hit), so that counts, hits and ties stay the same.  A
 * triangle's hit from its lane lies in (tmin, tmax]; the limit, at most
 * tmax, is applied here. */
enum { IC_SKIP, IC_TRIANGLE, IC_BALL, IC_ONE };

WALK_INLINE int ic_visit_several(const mprt_grid *g, long long voxel, real t_exit, const mprt__ray *ray, real dd,
                                 real tmin, real tmax, int shadow, int accept_listed, mprt__hit *best, mailbox *mb,
                                 mprt__visit *ic, mprt__sink *sink)
{
    const uint32_t end = g->start[voxel + 1];
    uint32_t k = g->start[voxel];
    int32_t ntests = 0; /* triangles tested: added to ic's counts once, at the end */
    for (; k < end; k += MPRT__PACK_MAX) {
        const uint32_t n = end - k < MPRT__PACK_MAX ? end - k : MPRT__PACK_MAX;
        uint32_t tri_index[MPRT__PACK_MAX], j, ntri = 0, nball = 0, thits = 0, bmiss = 0;
        int32_t ball_id[MPRT__PACK_MAX];
        unsigned char how[MPRT__PACK_MAX], lane[MPRT__PACK_MAX];
        real tt[MPRT__PACK_MAX];
        for (j = 0; j < n; j++) {
            const int32_t id = g->ids[k + j];
            const uint32_t ref = g->ic.ref[id], kind = ref & ((1u << MPRT__IC_KIND_BITS) - 1);
            if (mb) {
                if (mb->id[id & (MAILBOX_SIZE - 1)] == id) {
                    how[j] = IC_SKIP;
                    continue;
                }
                mb->id[id & (MAILBOX_SIZE - 1)] = id;
            }
            if (kind == MPRT__IC_TRIANGLE && g->pack.test) {
                how[j] = IC_TRIANGLE;
                lane[j] = (unsigned char)ntri;
                tri_index[ntri++] = ref >> MPRT__IC_KIND_BITS;
            } else if (kind != MPRT__IC_TRIANGLE && kind != MPRT__IC_POLYGON && g->pack.filter) {
                how[j] = IC_BALL;
                lane[j] = (unsigned char)nball;
                ball_id[nball++] = id;
            } else {
                how[j] = IC_ONE;
            }
        }
        if (ntri) thits = g->pack.test(g->ic.tri, tri_index, ntri, ray, tmin, tmax, tt);
        if (nball) bmiss = g->pack.filter(g->ic.ball, ball_id, nball, ray, dd);
        for (j = 0; j < n; j++) {
            const int32_t id = g->ids[k + j];
            real t;
            real limit = shadow ? tmax : best->t;
            if (how[j] == IC_SKIP) continue;
            if (how[j] == IC_TRIANGLE) {
                /* mprt__ic_test's count of a triangle, and its result from the lane */
                ntests++;
                if (!((thits >> lane[j]) & 1)) continue;
                t = tt[lane[j]];
                if (!(t <= limit)) continue;
            } else if (how[j] == IC_BALL && ((bmiss >> lane[j]) & 1)) {
                /* mprt__ic_test's count of a sphere, cylinder or cone whose ball the ray misses, and no hit */
                ic->tests[mprt__ic_scene_kind(&g->ic, id)]++;
                continue;
            } else if (!mprt__ic_test(&g->ic, g->scene, id, ray, dd, tmin, limit, &t, ic->tests, &ic->vertices)) {
                continue;
            }
            if (ic_take(g, id, t, shadow, best, sink)) {
                ic->tests[MPRT_POLYGON] += ntests;
                ic->vertices += 3 * ntests;
                return 1;
            }
        }
    }
    ic->tests[MPRT_POLYGON] += ntests;
    ic->vertices += 3 * ntests;
    return !shadow && best->prim >= 0 && (accept_listed || best->t <= t_exit);
}

WALK_INLINE int ic_visit(const mprt_grid *g, long long voxel, real t_exit, const mprt__ray *ray, real dd, real tmin,
                    real tmax, int shadow, int accept_listed, mprt__hit *best, mailbox *mb, mprt__visit *ic,
                    mprt__sink *sink)
{
    uint32_t k, end = g->start[voxel + 1];
    if (g->pack.first) {
        const uint32_t block = g->pack.first[voxel];
        if (block != g->pack.first[voxel + 1])
            return ic_visit_packed(g, voxel, block, t_exit, ray, dd, tmin, tmax, shadow, accept_listed, best, mb, ic,
                                   sink);
    }
    if ((g->pack.test || g->pack.filter) && end - g->start[voxel] >= 2)
        return ic_visit_several(g, voxel, t_exit, ray, dd, tmin, tmax, shadow, accept_listed, best, mb, ic, sink);
    for (k = g->start[voxel]; k < end; k++) {
        int32_t id = g->ids[k];
        real t;
        real limit = shadow ? tmax : best->t;
        if (mb) {
            if (mb->id[id & (MAILBOX_SIZE - 1)] == id) continue;
            mb->id[id & (MAILBOX_SIZE - 1)] = id;
        }
        if (!mprt__ic_test(&g->ic, g->scene, id, ray, dd, tmin, limit, &t, ic->tests, &ic->vertices)) continue;
        if (ic_take(g, id, t, shadow, best, sink)) return 1;
    }
    return !shadow && best->prim >= 0 && (accept_listed || best->t <= t_exit);
}

/* ---- OS + IC ----------------------------------------------------------------- */

/* Emit the OS visit that ends a walk (or a stretch of it, handing to IC). */
EMIT_INLINE void emit_os(mprt__sink *sink, int64_t ray_id, int ray_kind, int outcome, int32_t steps, int64_t voxel_id,
                         int32_t prim, const int tracing)
{
    mprt__visit os;
    mprt__visit_init(&os, ray_id, ray_kind, MPRT_STAGE_OS, outcome);
    os.steps = steps;
    os.voxel_id = voxel_id;
    os.prim = prim;
    mprt__emit_visit_as(sink, &os, tracing);
}

WALK_INLINE int os_ic_walk(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, int shadow, int use_mailbox,
                           int accept_listed, mprt__hit *best, mprt__sink *sink, int64_t ray_id, int ray_kind,
                           const int tracing)
{
    mprt__dda walk;
    mailbox mb, *pmb = NULL;
    int32_t steps;  /* voxels the walk entered since OS last had the ray */
    const real dd = vdot(ray->d, ray->d);
    int left = shadow ? MPRT_OUT_TO_SC : MPRT_OUT_LEFT;
    best->t = tmax;
    best->prim = -1;
    if (!mprt__dda_start(g, ray, tmin, tmax, &walk)) {
        emit_os(sink, ray_id, ray_kind, left, 0, -1, -1, tracing);
        return 0;
    }
    if (use_mailbox) {
        memset(&mb, 0xff, sizeof mb); /* -1: no primitive */
        pmb = &mb;
    }
    steps = 1;
    while (mprt__dda_seek(g, &walk, &steps)) {
        /* OS hands the ray to IC */
        mprt__visit ic;
        int accepted;
        emit_os(sink, ray_id, ray_kind, MPRT_OUT_TO_IC, steps, walk.voxel, -1, tracing);
        mprt__visit_init(&ic, ray_id, ray_kind, MPRT_STAGE_IC, MPRT_OUT_RETURN);
        ic.voxel_id = walk.voxel;
        accepted = ic_visit(g, walk.voxel, walk.t_exit, ray, dd, tmin, tmax, shadow, accept_listed, best, pmb, &ic, sink);
        if (accepted) {
            ic.outcome = shadow ? MPRT_OUT_BLOCKED : MPRT_OUT_HIT;
            ic.prim = best->prim;
        }
        mprt__emit_visit_as(sink, &ic, tracing);
        if (accepted) return 1;
        /* a return ray: back to OS, which walks on */
        steps = 0;
        if (!mprt__dda_next(g, &walk)) break;
        steps++;
    }
    /* The walk has tested every voxel the ray crosses, so the nearest
     * candidate is the nearest hit even when rounding put it past the
     * last stretch (a primitive lying on the grid box's face). */
    if (!shadow && best->prim >= 0) {
        emit_os(sink, ray_id, ray_kind, MPRT_OUT_LATE_HIT, steps, -1, best->prim, tracing);
        return 1;
    }
    emit_os(sink, ray_id, ray_kind, left, steps, -1, -1, tracing);
    return 0;
}

#endif
