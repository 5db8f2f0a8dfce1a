/* scene.c: scene storage, validation of every entity added, summary. */
#include "mprt_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *mprt_status_str(int status)
{
    switch (status) {
    case MPRT_OK: return "ok";
    case MPRT_ERR_INVALID_ARG: return "invalid argument";
    case MPRT_ERR_OUT_OF_MEMORY: return "out of memory";
    case MPRT_ERR_STATE: return "call not allowed in this state";
    case MPRT_ERR_CAPACITY: return "buffer too small";
    case MPRT_ERR_PARSE: return "parse error";
    case MPRT_ERR_IO: return "input/output error";
    default: return "unknown status";
    }
}

void mprt__vformat(char *buf, size_t cap, const char *fmt, va_list ap)
{
    if (cap == 0) return;
    vsnprintf(buf, cap, fmt, ap);
    buf[cap - 1] = '\0';
}

int mprt__scene_fail(mprt_scene *scene, int status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    mprt__vformat(scene->errmsg, sizeof scene->errmsg, fmt, ap);
    va_end(ap);
    return status;
}

/* Grow an array so it holds at least need elements. */
static int grow(void **ptr, long long *cap, long long need, size_t elem)
{
    long long n;
    void *p;
    if (need <= *cap) return 0;
    n = *cap ? *cap : 16;
    while (n < need) n *= 2;
    if ((unsigned long long)n > (unsigned long long)(SIZE_MAX / elem)) return -1;
    p = realloc(*ptr, (size_t)n * elem);
    if (!p) return -1;
    *ptr = p;
    *cap = n;
    return 0;
}

#define GROW(scene, arr, count, cap, extra)                                                  \
    (grow((void **)&(scene)->arr, &(scene)->cap, (scene)->count + (extra), sizeof *(scene)->arr) \
         ? mprt__scene_fail((scene), MPRT_ERR_OUT_OF_MEMORY, "out of memory growing " #arr)   \
         : MPRT_OK)

int mprt_scene_create(mprt_scene **out)
{
    mprt_scene *s;
    if (!out) return MPRT_ERR_INVALID_ARG;
    *out = NULL;
    s = calloc(1, sizeof *s);
    if (!s) return MPRT_ERR_OUT_OF_MEMORY;
    s->material = -1;
    s->from = v3(0, 0, 1);
    s->at = v3(0, 0, 0);
    s->up = v3(0, 1, 0);
    s->angle = 45;
    s->hither = 0;
    s->width = s->height = 512;
    *out = s;
    return MPRT_OK;
}

void mprt_scene_destroy(mprt_scene *s)
{
    if (!s) return;
    free(s->prims);
    free(s->spheres);
    free(s->polygons);
    free(s->cones);
    free(s->verts);
    free(s->vnormals);
    free(s->materials);
    free(s->lights);
    free(s);
}

const char *mprt_scene_errmsg(const mprt_scene *s) { return s ? s->errmsg : "no scene"; }
const char *mprt_scene_warning(const mprt_scene *s) { return s ? s->warning : "no scene"; }

void mprt__scene_warn(mprt_scene *s, const char *fmt, ...)
{
    va_list ap;
    if (s->dropped++ == 0) {
        va_start(ap, fmt);
        mprt__vformat(s->warning, sizeof s->warning, fmt, ap);
        va_end(ap);
    }
}

static vec3 tovec(const double *p) { return v3((real)p[0], (real)p[1], (real)p[2]); }

/* Finite, and representable in the build's precision (float for MPRT_SINGLE). */
static int finite1(double x) { return isfinite(x) && fabs(x) <= (double)REAL_MAX; }
static int finite3(const double *p) { return finite1(p[0]) && finite1(p[1]) && finite1(p[2]); }

/* A vertex normal, normalised unless it already is (so NFF round trips are exact). */
static vec3 unit_normal(const double *p)
{
    vec3 n = tovec(p);
    real l2 = vdot(n, n);
    if (fabs((double)l2 - 1) <= 4 * (double)REAL_EPS) return n;
    return vnorm(n);
}

int mprt_scene_set_view(mprt_scene *s, const double from[3], const double at[3],
                        const double up[3], double angle, double hither, int width, int height)
{
    vec3 f, a, u, dir;
    if (!s || !from || !at || !up) return MPRT_ERR_INVALID_ARG;
    if (!finite3(from) || !finite3(at) || !finite3(up) || !isfinite(angle) || !finite1(hither))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "view: NaN or infinite value");
    if (!(angle > 0 && angle < 180))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "view: angle %g is not in (0, 180) degrees", angle);
    if (hither < 0)
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "view: hither %g is negative", hither);
    if (width < 1 || height < 1 || width > 65536 || height > 65536)
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "view: resolution %dx%d is not in 1..65536", width, height);
    f = tovec(from);
    a = tovec(at);
    u = tovec(up);
    dir = vsub(a, f);
    if (vdot(dir, dir) == 0)
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "view: 'from' and 'at' are the same point");
    if (vdot(vcross(dir, u), vcross(dir, u)) == 0)
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "view: 'up' is zero or parallel to the view direction");
    s->from = f;
    s->at = a;
    s->up = u;
    s->angle = angle;
    s->hither = hither;
    s->width = width;
    s->height = height;
    return MPRT_OK;
}

