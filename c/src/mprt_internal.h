/* mprt_internal.h: types and functions shared by the library's files.
 * Nothing here is public API; internal symbols are prefixed mprt__. */
#ifndef MPRT_INTERNAL_H
#define MPRT_INTERNAL_H

#include "mprt.h"

#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>

#ifdef MPRT_SINGLE
typedef float real;
#define SQRT(x) sqrtf(x)
#define ABS(x) fabsf(x)
#define R(x) ((float)(x))
#define REAL_EPS 1.1920929e-07f
#define REAL_MAX 3.40282347e+38f
#else
typedef double real;
#define SQRT(x) sqrt(x)
#define ABS(x) fabs(x)
#define R(x) ((double)(x))
#define REAL_EPS 2.220446049250313e-16
#define REAL_MAX 1.7976931348623157e+308
#endif

typedef struct { real x, y, z; } vec3;

static inline vec3 v3(real x, real y, real z) { vec3 r; r.x = x; r.y = y; r.z = z; return r; }
static inline vec3 vadd(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline vec3 vsub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline vec3 vscale(vec3 a, real s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline vec3 vmadd(vec3 a, vec3 b, real s) { return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
static inline real vdot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vec3 vcross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline real vlen(vec3 a) { return (real)sqrt((double)vdot(a, a)); }
static inline vec3 vnorm(vec3 a)
{
    real l = vlen(a);
    return l > 0 ? vscale(a, 1 / l) : a;
}
static inline real vget(vec3 a, int axis) { return axis == 0 ? a.x : axis == 1 ? a.y : a.z; }
static inline real vmaxabs(vec3 a)
{
    real x = (real)fabs((double)a.x), y = (real)fabs((double)a.y), z = (real)fabs((double)a.z);
    return x > y ? (x > z ? x : z) : (y > z ? y : z);
}

/* ---- Scene storage ------------------------------------------------------ */

typedef struct {
    double rgb[3];
    double kd, ks, shine, t, ior;
} mprt__material;

typedef struct {
    vec3 pos;
    double rgb[3];
    int has_rgb;
} mprt__light;

typedef struct {
    vec3 c;
    real r;
} mprt__sphere;

/* A planar polygon; its vertices are scene->verts[first .. first+n), and when
 * has_normals, its vertex normals are scene->vnormals at the same indices. */
typedef struct {
    int first, n;
    int has_normals;
    vec3 normal;  /* unit geometric normal, right-handed from the vertex order */
    real d;       /* plane: dot(normal, p) == d */
} mprt__polygon;

/* An open cone frustum (NFF "c"), or a cylinder when rb == ra. */
typedef struct {
    vec3 base, apex;
    real rb, ra;
    /* derived by mprt__cone_prepare */
    vec3 w;       /* unit axis from base to apex */
    vec3 u, v;    /* unit vectors completing a right-handed frame */
    real len;     /* |apex - base| */
    real slope;   /* (ra - rb) / len */
} mprt__cone;

/* Primitive table entry: kind (mprt_kind), index into the kind's array,
 * material index. */
typedef struct {
    int kind;
    int index;
    int material;
} mprt__prim;

#define MPRT__ERRMSG 512

struct mprt_scene {
    /* Storage: the arrays and their capacities in elements.  A rollback
     * keeps them as they are (entries past the restored counts are unused). */
    mprt__prim *prims;         long long capprims;
    mprt__sphere *spheres;     long long capspheres;
    mprt__polygon *polygons;   long long cappolygons;
    mprt__cone *cones;         long long capcones;  /* cones and cylinders */
    vec3 *verts;               long long capverts;
    vec3 *vnormals;            long long capvnormals; /* parallel to verts; allocated lazily */
    mprt__material *materials; long long capmaterials;
    mprt__light *lights;       long long caplights;

    /* Contents: every field from nprims up to errmsg is saved by
     * mprt__scene_mark and put back by mprt__scene_rollback, so a field
     * added here is rolled back without further code. */
    long long nprims, nspheres, npolygons, ncones, nverts, nmaterials, nlights;
    long long ncylinders;      /* cones with equal radii */
    long long npatches;        /* polygons with vertex normals */
    long long dropped;         /* entities dropped with a warning */
    int material;              /* current material, -1 before the first set */
    vec3 from, at, up;
    double angle, hither;
    int width, height;
    double background[3];
    char warning[MPRT__ERRMSG]; /* first dropped entity */
    char notes[2 * MPRT__ERRMSG]; /* the NFF reader's notes (mprt_scene_notes) */

    /* Neither saved nor restored */
    char errmsg[MPRT__ERRMSG];
    int grids;                 /* grids built on the scene and not yet destroyed */
    int destroyed;             /* mprt_scene_destroy came while grids were left: the last frees it */
    pthread_mutex_t grids_lock; /* grids may be made and destroyed in several threads */
};

/* The scene's contents at a mark (see struct mprt_scene). */
typedef struct {
    unsigned char bytes[offsetof(struct mprt_scene, errmsg) - offsetof(struct mprt_scene, nprims)];
} mprt__scene_saved;

/* Save the scene's contents; rollback puts them back, undoing every entity
 * added, material set, view and background changed and warning recorded
 * since the mark (the error message stays as it is). */
void mprt__scene_mark(const mprt_scene *scene, mprt__scene_saved *saved);
void mprt__scene_rollback(mprt_scene *scene, const mprt__scene_saved *saved);

/* Count a grid built on the scene (delta +1) or destroyed (-1). */
void mprt__scene_count_grid(const mprt_scene *scene, int delta);
/* MPRT_OK while no grid uses the scene; else MPRT_ERR_STATE with a message
 * "CALL: ..." (call names the refused API call). */
int mprt__scene_check_unshared(mprt_scene *scene, const char *call);

/* Record an error message on the scene; returns status. printf-style. */
int mprt__scene_fail(mprt_scene *scene, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* Format into a fixed buffer (always NUL-terminated). */
void mprt__vformat(char *buf, size_t cap, const char *fmt, va_list ap);

/* Record that an entity was dropped (counted; the first message is kept). */
void mprt__scene_warn(mprt_scene *scene, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Append a line to the scene's notes (cut short, ending in "...", when full). */
void mprt__scene_note(mprt_scene *scene, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* mprt_scene_add_polygon with the reason for a rejection: *reason (may be
 * NULL) is set to the value mprt__polygon_prepare returned (0 when accepted
 * or rejected for another cause).  A polygon of zero area rejected with
 * reason != NULL leaves the scene's error message as it was: the caller
 * drops it with a warning (mprt__scene_warn). */
int mprt__scene_add_polygon(mprt_scene *scene, int n, const double *verts, const double *normals,
                            int *reason);

/* A patch's vertex normal as the scene stores it: normalised unless it
 * already is (so NFF round trips are exact). */
vec3 mprt__unit_normal(const double *n);

/* Intensity of each channel of a light given without a colour: the NFF
 * reader's rule, 1/sqrt(number of lights). */
double mprt__light_default_rgb(const mprt_scene *scene);

/* Bounds of primitive i; MPRT_ERR_STATE for a primitive of unknown kind. */
int mprt__prim_bounds(const mprt_scene *scene, long long i, vec3 *lo, vec3 *hi);
/* Message text for a primitive of unknown kind (a corrupted scene). */
#define MPRT__UNKNOWN_KIND "primitive %lld has unknown kind %d"

/* Bounding box of all primitives (zeros for none); MPRT_ERR_STATE with
 * *bad_prim set for a primitive of unknown kind. */
int mprt__scene_bounds(const mprt_scene *scene, vec3 *lo, vec3 *hi, long long *bad_prim);

/* ---- Geometry: preparation and validation (prim_*.c) --------------------- */
/* Each *_prepare checks its input and fills derived fields; on bad input it
 * writes a message (no trailing period) into err and returns nonzero:
 * MPRT__DEGENERATE for zero area (a polygon the NFF reader may drop with a
 * warning), MPRT__NONPLANAR for a polygon off its plane beyond tolerance,
 * MPRT__BAD for anything else (e.g. a cone with coincident ends). */
#define MPRT__DEGENERATE 1
#define MPRT__NONPLANAR 2
#define MPRT__BAD 3
int mprt__polygon_prepare(mprt__polygon *p, const vec3 *verts, char *err, size_t errcap);
int mprt__cone_prepare(mprt__cone *c, char *err, size_t errcap);

/* ---- Rays --------------------------------------------------------------- */

/* A ray with the precomputation that intersection routines share.  The
 * ray-space transform (kx, ky, kz, sx, sy, sz) maps a point p to shear
 * coordinates where the ray runs along +z from the origin; polygons use it
 * for a watertight inside test (Woop, Benthin, Wald 2013). */
typedef struct {
    vec3 o, d;        /* origin, direction (not necessarily unit) */
    vec3 inv;         /* 1/d per axis (+-inf for 0) */
    int kx, ky, kz;   /* axis permutation: kz = largest |d| component */
    real sx, sy, sz;  /* shear constants */
    vec3 mx, my;      /* shear x = dot(mx, p - o), y = dot(my, p - o): the same
                       * bits as p[kx] + sx p[kz] (the other terms are zeros) */
} mprt__ray;

/* Fill the derived fields of a ray from o and d. */
void mprt__ray_prepare(mprt__ray *ray, vec3 o, vec3 d);

/* ---- Intersection (prim_*.c) ---------------------------------------------
 * *_hit: nearest intersection with tmin < t <= tmax; returns 1 and sets *t,
 * else 0.  *_normal: unit outward/geometric normal at point p on the surface
 * (not flipped toward the ray).  *_box: nonzero when the primitive's surface
 * may touch the closed box [lo, hi]; never zero when it does (conservative). */
/* Cheap rejection: 1 when the line o + t d certainly passes farther than
 * sqrt(r2) from a point p with om = p - o, for no division and whatever
 * the rounding: |om x d|^2 against dd = d.d times r2 with room for the
 * rounding of this test and of the callers' own distance tests (those
 * keep every decision; this only spares them on clear misses). */
static inline int mprt__line_misses(vec3 om, vec3 d, real dd, real r2)
{
    vec3 c = vcross(om, d);
    return vdot(c, c) > dd * (R(1.07) * r2 + R(4096.0) * REAL_EPS * REAL_EPS * vdot(om, om));
}

int mprt__sphere_hit(const mprt__sphere *s, const mprt__ray *ray, real tmin, real tmax, real *t);
vec3 mprt__sphere_normal(const mprt__sphere *s, vec3 p);
int mprt__sphere_box(const mprt__sphere *s, vec3 lo, vec3 hi);
/* mprt__sphere_box given mbox = max(vmaxabs(lo), vmaxabs(hi)) and cmag = vmaxabs(s->c). */
int mprt__sphere_box_with(const mprt__sphere *s, vec3 lo, vec3 hi, real mbox, real cmag);
void mprt__sphere_bounds(const mprt__sphere *s, vec3 *lo, vec3 *hi);

int mprt__polygon_hit(const mprt__polygon *p, const vec3 *verts, const mprt__ray *ray, real tmin,
                      real tmax, real *t);
/* Shading normal: interpolated from vertex normals for patches, else geometric. */
vec3 mprt__polygon_normal(const mprt__polygon *p, const vec3 *verts, const vec3 *vnormals, vec3 point);
int mprt__polygon_box(const mprt__polygon *p, const vec3 *verts, vec3 lo, vec3 hi);
void mprt__polygon_bounds(const mprt__polygon *p, const vec3 *verts, vec3 *lo, vec3 *hi);
/* A polygon prepared for box tests against many boxes (the grid's build):
 * mprt__polybox_test(b, lo, hi, mbox), with mbox = max(vmaxabs(lo),
 * vmaxabs(hi)), answers exactly as mprt__polygon_box(p, verts, lo, hi) does
 * (1 or 0), or -1 when memory runs out.  Zero the struct before the first
 * mprt__polybox_set; mprt__polybox_free releases its buffers. */
typedef struct {
    const mprt__polygon *p;
    const vec3 *v;
    vec3 plo, phi;      /* vertex bounds */
    real dev, mag;      /* largest distance from the plane; largest |coordinate| of plo, phi */
    vec3 *buf[4];       /* clip stage outputs: 1 the outline clipped to the x slab, 3 to x and y */
    size_t cap[4], len[4];
    real xkey[2], ykey[2]; /* the slab bounds buffers 1 and 3 were clipped to */
    int have_x, have_y;
} mprt__polybox;
void mprt__polybox_set(mprt__polybox *b, const mprt__polygon *p, const vec3 *verts);
int mprt__polybox_test(mprt__polybox *b, vec3 lo, vec3 hi, real mbox);
void mprt__polybox_free(mprt__polybox *b);

int mprt__cylinder_hit(const mprt__cone *c, const mprt__ray *ray, real tmin, real tmax, real *t);
int mprt__cone_hit(const mprt__cone *c, const mprt__ray *ray, real tmin, real tmax, real *t);
vec3 mprt__cone_normal(const mprt__cone *c, vec3 p);
int mprt__cone_box(const mprt__cone *c, vec3 lo, vec3 hi);
/* What mprt__cone_box finds once per cone: the bounds, the largest coordinate
 * magnitude of base and apex, sqrt(1 + slope^2). */
typedef struct {
    vec3 lo, hi;
    real mag, lip;
} mprt__cone_extent;
void mprt__cone_box_prepare(const mprt__cone *c, mprt__cone_extent *x);
/* mprt__cone_box given the cone's extent and mbox = max(vmaxabs(lo), vmaxabs(hi)). */
int mprt__cone_box_with(const mprt__cone *c, const mprt__cone_extent *x, vec3 lo, vec3 hi, real mbox);
void mprt__cone_bounds(const mprt__cone *c, vec3 *lo, vec3 *hi);

/* ---- NFF (nff.c, nff_write.c) ------------------------------------------ */
/* The C library's decimal point in the current locale (NFF text uses '.'). */
char mprt__decimal_point(void);

/* cost.c: visits[base .. base + nvisits - 1] priced into process[0 ..
 * nvisits - 1], receive, send, flits (each may be NULL), as mprt_cost_visits
 * prices them; prev_ray and prev_outcome: the visit before visits[base]. */
int mprt__cost_range(const mprt_cost_table *t, const mprt_trace_ray *rays, const int64_t *children, size_t nrays,
                     const int32_t *prim_kind, size_t nprims, const mprt_trace_visit *visits, size_t base,
                     size_t nvisits, int64_t prev_ray, int prev_outcome, int64_t *process, int64_t *receive,
                     int64_t *send, int32_t *flits, char *errmsg, size_t errlen);

/* Record i of a trace's rays or visits, read through memcpy: a memory-mapped member of a
 * trace file lies at any offset of the file, so its records need not be aligned. */
static inline mprt_trace_ray mprt__ray_at(const void *rays, size_t i)
{
    mprt_trace_ray y;
    memcpy(&y, (const unsigned char *)rays + i * sizeof y, sizeof y);
    return y;
}

static inline mprt_trace_visit mprt__visit_at(const void *visits, size_t j)
{
    mprt_trace_visit a;
    memcpy(&a, (const unsigned char *)visits + j * sizeof a, sizeof a);
    return a;
}

/* Visit a's memory key for level 3 (an IC visit's voxel, an SC visit's shading -2 - its
 * material, else -1) into *key, its reference counted in vref or mref: 1, or 0 (nothing
 * counted) where the voxel, primitive or material is outside the ones given or the key does
 * not fit 32 bits.  mprt_visit_keys and the trace check's keys (tracecheck.c) both use it. */
static inline int mprt__visit_key(const mprt_trace_visit *a, const int64_t *prim_material, size_t nprims,
                                  int64_t *vref, size_t nvox, int64_t *mref, size_t nmat, int32_t *key)
{
    int64_t k = -1;
    if (a->stage == MPRT_STAGE_IC) {
        k = a->voxel_id;
        if (k >= 0) {
            if ((uint64_t)k >= nvox || k > INT32_MAX) return 0;
            vref[k]++;
        }
    } else if (a->stage == MPRT_STAGE_SC && a->prim >= 0) {
        int64_t m;
        if ((size_t)a->prim >= nprims) return 0;
        m = prim_material[a->prim];
        if (m < 0 || (uint64_t)m >= nmat || m > (int64_t)INT32_MAX - 2) return 0;
        mref[m]++;
        k = -2 - m;
    }
    *key = (int32_t)k;
    return 1;
}

#endif
