/* shade.c: SC, the shading calculation.  A ray that IC (or OS at the end of
 * its walk) found a hit for comes to SC, which adds the surface's ambient
 * light to the sample and makes the ray's children: a shadow ray toward each
 * light (carrying the light it would add), a reflection ray and a refraction
 * ray.  Paper rules drop a child whose contribution falls under the
 * threshold; both rules drop children beyond the depth limit.  The two rule
 * sets differ in which surfaces reflect (see the secondary rays below) and
 * in the shadow rays (spd: none toward a light behind the surface, Phong
 * highlights; paper: one per light, cut by the threshold). */
#include "render.h"

#include <string.h>

#define INF_REAL ((real)INFINITY)

/* Offset that keeps a secondary ray off the surface it starts on: scaled to
 * the hit point's magnitude, so it works at any scene scale. */
static real surface_offset(vec3 p) { return (vmaxabs(p) + R(1e-30)) * REAL_EPS * R(512); }

static vec3 reflect_dir(vec3 d, vec3 n) { return vnorm(vsub(d, vscale(n, 2 * vdot(d, n)))); }

/* Shading normal of primitive id at p; flags a primitive of unknown kind. */
static vec3 shading_normal(const mprt_scene *s, int32_t id, vec3 p, mprt__sink *sink)
{
    const mprt__prim *prim = &s->prims[id];
    switch (prim->kind) {
    case MPRT_SPHERE: return mprt__sphere_normal(&s->spheres[prim->index], p);
    case MPRT_POLYGON: return mprt__polygon_normal(&s->polygons[prim->index], s->verts, s->vnormals, p);
    case MPRT_CYLINDER:
    case MPRT_CONE: return mprt__cone_normal(&s->cones[prim->index], p);
    default:
        sink->bad_prim = id;
        return v3(0, 0, 1);
    }
}

/* Whether a child ray of this contribution and depth is made. */
static int keep_child(const mprt_render_desc *desc, double contribution, int depth)
{
    return !(depth > desc->max_depth || (desc->rules != MPRT_RULES_SPD && contribution < desc->threshold));
}

/* The children of one SC visit, made in order. */
typedef struct {
    const mprt__tree_ray *parent;
    int sample;
    vec3 origin;        /* the hit point */
    real offset;        /* children start this far from it */
    mprt__tree_ray *kids;
    int made, suppressed;
    mprt__sink *sink;
} children;

/* Make a child ray of kind (numbered and counted); returns it for the
 * caller to finish (shadow rays: their light). */
static mprt__tree_ray *make_child(children *ch, int kind, vec3 dir, real tmax, double contribution, int depth,
                                  int light)
{
    mprt__tree_ray *kid = &ch->kids[ch->made++];
    memset(kid, 0, sizeof *kid);
    kid->origin = ch->origin;
    kid->dir = dir;
    kid->tmin = ch->offset;
    kid->tmax = tmax;
    kid->contribution = contribution;
    kid->kind = kind;
    kid->depth = depth;
    kid->id = mprt__emit_ray(ch->sink, ch->parent->id, kind, depth, ch->sample, light, contribution);
    return kid;
}

