/* render.c: the 3MPRT loop.  Every ray moves through the paper's three
 * stages: OS (object search) walks voxels with the 3DDDA until one holds
 * primitives and hands the ray to IC; IC (intersection calculation) tests
 * that voxel's primitives and either sends the ray to SC (a hit), kills it
 * (a blocked shadow ray) or returns it to OS; SC (shading calculation)
 * shades, makes the shadow, reflection and refraction rays and sends them to
 * OS.  A ray leaving the grid at OS dies (primary and secondary rays: the
 * background) or, for a shadow ray, reaches its light and goes to SC.
 *
 * Grid independence: IC keeps the nearest hit it has found so far, also when
 * that hit lies beyond the current voxel's stretch of the ray, and accepts
 * it only in the voxel whose stretch reaches it.  Ties in t go to the lower
 * primitive id.  The accepted hit is therefore the nearest hit over all
 * primitives, whatever the subdivision, and so are the image and every ray
 * count. */
#include "camera.h"
#include "grid.h"

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define INF_REAL ((real)INFINITY)

/* ---- 3DDDA ---------------------------------------------------------------- */

static real boundary(const mprt_grid *g, int a, int i)
{
    return vget(g->lo, a) + (real)i * vget(g->cell, a);
}

static inline int dda_begin(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, mprt__dda *w)
{
    real t0 = tmin, t1 = tmax, o[3], d[3], inv[3];
    int a;
    o[0] = ray->o.x; o[1] = ray->o.y; o[2] = ray->o.z;
    d[0] = ray->d.x; d[1] = ray->d.y; d[2] = ray->d.z;
    inv[0] = ray->inv.x; inv[1] = ray->inv.y; inv[2] = ray->inv.z;
    /* Clip the ray to the grid box, grown by pad (slabs) */
    for (a = 0; a < 3; a++) {
        real lo = vget(g->lo, a) - g->pad, hi = vget(g->hi, a) + g->pad;
        if (d[a] == 0) {
            if (!(o[a] >= lo && o[a] <= hi)) return 0;
            continue;
        }
        {
            real ta = (lo - o[a]) * inv[a], tb = (hi - o[a]) * inv[a];
            if (ta > tb) { real tmp = ta; ta = tb; tb = tmp; }
            if (ta > t0) t0 = ta;
            if (tb < t1) t1 = tb;
        }
    }
    if (!(t0 <= t1)) return 0;
    /* First voxel: the cell holding the entry point; then per axis the
     * first boundary crossing and the spacing of the following ones */
    w->voxel = 0;
    for (a = 0; a < 3; a++) {
        real x = o[a] + t0 * d[a];
        real f = (x - vget(g->lo, a)) * vget(g->inv_cell, a);
        int c = f > 0 ? (f >= (real)g->n[a] ? g->n[a] - 1 : (int)f) : 0;
        long long stride = a == 0 ? 1 : a == 1 ? g->n[0] : (long long)g->n[0] * g->n[1];
        w->cell[a] = c;
        w->voxel += c * stride;
        if (d[a] == 0) {
            w->step[a] = 1;
            w->tnext[a] = (real)INFINITY;
            w->tdelta[a] = (real)INFINITY;
        } else {
            w->step[a] = d[a] < 0 ? -1 : 1;
            w->tnext[a] = (boundary(g, a, c + (d[a] > 0)) - o[a]) * inv[a];
            w->tdelta[a] = vget(g->cell, a) * (inv[a] < 0 ? -inv[a] : inv[a]);
        }
        w->stride[a] = w->step[a] * stride;
    }
    w->t_enter = t0;
    w->t_end = t1;
    w->t_exit = w->tnext[0] < w->tnext[1] ? (w->tnext[0] < w->tnext[2] ? w->tnext[0] : w->tnext[2])
                                          : (w->tnext[1] < w->tnext[2] ? w->tnext[1] : w->tnext[2]);
    if (w->t_exit > t1) w->t_exit = t1;
    if (w->t_exit < t0) w->t_exit = t0;
    return 1;
}

/* The smallest of three. */
static inline real min3(real a, real b, real c) { return a < b ? (a < c ? a : c) : (b < c ? b : c); }

/* One step of the walk: the axis whose boundary comes first (the lowest
 * axis on ties, so a ray through an edge or corner visits the voxels that
 * only touch it, one axis at a time).  Written with constant indices so the
 * state can live in registers. */