int mprt_scene_set_background(mprt_scene *s, const double rgb[3])
{
    if (!s || !rgb) return MPRT_ERR_INVALID_ARG;
    if (!finite3(rgb)) return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "background: NaN or infinite colour");
    memcpy(s->background, rgb, sizeof s->background);
    return MPRT_OK;
}

int mprt_scene_add_light(mprt_scene *s, const double pos[3], const double *rgb)
{
    int st;
    mprt__light *l;
    if (!s || !pos) return MPRT_ERR_INVALID_ARG;
    if (!finite3(pos) || (rgb && !finite3(rgb)))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "light: NaN or infinite value");
    if ((st = GROW(s, lights, nlights, caplights, 1)) != MPRT_OK) return st;
    l = &s->lights[s->nlights++];
    l->pos = tovec(pos);
    l->has_rgb = rgb != NULL;
    if (rgb) memcpy(l->rgb, rgb, sizeof l->rgb);
    else l->rgb[0] = l->rgb[1] = l->rgb[2] = 1;
    return MPRT_OK;
}

int mprt_scene_set_material(mprt_scene *s, const double rgb[3], double kd, double ks,
                            double shine, double t, double ior)
{
    int st;
    mprt__material *m;
    if (!s || !rgb) return MPRT_ERR_INVALID_ARG;
    if (!finite3(rgb) || !isfinite(kd) || !isfinite(ks) || !isfinite(shine) || !isfinite(t) || !isfinite(ior))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "material: NaN or infinite value");
    if (kd < 0 || ks < 0 || t < 0 || shine < 0)
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG,
                                "material: Kd %g, Ks %g, Shine %g and T %g must not be negative", kd, ks, shine, t);
    if (t > 0 && !(ior > 0))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG,
                                "material: index of refraction %g must be positive for a transmissive surface", ior);
    if ((st = GROW(s, materials, nmaterials, capmaterials, 1)) != MPRT_OK) return st;
    m = &s->materials[s->nmaterials];
    memcpy(m->rgb, rgb, sizeof m->rgb);
    m->kd = kd;
    m->ks = ks;
    m->shine = shine;
    m->t = t;
    m->ior = ior;
    s->material = (int)s->nmaterials++;
    return MPRT_OK;
}

/* Every primitive gets a material; before the first "f" a white diffuse one. */
static int need_material(mprt_scene *s)
{
    static const double white[3] = {1, 1, 1};
    if (s->material >= 0) return MPRT_OK;
    return mprt_scene_set_material(s, white, 1, 0, 0, 0, 1);
}

static int add_prim(mprt_scene *s, int kind, long long index)
{
    int st = GROW(s, prims, nprims, capprims, 1);
    if (st != MPRT_OK) return st;
    if (s->nprims >= 0x7fffffff) return mprt__scene_fail(s, MPRT_ERR_OUT_OF_MEMORY, "too many primitives");
    s->prims[s->nprims].kind = kind;
    s->prims[s->nprims].index = (int)index;
    s->prims[s->nprims].material = s->material;
    s->nprims++;
    return MPRT_OK;
}

