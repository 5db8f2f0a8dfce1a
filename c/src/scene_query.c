/* scene_query.c: what a scene holds, read back: its summary, each
 * primitive's kind, size and material, and the shapes, materials and lights
 * as arrays (the values the renderer uses). */
#include "mprt_internal.h"

#include <string.h>

int mprt__scene_bounds(const mprt_scene *s, vec3 *lo, vec3 *hi, long long *bad_prim)
{
    long long i;
    *lo = *hi = v3(0, 0, 0);
    for (i = 0; i < s->nprims; i++) {
        vec3 a, b;
        if (mprt__prim_bounds(s, i, &a, &b) != MPRT_OK) {
            *bad_prim = i;
            return MPRT_ERR_STATE;
        }
        if (i == 0) {
            *lo = a;
            *hi = b;
            continue;
        }
        *lo = v3(a.x < lo->x ? a.x : lo->x, a.y < lo->y ? a.y : lo->y, a.z < lo->z ? a.z : lo->z);
        *hi = v3(b.x > hi->x ? b.x : hi->x, b.y > hi->y ? b.y : hi->y, b.z > hi->z ? b.z : hi->z);
    }
    return MPRT_OK;
}

int mprt_scene_get_info(const mprt_scene *s, mprt_scene_info *info)
{
    long long bad;
    vec3 lo, hi;
    if (!s || !info) return MPRT_ERR_INVALID_ARG;
    if (mprt__scene_bounds(s, &lo, &hi, &bad) != MPRT_OK) return MPRT_ERR_STATE;
    memset(info, 0, sizeof *info);
    info->prims = s->nprims;
    info->count[MPRT_SPHERE] = s->nspheres;
    info->count[MPRT_POLYGON] = s->npolygons;
    info->count[MPRT_CYLINDER] = s->ncylinders;
    info->count[MPRT_CONE] = s->ncones - s->ncylinders;
    info->patches = s->npatches;
    info->vertices = s->nverts;
    info->lights = s->nlights;
    info->materials = s->nmaterials;
    info->dropped = s->dropped;
    info->lo[0] = lo.x; info->lo[1] = lo.y; info->lo[2] = lo.z;
    info->hi[0] = hi.x; info->hi[1] = hi.y; info->hi[2] = hi.z;
    info->from[0] = s->from.x; info->from[1] = s->from.y; info->from[2] = s->from.z;
    info->at[0] = s->at.x; info->at[1] = s->at.y; info->at[2] = s->at.z;
    info->up[0] = s->up.x; info->up[1] = s->up.y; info->up[2] = s->up.z;
    info->angle = s->angle;
    info->hither = s->hither;
    info->width = s->width;
    info->height = s->height;
    memcpy(info->background, s->background, sizeof info->background);
    return MPRT_OK;
}

int mprt_scene_get_prims(const mprt_scene *s, int32_t *kind, int32_t *words, int32_t *material, size_t cap)
{
    long long i;
    if (!s || !kind || !words || !material) return MPRT_ERR_INVALID_ARG;
    if (cap < (size_t)s->nprims) return MPRT_ERR_CAPACITY;
    for (i = 0; i < s->nprims; i++) {
        const mprt__prim *p = &s->prims[i];
        kind[i] = p->kind;
        material[i] = p->material;
        switch (p->kind) {
        case MPRT_SPHERE: words[i] = 4; break;                                   /* centre, radius */
        case MPRT_POLYGON: words[i] = 3 * s->polygons[p->index].n + 4; break;    /* vertices, plane */
        case MPRT_CYLINDER:
        case MPRT_CONE: words[i] = 8; break;                                     /* two discs */
        default: return MPRT_ERR_STATE;
        }
    }
    return MPRT_OK;
}

/* ---- Shape data by kind ---------------------------------------------------
 * Each getter walks the primitive table in id order and copies the entries
 * of its kinds; a NULL buffer is allowed when the scene has none of them. */

/* Primitives of kind a or kind b. */
static long long count_kinds(const mprt_scene *s, int a, int b)
{
    long long i, n = 0;
    for (i = 0; i < s->nprims; i++) n += s->prims[i].kind == a || s->prims[i].kind == b;
    return n;
}

static void put3(double *out, vec3 v)
{
    out[0] = (double)v.x;
    out[1] = (double)v.y;
    out[2] = (double)v.z;
}