static inline int dda_step(const mprt_grid *g, mprt__dda *w)
{
    real t;
    if (w->t_exit >= w->t_end) return 0;
    if (w->tnext[0] <= w->tnext[1] && w->tnext[0] <= w->tnext[2]) {
        w->cell[0] += w->step[0];
        if ((unsigned)w->cell[0] >= (unsigned)g->n[0]) return 0;
        w->voxel += w->stride[0];
        w->tnext[0] += w->tdelta[0];
    } else if (w->tnext[1] <= w->tnext[2]) {
        w->cell[1] += w->step[1];
        if ((unsigned)w->cell[1] >= (unsigned)g->n[1]) return 0;
        w->voxel += w->stride[1];
        w->tnext[1] += w->tdelta[1];
    } else {
        w->cell[2] += w->step[2];
        if ((unsigned)w->cell[2] >= (unsigned)g->n[2]) return 0;
        w->voxel += w->stride[2];
        w->tnext[2] += w->tdelta[2];
    }
    /* The new stretch starts where the old one ended */
    w->t_enter = w->t_exit;
    t = min3(w->tnext[0], w->tnext[1], w->tnext[2]);
    if (t > w->t_end) t = w->t_end;
    w->t_exit = t < w->t_enter ? w->t_enter : t;
    return 1;
}

int mprt__dda_start(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, mprt__dda *w)
{
    return dda_begin(g, ray, tmin, tmax, w);
}

int mprt__dda_next(const mprt_grid *g, mprt__dda *w) { return dda_step(g, w); }

/* ---- IC: one voxel's primitives ------------------------------------------- */

typedef struct {
    real t;
    int32_t prim;
} hit;

/* Mailbox: primitive ids this ray has tested, direct-mapped.  A primitive
 * tested once need not be tested again in a later voxel: its hit, if any
 * within the (shrinking) search range, is already the candidate. */
#define MAILBOX 64
typedef struct {
    int32_t id[MAILBOX];
} mailbox;

/* Test one primitive; counts the test. */
static int test_prim(const mprt_scene *s, int32_t id, const mprt__ray *ray, real tmin, real tmax, real *t,
                     mprt_counters *c)
{
    const mprt__prim *p = &s->prims[id];
    c->tests[p->kind]++;
    switch (p->kind) {
    case MPRT_SPHERE: return mprt__sphere_hit(&s->spheres[p->index], ray, tmin, tmax, t);
    case MPRT_POLYGON:
        c->polygon_vertices += s->polygons[p->index].n;
        return mprt__polygon_hit(&s->polygons[p->index], s->verts, ray, tmin, tmax, t);
    case MPRT_CYLINDER: return mprt__cylinder_hit(&s->cones[p->index], ray, tmin, tmax, t);
    default: return mprt__cone_hit(&s->cones[p->index], ray, tmin, tmax, t);
    }
}

/* IC visit: test the voxel's list.  For a shadow ray (any_hit) return 1 on
 * any hit in (tmin, tmax].  Otherwise update the nearest hit *best and
 * return 1 when it lies within this voxel's stretch (accepted). */
static int ic_visit(const mprt_grid *g, long long voxel, real t_exit, const mprt__ray *ray, real tmin,
                    real tmax, int any_hit, hit *best, mailbox *mb, mprt_counters *c)
{
    const mprt_scene *s = g->scene;
    uint32_t k, k1 = g->start[voxel + 1];
    c->ic_visits++;
    for (k = g->start[voxel]; k < k1; k++) {
        int32_t id = g->ids[k];
        real t;
        real limit = any_hit ? tmax : best->t;
        if (mb) {
            if (mb->id[id & (MAILBOX - 1)] == id) continue;
            mb->id[id & (MAILBOX - 1)] = id;
        }
        if (!test_prim(s, id, ray, tmin, limit, &t, c)) continue;
        if (any_hit) {
            best->t = t;
            best->prim = id;
            return 1;
        }
        if (t < best->t || (t == best->t && id < best->prim)) {
            best->t = t;
            best->prim = id;
        }
    }
    return !any_hit && best->prim >= 0 && best->t <= t_exit;
}

/* ---- Trace recording -------------------------------------------------------
 * A recorder is only present when tracing; every hook is one NULL test. */
typedef struct {
    mprt_trace_ray *rays;
    size_t cap_rays, nrays;
    mprt_trace_visit *visits;
    size_t cap_visits, nvisits;
    mprt_trace_visit scratch; /* where visits past the capacity are written */
} recorder;