int mprt_scene_add_sphere(mprt_scene *s, const double center[3], double radius)
{
    int st;
    if (!s || !center) return MPRT_ERR_INVALID_ARG;
    if (!finite3(center) || !finite1(radius))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "sphere: NaN or infinite value");
    if (!(radius > 0))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "sphere: radius %g is not positive", radius);
    if ((st = need_material(s)) != MPRT_OK) return st;
    if ((st = GROW(s, spheres, nspheres, capspheres, 1)) != MPRT_OK) return st;
    s->spheres[s->nspheres].c = tovec(center);
    s->spheres[s->nspheres].r = (real)radius;
    if ((st = add_prim(s, MPRT_SPHERE, s->nspheres)) != MPRT_OK) return st;
    s->nspheres++;
    return MPRT_OK;
}

int mprt_scene_add_polygon(mprt_scene *s, int n, const double *verts, const double *normals)
{
    return mprt__scene_add_polygon(s, n, verts, normals, NULL);
}

int mprt__scene_add_polygon(mprt_scene *s, int n, const double *verts, const double *normals, int *reason)
{
    int st, i, why;
    mprt__polygon p;
    char err[200];
    if (!s || !verts) return MPRT_ERR_INVALID_ARG;
    if (n < 3) return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "polygon: %d vertices, at least 3 needed", n);
    for (i = 0; i < n; i++) {
        if (!finite3(verts + 3 * i) || (normals && !finite3(normals + 3 * i)))
            return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "polygon: NaN or infinite value at vertex %d", i + 1);
    }
    if ((st = need_material(s)) != MPRT_OK) return st;
    if ((st = GROW(s, verts, nverts, capverts, n)) != MPRT_OK) return st;
    if (normals || s->vnormals) {
        /* vnormals is parallel to verts once any patch exists; zero before it */
        int fresh = s->vnormals == NULL;
        if (grow((void **)&s->vnormals, &s->capvnormals, s->capverts, sizeof *s->vnormals))
            return mprt__scene_fail(s, MPRT_ERR_OUT_OF_MEMORY, "out of memory growing vnormals");
        if (fresh && s->nverts) memset(s->vnormals, 0, (size_t)s->nverts * sizeof *s->vnormals);
    }
    for (i = 0; i < n; i++) {
        s->verts[s->nverts + i] = tovec(verts + 3 * i);
        if (s->vnormals) s->vnormals[s->nverts + i] = normals ? unit_normal(normals + 3 * i) : v3(0, 0, 0);
    }
    memset(&p, 0, sizeof p);
    p.first = (int)s->nverts;
    p.n = n;
    p.has_normals = normals != NULL;
    if (reason) *reason = 0;
    if ((why = mprt__polygon_prepare(&p, s->verts, err, sizeof err)) != 0) {
        if (reason) *reason = why;
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "polygon: %s", err);
    }
    if (normals) {
        for (i = 0; i < n; i++) {
            vec3 vn = s->vnormals[s->nverts + i];
            if (vdot(vn, vn) == 0)
                return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "polygon patch: zero normal at vertex %d", i + 1);
        }
    }
    if ((st = GROW(s, polygons, npolygons, cappolygons, 1)) != MPRT_OK) return st;
    s->polygons[s->npolygons] = p;
    if ((st = add_prim(s, MPRT_POLYGON, s->npolygons)) != MPRT_OK) return st;
    s->npolygons++;
    s->nverts += n;
    if (normals) s->npatches++;
    return MPRT_OK;
}

