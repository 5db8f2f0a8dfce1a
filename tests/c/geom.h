/* geom.h: what the primitive tests share: a seeded generator, vectors in
 * double, rays, polygon meshes and planes, and the tolerances that follow
 * `real` (the tests build with -DMPRT_SINGLE too). */
#ifndef MPRT_TEST_GEOM_H
#define MPRT_TEST_GEOM_H

#include "mprt_internal.h"

#include "check.h"

#include <stdlib.h>
#include <string.h>

#define EPS ((double)REAL_EPS)
/* Relative tolerance for quantities computed in a few operations */
#define TOL (4096 * EPS)
#define PI 3.14159265358979323846

typedef struct { unsigned long long s; } rng;

static inline void rng_seed(rng *r, unsigned long long seed) { r->s = seed * 0x9E3779B97F4A7C15ULL + 1; }

static inline unsigned long long rng_next(rng *r)
{
    unsigned long long z = (r->s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

/* Uniform in [0, 1). */
static inline double rnd(rng *r) { return (double)(rng_next(r) >> 11) * (1.0 / 9007199254740992.0); }
static inline double rnd_in(rng *r, double a, double b) { return a + (b - a) * rnd(r); }
/* Integer in [a, b]. */
static inline int rnd_int(rng *r, int a, int b) { return a + (int)(rng_next(r) % (unsigned long long)(b - a + 1)); }

static inline vec3 vd(double x, double y, double z) { return v3((real)x, (real)y, (real)z); }

static inline vec3 rnd_unit(rng *r)
{
    double z = rnd_in(r, -1, 1), a = rnd_in(r, 0, 2 * PI), s = sqrt(1 - z * z);
    return vd(s * cos(a), s * sin(a), z);
}

static inline mprt__ray mkray(vec3 o, vec3 d)
{
    mprt__ray ray;
    mprt__ray_prepare(&ray, o, d);
    return ray;
}

static inline double dlen(vec3 a) { return sqrt((double)a.x * a.x + (double)a.y * a.y + (double)a.z * a.z); }
static inline double ddist(vec3 a, vec3 b) { return dlen(vsub(a, b)); }
static inline double dmag(vec3 a) { return (double)vmaxabs(a); }

/* A growable set of polygons with their own vertex array, as the scene keeps them. */
typedef struct {
    vec3 *v;
    int nv, capv;
    mprt__polygon *p;
    int np, capp;
} mesh;

/* Add a polygon; returns mprt__polygon_prepare's code (the polygon is kept only on 0). */
static inline int mesh_add(mesh *m, int n, const vec3 *pts, int flip)
{
    mprt__polygon p;
    char err[200];
    int i, st;
    if (m->nv + n > m->capv) {
        m->capv = 2 * (m->nv + n) + 16;
        m->v = (vec3 *)realloc(m->v, sizeof *m->v * (size_t)m->capv);
    }
    if (m->np + 1 > m->capp) {
        m->capp = 2 * m->np + 16;
        m->p = (mprt__polygon *)realloc(m->p, sizeof *m->p * (size_t)m->capp);
    }
    if (!m->v || !m->p) {
        fprintf(stderr, "out of memory\n");
        exit(2);
    }
    for (i = 0; i < n; i++) m->v[m->nv + i] = pts[flip ? n - 1 - i : i];
    memset(&p, 0, sizeof p);
    p.first = m->nv;
    p.n = n;
    st = mprt__polygon_prepare(&p, m->v, err, sizeof err);
    if (st == 0) {
        m->p[m->np++] = p;
        m->nv += n;
    }
    return st;
}

static inline void mesh_free(mesh *m)
{
    free(m->v);
    free(m->p);
    memset(m, 0, sizeof *m);
}

/* Even-odd point in polygon, 2D, in double. */
static inline int pip2(const double *x, const double *y, int n, double px, double py)
{
    int i, j, c = 0;
    for (i = 0, j = n - 1; i < n; j = i++)
        if (((y[i] > py) != (y[j] > py)) && (px < (x[j] - x[i]) * (py - y[i]) / (y[j] - y[i]) + x[i]))
            c = !c;
    return c;
}

/* A gear-like concave outline of n vertices (n a multiple of 4): teeth of radius 1, gaps 0.8. */
static inline void gear_outline(int n, double *x, double *y)
{
    int i;
    for (i = 0; i < n; i++) {
        double a = 2 * PI * (i + 0.5 * (i & 1)) / n, r = (i & 2) ? 0.8 : 1.0;
        x[i] = r * cos(a);
        y[i] = r * sin(a);
    }
}

/* An orthonormal frame (e1, e2, n) in double. */
static inline void frame(const double n[3], double e1[3], double e2[3])
{
    double a[3] = {1, 0, 0}, l;
    if (fabs(n[0]) > 0.6) {
        a[0] = 0;
        a[1] = 1;
    }
    e1[0] = a[1] * n[2] - a[2] * n[1];
    e1[1] = a[2] * n[0] - a[0] * n[2];
    e1[2] = a[0] * n[1] - a[1] * n[0];
    l = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    e1[0] /= l;
    e1[1] /= l;
    e1[2] /= l;
    e2[0] = n[1] * e1[2] - n[2] * e1[1];
    e2[1] = n[2] * e1[0] - n[0] * e1[2];
    e2[2] = n[0] * e1[1] - n[1] * e1[0];
}

/* A planar polygon in 3D from a 2D outline: c + x e1 + y e2. */
typedef struct {
    double c[3], e1[3], e2[3], n[3];
} plane3;

static inline void plane_make(plane3 *pl, rng *r, double cx, double cy, double cz)
{
    vec3 u = rnd_unit(r);
    pl->c[0] = cx;
    pl->c[1] = cy;
    pl->c[2] = cz;
    pl->n[0] = (double)u.x;
    pl->n[1] = (double)u.y;
    pl->n[2] = (double)u.z;
    {
        double l = sqrt(pl->n[0] * pl->n[0] + pl->n[1] * pl->n[1] + pl->n[2] * pl->n[2]);
        pl->n[0] /= l;
        pl->n[1] /= l;
        pl->n[2] /= l;
    }
    frame(pl->n, pl->e1, pl->e2);
}

static inline void plane_point(const plane3 *pl, double x, double y, double h, double out[3])
{
    int k;
    for (k = 0; k < 3; k++) out[k] = pl->c[k] + x * pl->e1[k] + y * pl->e2[k] + h * pl->n[k];
}

static inline vec3 plane_vec(const plane3 *pl, double x, double y, double h)
{
    double q[3];
    plane_point(pl, x, y, h, q);
    return vd(q[0], q[1], q[2]);
}

static inline mprt__cone mkcone(vec3 base, double rb, vec3 apex, double ra)
{
    mprt__cone c;
    char err[200];
    memset(&c, 0, sizeof c);
    c.base = base;
    c.apex = apex;
    c.rb = (real)rb;
    c.ra = (real)ra;
    if (mprt__cone_prepare(&c, err, sizeof err) != 0) fprintf(stderr, "mkcone: %s\n", err);
    return c;
}

static inline int cone_any_hit(const mprt__cone *c, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    return c->rb == c->ra ? mprt__cylinder_hit(c, ray, tmin, tmax, t) : mprt__cone_hit(c, ray, tmin, tmax, t);
}

/* A point on the cone's lateral surface: axial fraction f, angle a. */
static inline vec3 cone_point(const mprt__cone *c, double f, double a)
{
    double z = f * (double)c->len, r = (double)c->rb + (double)c->slope * z, q[3];
    int k;
    for (k = 0; k < 3; k++)
        q[k] = (double)vget(c->base, k) + z * (double)vget(c->w, k) +
               r * (cos(a) * (double)vget(c->u, k) + sin(a) * (double)vget(c->v, k));
    return vd(q[0], q[1], q[2]);
}

#endif