/* Append a visit (counted even when it does not fit, so the caller learns the size). */
static mprt_trace_visit *rec_visit(recorder *rec, int64_t ray, int stage, int outcome)
{
    mprt_trace_visit *v = rec->nvisits < rec->cap_visits ? &rec->visits[rec->nvisits] : &rec->scratch;
    rec->nvisits++;
    memset(v, 0, sizeof *v);
    v->ray = ray;
    v->voxel_id = -1;
    v->prim = -1;
    v->stage = (uint8_t)stage;
    v->outcome = (uint8_t)outcome;
    return v;
}

/* Append a ray record; returns its id. */
static int64_t rec_ray(recorder *rec, int64_t parent, int kind, int depth, int pixel, int light, double contrib)
{
    int64_t id = (int64_t)rec->nrays++;
    if ((size_t)id < rec->cap_rays) {
        mprt_trace_ray *r = &rec->rays[id];
        r->id = id;
        r->parent = parent;
        r->pixel = pixel;
        r->light = (int16_t)light;
        r->kind = (uint8_t)kind;
        r->depth = (uint8_t)(depth > 255 ? 255 : depth);
        r->contribution = contrib;
    }
    return id;
}

/* OS + IC: walk until a hit is accepted or the ray leaves.  Returns 1 with
 * *best set for a hit (for a shadow ray: blocked), 0 when the ray left. */
static int os_ic(const mprt_grid *g, const mprt__ray *ray, real tmin, real tmax, int any_hit, hit *best,
                 int use_mailbox, mprt_counters *c, recorder *rec, int64_t ray_id)
{
    mprt__dda w;
    mailbox mb, *pmb = NULL;
    const uint8_t *flag = g->flag;
    long long voxels = 1, os = 1, mark = 0;
    int found = 0;
    best->t = tmax;
    best->prim = -1;
    if (!dda_begin(g, ray, tmin, tmax, &w)) {
        c->os_visits++;
        if (rec) rec_visit(rec, ray_id, MPRT_STAGE_OS, any_hit ? MPRT_OUT_TO_SC : MPRT_OUT_LEFT);
        return 0;
    }
    if (use_mailbox) {
        memset(&mb, 0xff, sizeof mb); /* -1: no primitive */
        pmb = &mb;
    }
    for (;;) {
        if (flag[w.voxel]) {
            /* OS hands the ray to IC */
            long long tests0[MPRT_NKINDS] = {0, 0, 0, 0}, vertices0 = 0;
            int accepted;
            if (rec) {
                mprt_trace_visit *v = rec_visit(rec, ray_id, MPRT_STAGE_OS, MPRT_OUT_TO_IC);
                v->steps = (int32_t)(voxels - mark);
                v->voxel_id = w.voxel;
                memcpy(tests0, c->tests, sizeof tests0);
                vertices0 = c->polygon_vertices;
            }
            accepted = ic_visit(g, w.voxel, w.t_exit, ray, tmin, tmax, any_hit, best, pmb, c);
            if (rec) {
                mprt_trace_visit *v = rec_visit(rec, ray_id, MPRT_STAGE_IC,
                                                accepted ? (any_hit ? MPRT_OUT_BLOCKED : MPRT_OUT_HIT) : MPRT_OUT_RETURN);
                int k;
                v->voxel_id = w.voxel;
                for (k = 0; k < MPRT_NKINDS; k++) v->tests[k] = (int32_t)(c->tests[k] - tests0[k]);
                v->vertices = (int32_t)(c->polygon_vertices - vertices0);
                if (accepted) v->prim = best->prim;
                mark = voxels;
            }
            if (accepted) {
                found = 1;
                break;
            }
            /* a return ray: back to OS */
            os++;
        }
        if (!dda_step(g, &w)) break;
        voxels++;
    }
    c->voxels_traversed += voxels;
    c->os_visits += os;
    /* The walk has tested every voxel the ray crosses, so the nearest
     * candidate is the nearest hit even when rounding put it past the
     * last stretch (a primitive lying on the grid box's face). */
    if (!found && !any_hit && best->prim >= 0) {
        if (rec) {
            mprt_trace_visit *v = rec_visit(rec, ray_id, MPRT_STAGE_OS, MPRT_OUT_LATE_HIT);
            v->steps = (int32_t)(voxels - mark);
            v->prim = best->prim;
        }
        return 1;
    }
    if (!found && rec) {
        mprt_trace_visit *v = rec_visit(rec, ray_id, MPRT_STAGE_OS, any_hit ? MPRT_OUT_TO_SC : MPRT_OUT_LEFT);
        v->steps = (int32_t)(voxels - mark);
    }
    return found;
}

