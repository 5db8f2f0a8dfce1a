/* scene.c: scene storage, validation of every entity added, the mark and
 * rollback of a failed load, and the refusal of changes while grids use the
 * scene.  Queries (summary, arrays) are in scene_query.c. */
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
    case MPRT_ERR_LIMIT: return "work limit reached";
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
    if (pthread_mutex_init(&s->grids_lock, NULL) != 0) {
        free(s);
        return MPRT_ERR_OUT_OF_MEMORY;
    }
    *out = s;
    return MPRT_OK;
}

static void free_scene(mprt_scene *s)
{
    free(s->prims);
    free(s->spheres);
    free(s->polygons);
    free(s->cones);
    free(s->verts);
    free(s->vnormals);
    free(s->materials);
    free(s->lights);
    pthread_mutex_destroy(&s->grids_lock);
    free(s);
}

void mprt_scene_destroy(mprt_scene *s)
{
    int grids;
    if (!s) return;
    pthread_mutex_lock(&s->grids_lock);
    grids = s->grids;
    s->destroyed = grids > 0;
    pthread_mutex_unlock(&s->grids_lock);
    if (grids == 0) free_scene(s);       /* else the last grid's destruction frees it */
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

const char *mprt_scene_notes(const mprt_scene *s) { return s ? s->notes : "no scene"; }

void mprt__scene_note(mprt_scene *s, const char *fmt, ...)
{
    static const char cut[] = "...\n";
    size_t used = strlen(s->notes), cap = sizeof s->notes;
    va_list ap;
    if (used + sizeof cut > cap) return; /* already full (ends in "...") */
    va_start(ap, fmt);
    mprt__vformat(s->notes + used, cap - used - 1, fmt, ap);
    va_end(ap);
    used = strlen(s->notes);
    if (used + 1 + sizeof cut > cap) memcpy(s->notes + cap - sizeof cut, cut, sizeof cut); /* cut short */
    else memcpy(s->notes + used, "\n", 2);
}

static vec3 tovec(const double *p) { return v3((real)p[0], (real)p[1], (real)p[2]); }

/* Finite, and representable in the build's precision (float for MPRT_SINGLE). */
static int finite1(double x) { return isfinite(x) && fabs(x) <= (double)REAL_MAX; }
static int finite3(const double *p) { return finite1(p[0]) && finite1(p[1]) && finite1(p[2]); }

/* A coordinate or length of geometry (positions, radii, the hither
 * distance): finite and at most COORD_LIMIT in magnitude, so that the
 * products intersection and shading form (squares of coordinates) stay
 * finite.  A sphere of radius 1e301 would otherwise be hit at t = inf. */
#ifdef MPRT_SINGLE
#define COORD_LIMIT 1e18
#define BAD_COORD "NaN, infinite or over 1e18 in magnitude"
#else
#define COORD_LIMIT 1e100
#define BAD_COORD "NaN, infinite or over 1e100 in magnitude"
#endif
static int coord1(double x) { return isfinite(x) && fabs(x) <= COORD_LIMIT; }
static int coord3(const double *p) { return coord1(p[0]) && coord1(p[1]) && coord1(p[2]); }

vec3 mprt__unit_normal(const double *p)
{
    vec3 n = tovec(p);
    real l2 = vdot(n, n), big;
    if (fabs((double)l2 - 1) <= 4 * (double)REAL_EPS) return n;
    /* Scaled first, so that a very long or very short normal keeps its direction */
    big = vmaxabs(n);
    return big > 0 ? vnorm(v3(n.x / big, n.y / big, n.z / big)) : n;
}

int mprt_scene_set_view(mprt_scene *s, const double from[3], const double at[3],
                        const double up[3], double angle, double hither, int width, int height)
{
    vec3 f, a, u, dir;
    if (!s || !from || !at || !up) return MPRT_ERR_INVALID_ARG;
    if (mprt__scene_check_unshared(s, "set_view") != MPRT_OK) return MPRT_ERR_STATE;
    if (!coord3(from) || !coord3(at) || !coord3(up) || !isfinite(angle) || !coord1(hither))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "view: a value is " BAD_COORD);
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
    if (mprt__scene_check_unshared(s, "set_background") != MPRT_OK) return MPRT_ERR_STATE;
    if (!finite3(rgb)) return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "background: NaN or infinite colour");
    memcpy(s->background, rgb, sizeof s->background);
    return MPRT_OK;
}