int mprt_scene_get_spheres(const mprt_scene *s, int32_t *ids, double *data, size_t cap)
{
    long long i, n = 0;
    if (!s) return MPRT_ERR_INVALID_ARG;
    if (cap < (size_t)s->nspheres) return MPRT_ERR_CAPACITY;
    if (s->nspheres && (!ids || !data)) return MPRT_ERR_INVALID_ARG;
    for (i = 0; i < s->nprims; i++) {
        const mprt__sphere *sp;
        if (s->prims[i].kind != MPRT_SPHERE) continue;
        sp = &s->spheres[s->prims[i].index];
        ids[n] = (int32_t)i;
        put3(data + 4 * n, sp->c);
        data[4 * n + 3] = (double)sp->r;
        n++;
    }
    return MPRT_OK;
}

int mprt_scene_get_cones(const mprt_scene *s, int32_t *ids, double *data, size_t cap)
{
    long long i, n = 0, count;
    if (!s) return MPRT_ERR_INVALID_ARG;
    count = count_kinds(s, MPRT_CYLINDER, MPRT_CONE);
    if (cap < (size_t)count) return MPRT_ERR_CAPACITY;
    if (count && (!ids || !data)) return MPRT_ERR_INVALID_ARG;
    for (i = 0; i < s->nprims; i++) {
        const mprt__cone *c;
        if (s->prims[i].kind != MPRT_CYLINDER && s->prims[i].kind != MPRT_CONE) continue;
        c = &s->cones[s->prims[i].index];
        ids[n] = (int32_t)i;
        put3(data + 8 * n, c->base);
        data[8 * n + 3] = (double)c->rb;
        put3(data + 8 * n + 4, c->apex);
        data[8 * n + 7] = (double)c->ra;
        n++;
    }
    return MPRT_OK;
}

int mprt_scene_get_polygons(const mprt_scene *s, int32_t *ids, int32_t *vstart, size_t cap_polys, double *verts,
                            size_t cap_verts)
{
    long long i, n = 0, v = 0;
    if (!s || !vstart) return MPRT_ERR_INVALID_ARG;
    if (cap_polys < (size_t)s->npolygons || cap_verts < (size_t)s->nverts) return MPRT_ERR_CAPACITY;
    if (s->npolygons && (!ids || !verts)) return MPRT_ERR_INVALID_ARG;
    vstart[0] = 0;
    for (i = 0; i < s->nprims; i++) {
        const mprt__polygon *p;
        int k;
        if (s->prims[i].kind != MPRT_POLYGON) continue;
        p = &s->polygons[s->prims[i].index];
        ids[n] = (int32_t)i;
        for (k = 0; k < p->n; k++, v++) put3(verts + 3 * v, s->verts[p->first + k]);
        vstart[++n] = (int32_t)v;
    }
    return MPRT_OK;
}

int mprt_scene_get_materials(const mprt_scene *s, double *data, size_t cap)
{
    long long i;
    if (!s) return MPRT_ERR_INVALID_ARG;
    if (cap < (size_t)s->nmaterials) return MPRT_ERR_CAPACITY;
    if (s->nmaterials && !data) return MPRT_ERR_INVALID_ARG;
    for (i = 0; i < s->nmaterials; i++) {
        const mprt__material *m = &s->materials[i];
        double *out = data + 8 * i;
        out[0] = m->rgb[0];
        out[1] = m->rgb[1];
        out[2] = m->rgb[2];
        out[3] = m->kd;
        out[4] = m->ks;
        out[5] = m->shine;
        out[6] = m->t;
        out[7] = m->ior;
    }
    return MPRT_OK;
}

double mprt__light_default_rgb(const mprt_scene *s)
{
    return s->nlights ? 1 / sqrt((double)s->nlights) : 1;
}

int mprt_scene_get_lights(const mprt_scene *s, double *data, size_t cap)
{
    long long i;
    double dflt;
    if (!s) return MPRT_ERR_INVALID_ARG;
    if (cap < (size_t)s->nlights) return MPRT_ERR_CAPACITY;
    if (s->nlights && !data) return MPRT_ERR_INVALID_ARG;
    dflt = mprt__light_default_rgb(s);
    for (i = 0; i < s->nlights; i++) {
        const mprt__light *l = &s->lights[i];
        int k;
        put3(data + 6 * i, l->pos);
        for (k = 0; k < 3; k++) data[6 * i + 3 + k] = l->has_rgb ? l->rgb[k] : dflt;
    }
    return MPRT_OK;
}