/* ---- Batch closest hit ------------------------------------------------------ */

int mprt_grid_intersect(mprt_grid *g, size_t n, const double *org, const double *dir, double *t,
                        int32_t *prim, mprt_counters *counters)
{
    size_t i;
    mprt_counters c;
    if (!g) return MPRT_ERR_INVALID_ARG;
    if (g->failed) return MPRT_ERR_STATE;
    if (n && (!org || !dir || !t || !prim)) return MPRT_ERR_INVALID_ARG;
    memset(&c, 0, sizeof c);
    for (i = 0; i < n; i++) {
        mprt__ray ray;
        hit h;
        const double *o = org + 3 * i, *d = dir + 3 * i;
        if (!(isfinite(o[0]) && isfinite(o[1]) && isfinite(o[2]) && isfinite(d[0]) && isfinite(d[1]) &&
              isfinite(d[2])) ||
            (d[0] == 0 && d[1] == 0 && d[2] == 0)) {
            return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "intersect: ray %zu has a NaN or infinite component or a zero direction", i);
        }
        mprt__ray_prepare(&ray, v3((real)o[0], (real)o[1], (real)o[2]), v3((real)d[0], (real)d[1], (real)d[2]));
        if (os_ic(g, &ray, 0, INF_REAL, 0, &h, 1, &c, NULL, 0)) {
            t[i] = (double)h.t;
            prim[i] = h.prim;
            c.hits++;
        } else {
            t[i] = INFINITY;
            prim[i] = -1;
        }
    }
    if (counters) *counters = c;
    return MPRT_OK;
}

/* ---- Rendering ------------------------------------------------------------ */


/* A ray waiting for OS, with what SC needs when it comes back. */
typedef struct {
    vec3 o, d;        /* d is unit length */
    real tmin, tmax;
    double contrib;   /* how much the ray can still add to its pixel */
    double rgb[3];    /* shadow rays: light it carries to the pixel */
    int kind, depth;
    int64_t id;       /* trace: tile-local ray number */
} job;

typedef struct {
    const mprt_grid *grid;
    const mprt_render_desc *desc;
    mprt__camera cam;
    double light_rgb_default; /* intensity of lights without colour */
    double *samples;          /* sw*sh*3 sample colours */
    int tiles_x, tiles_y, next_tile;
    mprt_counters *tile_counters;
    pthread_mutex_t lock;
    int failed;
    recorder *rec;            /* tracing one tile: where its records go */
    int stride, ox, oy;       /* layout of samples (see render_tile) */
} render_ctx;

/* Offset that keeps a secondary ray off the surface it starts on: scaled to
 * the hit point's magnitude, so it works at any scene scale. */
static real surface_offset(vec3 p) { return (vmaxabs(p) + R(1e-30)) * REAL_EPS * R(512); }

static vec3 reflect_dir(vec3 d, vec3 n) { return vnorm(vsub(d, vscale(n, 2 * vdot(d, n)))); }

static vec3 shading_normal(const mprt_scene *s, int32_t id, vec3 p)
{
    const mprt__prim *pr = &s->prims[id];
    switch (pr->kind) {
    case MPRT_SPHERE: return mprt__sphere_normal(&s->spheres[pr->index], p);
    case MPRT_POLYGON: return mprt__polygon_normal(&s->polygons[pr->index], s->verts, s->vnormals, p);
    default: return mprt__cone_normal(&s->cones[pr->index], p);
    }
}

/* Decide whether a child ray is traced; counts the suppressed ones. */
static int keep_child(const render_ctx *x, double contrib, int depth, mprt_counters *c)
{
    const mprt_render_desc *rd = x->desc;
    if (depth > rd->max_depth || (rd->rules == MPRT_RULES_PAPER && contrib < rd->threshold)) {
        c->suppressed_rays++;
        return 0;
    }
    return 1;
}

/* SC for a primary or secondary ray that hit primitive h at distance t:
 * add the ambient term, push shadow, reflection and refraction rays. */