int mprt_scene_add_light(mprt_scene *s, const double pos[3], const double *rgb)
{
    int st;
    mprt__light *l;
    if (!s || !pos) return MPRT_ERR_INVALID_ARG;
    if (mprt__scene_check_unshared(s, "add_light") != MPRT_OK) return MPRT_ERR_STATE;
    if (!coord3(pos)) return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "light: a position value is " BAD_COORD);
    if (rgb && !finite3(rgb)) return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "light: NaN or infinite colour");
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
    if (mprt__scene_check_unshared(s, "set_material") != MPRT_OK) return MPRT_ERR_STATE;
    if (!finite3(rgb) || !isfinite(kd) || !isfinite(ks) || !isfinite(shine) || !isfinite(t) || !isfinite(ior))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "material: NaN or infinite value");
    /* Weights are fractions of the light a ray carries, so each child ray of
     * a hit carries no more than its parent (at total internal reflection
     * the one reflection ray carries min(Ks + T, 1)): along every path the
     * weight cannot grow, and the contribution cutoff ends it.  Ks + T may
     * exceed 1 (the glass of many NFF files, .9 and .9): the tree is then
     * wider, and the ray budget of a sample bounds it.  Colours and Shine are
     * not fractions and may exceed 1. */
    if (!(kd >= 0 && kd <= 1) || !(ks >= 0 && ks <= 1) || !(t >= 0 && t <= 1))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "material: Kd %g, Ks %g and T %g must each be in [0, 1]", kd,
                                ks, t);
    if (shine < 0) return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "material: Shine %g is negative", shine);
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
    if (mprt__scene_check_unshared(s, "add_sphere") != MPRT_OK) return MPRT_ERR_STATE;
    if (!coord3(center) || !coord1(radius))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "sphere: a value is " BAD_COORD);
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
    if (mprt__scene_check_unshared(s, "add_polygon") != MPRT_OK) return MPRT_ERR_STATE;
    if (n < 3) return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "polygon: %d vertices, at least 3 needed", n);
    for (i = 0; i < n; i++) {
        if (!coord3(verts + 3 * i))
            return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "polygon: a value of vertex %d is " BAD_COORD, i + 1);
        if (normals && !finite3(normals + 3 * i))
            return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "polygon: NaN or infinite normal at vertex %d", i + 1);
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
        if (s->vnormals) s->vnormals[s->nverts + i] = normals ? mprt__unit_normal(normals + 3 * i) : v3(0, 0, 0);
    }
    memset(&p, 0, sizeof p);
    p.first = (int)s->nverts;
    p.n = n;
    p.has_normals = normals != NULL;
    if (reason) *reason = 0;
    if ((why = mprt__polygon_prepare(&p, s->verts, err, sizeof err)) != 0) {
        if (reason) *reason = why;
        if (reason && why == MPRT__DEGENERATE) return MPRT_ERR_INVALID_ARG; /* the caller drops it */
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
    if (mprt__scene_check_unshared(s, "add_cone") != MPRT_OK) return MPRT_ERR_STATE;
    if (!coord3(base) || !coord3(apex) || !coord1(base_r) || !coord1(apex_r))
        return mprt__scene_fail(s, MPRT_ERR_INVALID_ARG, "cone: a value is " BAD_COORD);
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

int mprt__prim_bounds(const mprt_scene *s, long long i, vec3 *lo, vec3 *hi)
{
    const mprt__prim *p = &s->prims[i];
    switch (p->kind) {
    case MPRT_SPHERE: mprt__sphere_bounds(&s->spheres[p->index], lo, hi); return MPRT_OK;
    case MPRT_POLYGON: mprt__polygon_bounds(&s->polygons[p->index], s->verts, lo, hi); return MPRT_OK;
    case MPRT_CYLINDER:
    case MPRT_CONE: mprt__cone_bounds(&s->cones[p->index], lo, hi); return MPRT_OK;
    default: return MPRT_ERR_STATE;
    }
}

/* ---- Mark and rollback ---------------------------------------------------- */

/* The contents are the bytes from nprims up to errmsg (see struct mprt_scene). */
void mprt__scene_mark(const mprt_scene *s, mprt__scene_saved *saved)
{
    memcpy(saved->bytes, (const unsigned char *)s + offsetof(struct mprt_scene, nprims), sizeof saved->bytes);
}

void mprt__scene_rollback(mprt_scene *s, const mprt__scene_saved *saved)
{
    memcpy((unsigned char *)s + offsetof(struct mprt_scene, nprims), saved->bytes, sizeof saved->bytes);
}

/* ---- Grids on the scene ------------------------------------------------------ */

void mprt__scene_count_grid(const mprt_scene *scene, int delta)
{
    /* The grid count is bookkeeping, not content: a const scene counts too */
    mprt_scene *s = (mprt_scene *)(uintptr_t)scene;
    int gone;
    pthread_mutex_lock(&s->grids_lock);
    s->grids += delta;
    gone = s->destroyed && s->grids == 0;
    pthread_mutex_unlock(&s->grids_lock);
    if (gone) free_scene(s);             /* destroyed while this grid was left */
}

int mprt__scene_check_unshared(mprt_scene *s, const char *call)
{
    int grids;
    pthread_mutex_lock(&s->grids_lock);
    grids = s->grids;
    pthread_mutex_unlock(&s->grids_lock);
    if (grids == 0) return MPRT_OK;
    return mprt__scene_fail(s, MPRT_ERR_STATE, "%s: the scene has %d grid%s; a scene cannot change while grids use it",
                            call, grids, grids == 1 ? "" : "s");
}