void mprt__sc_shade(const mprt__render_setup *setup, const mprt__tree_ray *ray, mprt__hit hit, int sample,
                    double rgb[3], mprt__tree_ray *stack, int *top, mprt__sink *sink)
{
    const mprt_scene *s = setup->scene;
    const mprt_render_desc *desc = &setup->desc;
    const mprt__material *m = &s->materials[s->prims[hit.prim].material];
    vec3 p = vmadd(ray->origin, ray->dir, hit.t);
    vec3 n = shading_normal(s, hit.prim, p, sink);
    int entering = 1, tir = 0, l, i, spd = desc->rules == MPRT_RULES_SPD, all;
    vec3 refract = v3(0, 0, 0);
    double cosi;
    children ch;
    mprt__visit sc;

    /* Whether SC counts both secondary candidates at this hit */
    all = desc->candidates == MPRT_CANDIDATES_ALL ||
          (desc->candidates == MPRT_CANDIDATES_SPECULAR && (m->ks > 0 || m->t > 0));
    ch.parent = ray;
    ch.sample = sample;
    ch.origin = p;
    ch.offset = desc->offset == MPRT_OFFSET_NONE ? 0 : surface_offset(p);
    ch.kids = stack + *top;
    ch.made = ch.suppressed = 0;
    ch.sink = sink;
    /* Face the normal toward the incoming ray */
    if (vdot(n, ray->dir) > 0) {
        n = vscale(n, -1);
        entering = 0;
    }
    cosi = -(double)vdot(n, ray->dir);
    rgb[0] += ray->contribution * desc->ambient * m->rgb[0];
    rgb[1] += ray->contribution * desc->ambient * m->rgb[1];
    rgb[2] += ray->contribution * desc->ambient * m->rgb[2];

    /* Shadow rays, one per light */
    for (l = 0; l < (int)s->nlights; l++) {
        const mprt__light *light = &s->lights[l];
        vec3 to = vsub(light->pos, p);
        real dist = vlen(to);
        double ndl, lum, spec = 0, carried[3];
        mprt__tree_ray *kid;
        if (!(dist > ch.offset)) continue;
        to = vscale(to, 1 / dist);
        ndl = (double)vdot(n, to);
        /* A light behind the surface: no candidate (spd), a ray cast
         * whatever the threshold, or a candidate carrying 0 (paper) */
        if (ndl <= 0 && desc->behind == MPRT_BEHIND_SKIP) continue;
        lum = (ndl > 0 ? ndl : 0) * m->kd * ray->contribution;
        if (spd && m->ks > 0) {
            double rv = (double)vdot(reflect_dir(ray->dir, n), to);
            if (rv > 0) spec = m->ks * pow(rv, m->shine) * ray->contribution;
        }
        if (!(ndl <= 0 && desc->behind == MPRT_BEHIND_CAST)) {
            /* The threshold compares N.L Kd contribution, times the light's
             * mean intensity unless the surface term alone */
            double grey = desc->shadow_term == MPRT_SHADOW_SURFACE ? 1
                          : light->has_rgb ? (light->rgb[0] + light->rgb[1] + light->rgb[2]) / 3
                                           : setup->light_rgb_default;
            if (!keep_child(desc, lum * grey, ray->depth)) {
                ch.suppressed++;
                continue;
            }
        }
        for (i = 0; i < 3; i++) {
            double li = light->has_rgb ? light->rgb[i] : setup->light_rgb_default;
            carried[i] = li * (lum * m->rgb[i] + spec);
        }
        kid = make_child(&ch, MPRT_RAY_SHADOW, to, dist, ray->contribution, ray->depth, l);
        memcpy(kid->light_rgb, carried, sizeof carried);
    }
    /* Secondary rays.  Refraction follows Snell's law; at total internal
     * reflection (TIR) there is no refraction ray and the transmitted share
     * goes to the reflection ray instead, so one reflection ray carries
     * Ks + T, at most 1 (never two rays along the same direction; a child
     * never outweighs its parent, even where Ks + T is over 1).  Paper rules make a
     * reflection ray when Ks > 0 or at TIR.  SPD rules (its Readme, rules 8
     * and 9) make one on every reflective or transmitting surface: on a
     * transmitting surface with Ks = 0 it carries no weight (contribution
     * 0), so it changes the ray counts but not the image. */
    if (m->t > 0) {
        double eta = entering ? 1 / m->ior : m->ior;
        double k = 1 - eta * eta * (1 - cosi * cosi);
        tir = k < 0;
        if (!tir) refract = vnorm(vadd(vscale(ray->dir, (real)eta), vscale(n, (real)(eta * cosi - sqrt(k)))));
    }
    if (m->ks > 0 || tir || (spd && m->t > 0)) {
        double w = ray->contribution * fmin(m->ks + (tir ? m->t : 0), 1.0);
        if (keep_child(desc, w, ray->depth + 1))
            make_child(&ch, MPRT_RAY_REFLECT, reflect_dir(ray->dir, n), INF_REAL, w, ray->depth + 1, -1);
        else
            ch.suppressed++;
    } else if (all) {
        ch.suppressed++; /* a reflection candidate of weight 0 */
    }
    if (m->t > 0 && !tir) {
        double w = ray->contribution * m->t;
        if (keep_child(desc, w, ray->depth + 1))
            make_child(&ch, MPRT_RAY_REFRACT, refract, INF_REAL, w, ray->depth + 1, -1);
        else
            ch.suppressed++;
    } else if (all && !(m->t > 0)) {
        ch.suppressed++; /* a refraction candidate of weight 0 */
    }
    mprt__visit_init(&sc, ray->id, ray->kind, MPRT_STAGE_SC, MPRT_OUT_SHADED);
    sc.prim = hit.prim;
    sc.made = ch.made;
    sc.suppressed = ch.suppressed;
    sc.tir = tir && ray->depth + 1 <= desc->max_depth;
    mprt__emit_visit(sink, &sc);
    /* Push in reverse so the children are traced in the order made */
    for (i = 0; i < ch.made / 2; i++) {
        mprt__tree_ray tmp = ch.kids[i];
        ch.kids[i] = ch.kids[ch.made - 1 - i];
        ch.kids[ch.made - 1 - i] = tmp;
    }
    *top += ch.made;
}