static void sc_shade(const render_ctx *x, const job *r, hit h, double acc[3], job *stack, int *sp,
                     mprt_counters *c, recorder *rec, int pixel)
{
    long long suppressed0 = c->suppressed_rays;
    const mprt_scene *s = x->grid->scene;
    const mprt_render_desc *rd = x->desc;
    const mprt__material *m = &s->materials[s->prims[h.prim].material];
    vec3 p = vmadd(r->o, r->d, h.t);
    vec3 n = shading_normal(s, h.prim, p);
    real off = surface_offset(p);
    int entering = 1, l, spd = rd->rules == MPRT_RULES_SPD;
    double cosi;
    job *kids = stack + *sp;
    int nk = 0;

    c->sc_visits++;
    /* Face the normal toward the incoming ray */
    if (vdot(n, r->d) > 0) {
        n = vscale(n, -1);
        entering = 0;
    }
    cosi = -(double)vdot(n, r->d);
    acc[0] += r->contrib * rd->ambient * m->rgb[0];
    acc[1] += r->contrib * rd->ambient * m->rgb[1];
    acc[2] += r->contrib * rd->ambient * m->rgb[2];

    /* Shadow rays, one per light */
    for (l = 0; l < (int)s->nlights; l++) {
        const mprt__light *L = &s->lights[l];
        vec3 to = vsub(L->pos, p);
        real dist = vlen(to);
        double ndl, lum, spec = 0, rgb[3];
        int i;
        if (!(dist > off)) continue;
        to = vscale(to, 1 / dist);
        ndl = (double)vdot(n, to);
        if (spd && ndl <= 0) continue; /* SPD: no shadow ray toward a light behind the surface */
        lum = (ndl > 0 ? ndl : 0) * m->kd * r->contrib;
        if (spd && m->ks > 0) {
            double rv = (double)vdot(reflect_dir(r->d, n), to);
            if (rv > 0) spec = m->ks * pow(rv, m->shine) * r->contrib;
        }
        if (!spd && !keep_child(x, lum * (L->has_rgb ? (L->rgb[0] + L->rgb[1] + L->rgb[2]) / 3 : x->light_rgb_default),
                                r->depth, c))
            continue;
        for (i = 0; i < 3; i++) {
            double li = L->has_rgb ? L->rgb[i] : x->light_rgb_default;
            rgb[i] = li * (lum * m->rgb[i] + spec);
        }
        kids[nk].o = p;
        kids[nk].d = to;
        kids[nk].tmin = off;
        kids[nk].tmax = dist;
        kids[nk].contrib = r->contrib;
        kids[nk].rgb[0] = rgb[0];
        kids[nk].rgb[1] = rgb[1];
        kids[nk].rgb[2] = rgb[2];
        kids[nk].kind = MPRT_RAY_SHADOW;
        kids[nk].depth = r->depth;
        if (rec) kids[nk].id = rec_ray(rec, r->id, MPRT_RAY_SHADOW, r->depth, pixel, l, kids[nk].contrib);
        nk++;
        c->shadow_rays++;
    }
    /* Reflection */
    if (m->ks > 0 && keep_child(x, r->contrib * m->ks, r->depth + 1, c)) {
        memset(&kids[nk], 0, sizeof kids[nk]);
        kids[nk].o = p;
        kids[nk].d = reflect_dir(r->d, n);
        kids[nk].tmin = off;
        kids[nk].tmax = INF_REAL;
        kids[nk].contrib = r->contrib * m->ks;
        kids[nk].kind = MPRT_RAY_REFLECT;
        kids[nk].depth = r->depth + 1;
        if (rec) kids[nk].id = rec_ray(rec, r->id, MPRT_RAY_REFLECT, r->depth + 1, pixel, -1, kids[nk].contrib);
        nk++;
        c->reflect_rays++;
    }
    /* Refraction (Snell); total internal reflection makes a reflection ray */
    if (m->t > 0 && keep_child(x, r->contrib * m->t, r->depth + 1, c)) {
        double eta = entering ? 1 / m->ior : m->ior;
        double k = 1 - eta * eta * (1 - cosi * cosi);
        memset(&kids[nk], 0, sizeof kids[nk]);
        kids[nk].o = p;
        if (k < 0) {
            kids[nk].d = reflect_dir(r->d, n);
            kids[nk].kind = MPRT_RAY_REFLECT;
            c->reflect_rays++;
        } else {
            vec3 d = vadd(vscale(r->d, (real)eta), vscale(n, (real)(eta * cosi - sqrt(k))));
            kids[nk].d = vnorm(d);
            kids[nk].kind = MPRT_RAY_REFRACT;
            c->refract_rays++;
        }
        kids[nk].tmin = off;
        kids[nk].tmax = INF_REAL;
        kids[nk].contrib = r->contrib * m->t;
        kids[nk].depth = r->depth + 1;
        if (rec) kids[nk].id = rec_ray(rec, r->id, kids[nk].kind, r->depth + 1, pixel, -1, kids[nk].contrib);
        nk++;
    }
    if (rec) {
        mprt_trace_visit *v = rec_visit(rec, r->id, MPRT_STAGE_SC, MPRT_OUT_SHADED);
        v->prim = h.prim;
        v->made = (uint8_t)nk;
        v->suppressed = (uint8_t)(c->suppressed_rays - suppressed0);
    }
    /* Push in reverse so the children are traced in the order made */
    {
        int i;
        for (i = 0; i < nk / 2; i++) {
            job tmp = kids[i];
            kids[i] = kids[nk - 1 - i];
            kids[nk - 1 - i] = tmp;
        }
    }
    *sp += nk;
}