int mprt_scene_add_cone(mprt_scene *s, const double base[3], double base_r, const double apex[3],
                        double apex_r)
{
    int st;
    mprt__cone c;
    char err[200];
    if (!s || !base || !apex) return MPRT_ERR_INVALID_ARG;
    if (!finite3(base) || !finite3(apex) || !finite1(base_r) || !finite1(apex_r))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "cone: NaN or infinite value");
    memset(&c, 0, sizeof c);
    c.base = tovec(base);
    c.apex = tovec(apex);
    c.rb = (real)base_r;
    c.ra = (real)apex_r;
    if (mprt__cone_prepare(&c, err, sizeof err))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "cone: %s", err);
    if ((st = need_material(s)) != MPRT_OK) return st;
    if ((st = GROW(s, cones, ncones, capcones, 1)) != MPRT_OK) return st;
    s->cones[s->ncones] = c;
    if ((st = add_prim(s, c.rb == c.ra ? MPRT_CYLINDER : MPRT_CONE, s->ncones)) != MPRT_OK) return st;
    s->ncones++;
    if (c.rb == c.ra) s->ncylinders++;
    return MPRT_OK;
}

void mprt__prim_bounds(const mprt_scene *s, long long i, vec3 *lo, vec3 *hi)
{
    const mprt__prim *p = &s->prims[i];
    switch (p->kind) {
    case MPRT_SPHERE: mprt__sphere_bounds(&s->spheres[p->index], lo, hi); break;
    case MPRT_POLYGON: mprt__polygon_bounds(&s->polygons[p->index], s->verts, lo, hi); break;
    default: mprt__cone_bounds(&s->cones[p->index], lo, hi); break;
    }
}

int mprt_scene_get_info(const mprt_scene *s, mprt_scene_info *info)
{
    long long i;
    vec3 lo = v3(0, 0, 0), hi = v3(0, 0, 0);
    if (!s || !info) return MPRT_ERR_INVALID_ARG;
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
    for (i = 0; i < s->nprims; i++) {
        vec3 a, b;
        mprt__prim_bounds(s, i, &a, &b);
        if (i == 0) { lo = a; hi = b; continue; }
        lo = v3(a.x < lo.x ? a.x : lo.x, a.y < lo.y ? a.y : lo.y, a.z < lo.z ? a.z : lo.z);
        hi = v3(b.x > hi.x ? b.x : hi.x, b.y > hi.y ? b.y : hi.y, b.z > hi.z ? b.z : hi.z);
    }
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

int mprt_scene_load_nff(mprt_scene *s, const char *path)
{
    FILE *f;
    char *buf;
    long len;
    size_t got;
    int st;
    if (!s || !path) return MPRT_ERR_INVALID_ARG;
    f = fopen(path, "rb");
    if (!f) return mprt__scene_fail(s, MPRT_ERR_IO, "%s: cannot open for reading", path);
    if (fseek(f, 0, SEEK_END) != 0 || (len = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        return mprt__scene_fail(s, MPRT_ERR_IO, "%s: cannot determine the file size", path);
    }
    buf = malloc((size_t)len + 1);
    if (!buf) {
        fclose(f);
        return mprt__scene_fail(s, MPRT_ERR_OUT_OF_MEMORY, "%s: out of memory reading %ld bytes", path, len);
    }
    got = fread(buf, 1, (size_t)len, f);
    fclose(f);
    if (got != (size_t)len) {
        free(buf);
        return mprt__scene_fail(s, MPRT_ERR_IO, "%s: read failed", path);
    }
    buf[len] = '\0';
    st = mprt__nff_parse(s, buf, (size_t)len, path);
    free(buf);
    return st;
}

int mprt_scene_parse_nff(mprt_scene *s, const char *text, size_t len, const char *name)
{
    if (!s || (!text && len)) return MPRT_ERR_INVALID_ARG;
    return mprt__nff_parse(s, text ? text : "", len, name ? name : "<string>");
}

int mprt_scene_write_nff(const mprt_scene *s, char *buf, size_t cap, size_t *needed)
{
    if (!s || !needed || (!buf && cap)) return MPRT_ERR_INVALID_ARG;
    return mprt__nff_write(s, buf, cap, needed);
}

int mprt_scene_spd(mprt_scene *s, const char *name, int size)
{
    if (!s || !name) return MPRT_ERR_INVALID_ARG;
    return mprt__spd_generate(s, name, size);
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
        words[i] = p->kind == MPRT_SPHERE ? 4 : p->kind == MPRT_POLYGON ? 3 * s->polygons[p->index].n + 4 : 8;
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