/* Trace the whole ray tree of one sample; returns its colour in acc. */
static void trace_sample(const render_ctx *x, job first, double acc[3], job *stack, mprt_counters *c,
                         recorder *rec, int pixel)
{
    const mprt_scene *s = x->grid->scene;
    int sp = 0;
    if (rec) first.id = rec_ray(rec, -1, MPRT_RAY_PRIMARY, 1, pixel, -1, 1.0);
    stack[sp++] = first;
    acc[0] = acc[1] = acc[2] = 0;
    while (sp > 0) {
        job r = stack[--sp];
        mprt__ray ray;
        hit h;
        int any = r.kind == MPRT_RAY_SHADOW;
        mprt__ray_prepare(&ray, r.o, r.d);
        if (os_ic(x->grid, &ray, r.tmin, r.tmax, any, &h, x->desc->mailbox, c, rec, r.id)) {
            c->hits++;
            if (r.kind == MPRT_RAY_PRIMARY) c->eye_hits++;
            if (any) continue; /* blocked shadow ray dies at IC */
            sc_shade(x, &r, h, acc, stack, &sp, c, rec, pixel);
        } else if (any) {
            /* unblocked shadow ray: OS -> SC, adds its light */
            c->sc_visits++;
            if (rec) rec_visit(rec, r.id, MPRT_STAGE_SC, MPRT_OUT_LIT);
            acc[0] += r.rgb[0];
            acc[1] += r.rgb[1];
            acc[2] += r.rgb[2];
        } else {
            /* left the space: the background */
            acc[0] += r.contrib * s->background[0];
            acc[1] += r.contrib * s->background[1];
            acc[2] += r.contrib * s->background[2];
        }
    }
}

/* The eye ray of sample (x, y). */
static job primary(const mprt__camera *cam, int x, int y)
{
    job j;
    memset(&j, 0, sizeof j);
    j.o = cam->from;
    j.d = mprt__camera_ray(cam, x, y, &j.tmin);
    j.tmax = INF_REAL;
    j.contrib = 1;
    j.kind = MPRT_RAY_PRIMARY;
    j.depth = 1;
    return j;
}

/* Trace a tile's samples; colours go to x->samples, whose row stride is
 * x->stride samples and whose first sample is (x->ox, x->oy). */
static void render_tile(render_ctx *x, int tile, job *stack, mprt_counters *c)
{
    const mprt__camera *cam = &x->cam;
    int rect[4], i, j;
    mprt__tile_rect(cam, x->desc->tile, tile, rect);
    for (j = rect[1]; j < rect[3]; j++)
        for (i = rect[0]; i < rect[2]; i++) {
            double *acc = x->samples + 3 * ((size_t)(j - x->oy) * (size_t)x->stride + (size_t)(i - x->ox));
            c->eye_rays++;
            trace_sample(x, primary(cam, i, j), acc, stack, c, x->rec, j * cam->samples_w + i);
        }
}

/* Depth-first ray trees: each level holds at most one SC visit's children. */
static size_t stack_size(const render_ctx *x)
{
    return (size_t)(x->desc->max_depth + 2) * (size_t)(x->grid->scene->nlights + 2) + 8;
}

static void *worker(void *arg)
{
    render_ctx *x = arg;
    job *stack = malloc(stack_size(x) * sizeof *stack);
    int ntiles = x->tiles_x * x->tiles_y;
    if (!stack) {
        pthread_mutex_lock(&x->lock);
        x->failed = 1;
        pthread_mutex_unlock(&x->lock);
        return NULL;
    }
    for (;;) {
        int tile;
        pthread_mutex_lock(&x->lock);
        tile = x->failed ? ntiles : x->next_tile++;
        pthread_mutex_unlock(&x->lock);
        if (tile >= ntiles) break;
        render_tile(x, tile, stack, &x->tile_counters[tile]);
    }
    free(stack);
    return NULL;
}

void mprt_render_desc_init(mprt_render_desc *d)
{
    if (!d) return;
    memset(d, 0, sizeof *d);
    d->rules = MPRT_RULES_PAPER;
    d->threshold = 1.0 / 512;
    d->max_depth = 0;
    d->threads = 1;
    d->tile = 16;
    d->ambient = 0.1;
}

int mprt_grid_resolve_desc(mprt_grid *g, const mprt_render_desc *desc, mprt_render_desc *out)
{
    mprt_render_desc rd;
    if (!g || !desc || !out) return MPRT_ERR_INVALID_ARG;
    if (g->failed) return MPRT_ERR_STATE;
    rd = *desc;
    if (rd.width == 0) rd.width = g->scene->width;
    if (rd.height == 0) rd.height = g->scene->height;
    if (rd.width < 1 || rd.height < 1 || rd.width > 65536 || rd.height > 65536)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: resolution %dx%d is not in 1..65536", rd.width,
                               rd.height);
    if (rd.rules != MPRT_RULES_PAPER && rd.rules != MPRT_RULES_SPD)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: unknown rule set %d (0 paper, 1 spd)", rd.rules);
    if (!(rd.threshold >= 0 && rd.threshold < 1))
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: threshold %g is not in [0, 1)", rd.threshold);
    if (!(rd.ambient >= 0 && rd.ambient <= 1))
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: ambient %g is not in [0, 1]", rd.ambient);
    if (rd.max_depth < 0 || rd.max_depth > 255)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: max_depth %d is not in 0..255", rd.max_depth);
    if (rd.max_depth == 0) rd.max_depth = rd.rules == MPRT_RULES_SPD ? 5 : 64;
    if (rd.tile <= 0) rd.tile = 16;
    if (rd.threads < 0 || rd.threads > 64)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: threads %d is not in 0..64", rd.threads);
    if (rd.threads == 0) rd.threads = 1;
    *out = rd;
    return MPRT_OK;
}

/* Validate a render description and set up the context (camera, tiling).
 * rd_out receives the resolved description. */
static int setup(mprt_grid *g, const mprt_render_desc *desc, mprt_render_desc *rd_out, render_ctx *xp)
{
    const mprt_scene *s;
    int st = mprt_grid_resolve_desc(g, desc, rd_out);
    if (st != MPRT_OK) return st;
    s = g->scene;
    memset(xp, 0, sizeof *xp);
    xp->grid = g;
    xp->desc = rd_out;
    mprt__camera_setup(s, rd_out->width, rd_out->height, rd_out->rules, &xp->cam);
    xp->light_rgb_default = mprt__light_default_rgb(s);
    mprt__tile_counts(&xp->cam, rd_out->tile, &xp->tiles_x, &xp->tiles_y);
    return MPRT_OK;
}

int mprt_grid_trace_tile(mprt_grid *g, const mprt_render_desc *desc, int tile, double *samples, size_t cap_samples,
                         mprt_trace_ray *rays, size_t cap_rays, size_t *nrays, mprt_trace_visit *visits,
                         size_t cap_visits, size_t *nvisits, mprt_counters *counters)
{
    render_ctx x;
    mprt_render_desc rd;
    recorder rec;
    mprt_counters c;
    job *stack;
    int rect[4];
    size_t nsamples;
    int st = setup(g, desc, &rd, &x);
    if (st != MPRT_OK) return st;
    if (!samples || !nrays || !nvisits || (cap_rays && !rays) || (cap_visits && !visits)) return MPRT_ERR_INVALID_ARG;
    if (tile < 0 || tile >= x.tiles_x * x.tiles_y) {
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "trace: tile %d is not in 0..%d", tile, x.tiles_x * x.tiles_y - 1);
    }
    mprt__tile_rect(&x.cam, rd.tile, tile, rect);
    nsamples = (size_t)(rect[2] - rect[0]) * (size_t)(rect[3] - rect[1]);
    if (cap_samples < nsamples * 3) {
        return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "trace: sample buffer holds %zu doubles, %zu needed", cap_samples,
                               nsamples * 3);
    }
    memset(&rec, 0, sizeof rec);
    rec.rays = rays;
    rec.cap_rays = cap_rays;
    rec.visits = visits;
    rec.cap_visits = cap_visits;
    x.rec = &rec;
    x.samples = samples;
    x.stride = rect[2] - rect[0];
    x.ox = rect[0];
    x.oy = rect[1];
    stack = malloc(stack_size(&x) * sizeof *stack);
    if (!stack) {
        return mprt__grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "trace: out of memory for the ray stack");
    }
    memset(&c, 0, sizeof c);
    render_tile(&x, tile, stack, &c);
    free(stack);
    *nrays = rec.nrays;
    *nvisits = rec.nvisits;
    if (counters) *counters = c;
    if (rec.nrays > cap_rays || rec.nvisits > cap_visits) {
        return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "trace: tile %d needs %zu rays and %zu visits", tile, rec.nrays,
                 rec.nvisits);
    }
    return MPRT_OK;
}

int mprt_grid_render(mprt_grid *g, const mprt_render_desc *desc, float *rgb, size_t cap, mprt_counters *counters)
{
    render_ctx x;
    mprt_render_desc rd;
    pthread_t th[64];
    int nth, i, started = 0, ntiles, w, h;
    size_t nsamples;
    int st = setup(g, desc, &rd, &x);
    if (st != MPRT_OK) return st;
    if (!rgb) return MPRT_ERR_INVALID_ARG;
    w = x.cam.width;
    h = x.cam.height;
    if (cap < (size_t)w * (size_t)h * 3) {
        return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "render: image buffer holds %zu floats, %zu needed", cap,
                 (size_t)w * (size_t)h * 3);
    }
    nsamples = (size_t)x.cam.samples_w * (size_t)x.cam.samples_h;
    ntiles = x.tiles_x * x.tiles_y;
    x.stride = x.cam.samples_w;
    x.samples = malloc(nsamples * 3 * sizeof *x.samples);
    x.tile_counters = calloc((size_t)ntiles, sizeof *x.tile_counters);
    if (!x.samples || !x.tile_counters || pthread_mutex_init(&x.lock, NULL) != 0) {
        free(x.samples);
        free(x.tile_counters);
        return mprt__grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "render: out of memory for %zu samples", nsamples);
    }
    nth = rd.threads;
    for (i = 1; i < nth; i++) {
        if (pthread_create(&th[i], NULL, worker, &x) != 0) break;
        started++;
    }
    worker(&x);
    for (i = 1; i <= started; i++) pthread_join(th[i], NULL);
    pthread_mutex_destroy(&x.lock);
    if (x.failed) {
        free(x.samples);
        free(x.tile_counters);
        return mprt__grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "render: out of memory for a worker's ray stack");
    }
    /* Pixels: samples as they are, or the mean of each pixel's four corners */
    mprt__samples_to_pixels(x.cam.corners, x.cam.samples_w, x.cam.samples_h, x.samples, rgb);
    if (counters) {
        int t, k;
        memset(counters, 0, sizeof *counters);
        for (t = 0; t < ntiles; t++) {
            const mprt_counters *tc = &x.tile_counters[t];
            counters->eye_rays += tc->eye_rays;
            counters->eye_hits += tc->eye_hits;
            counters->reflect_rays += tc->reflect_rays;
            counters->refract_rays += tc->refract_rays;
            counters->shadow_rays += tc->shadow_rays;
            counters->suppressed_rays += tc->suppressed_rays;
            counters->voxels_traversed += tc->voxels_traversed;
            for (k = 0; k < MPRT_NKINDS; k++) counters->tests[k] += tc->tests[k];
            counters->polygon_vertices += tc->polygon_vertices;
            counters->hits += tc->hits;
            counters->os_visits += tc->os_visits;
            counters->ic_visits += tc->ic_visits;
            counters->sc_visits += tc->sc_visits;
        }
    }
    free(x.samples);
    free(x.tile_counters);
    return MPRT_OK;
}
