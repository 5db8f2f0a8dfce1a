/* prim_polygon.c: planar polygons of any vertex count, convex or concave.
 *
 * Validation (mprt__polygon_prepare) works in double whatever `real` is:
 *   - the normal is Newell's, summed about the centroid;
 *   - zero area: area <= 1e-12 L^2 + 16 eps L (L + M), where L is the largest
 *     extent of the vertex bounding box, M the largest vertex coordinate
 *     magnitude and eps the machine epsilon of `real` (the rounding noise of
 *     the stored vertices);
 *   - non-planar: a vertex farther from the plane than 1e-6 L + 1e-5 M.  The
 *     1e-5 M term admits the rounding of NFF text, which SPD prints with six
 *     significant digits (an error of up to 5e-6 of each coordinate).
 *
 * The hit test is watertight (Woop, Benthin, Wald 2013, extended from
 * triangles to n-gons): vertices are moved into the ray's shear space, where
 * the ray is the +z axis through (0, 0), and the origin's winding number is
 * summed over the edges with the edge function E(a, b) = ax by - ay bx.  A
 * shared edge gets exactly opposite contributions in its two faces (E is
 * antisymmetric bit for bit without fused multiply-add), and vertices use a
 * half-open rule in y, so across a mesh the winding numbers add up to the
 * outline's: a ray through a shared edge or vertex inside a mesh hits at
 * least one face, whatever the faces' orientations.  The fill rule is
 * nonzero winding (the same as even-odd for simple polygons). */
#include "ic.h"

#include <stdio.h>


#define AREA_REL 1e-12
#define PLANE_REL 1e-6
#define PLANE_ABS_REL 1e-5

static void err_set(char *err, size_t cap, const char *msg)
{
    if (err && cap) snprintf(err, cap, "%s", msg);
}

int mprt__polygon_prepare(mprt__polygon *p, const vec3 *verts, char *err, size_t errcap)
{
    const vec3 *v;
    double c[3] = {0, 0, 0}, nrm[3] = {0, 0, 0}, lo[3], hi[3], ext = 0, mag = 0, len2, len;
    double area, tol, dev, worst = 0, d;
    int i, j, k, n = p->n, worst_i = 0;

    if (n < 3) {
        if (err && errcap) snprintf(err, errcap, "%d vertices, at least 3 needed", n);
        return MPRT__BAD;
    }
    v = verts + p->first;

    /* Centroid, bounding box and magnitude, in double */
    for (i = 0; i < n; i++) {
        double q[3];
        q[0] = (double)v[i].x;
        q[1] = (double)v[i].y;
        q[2] = (double)v[i].z;
        for (k = 0; k < 3; k++) {
            if (!isfinite(q[k])) {
                if (err && errcap) snprintf(err, errcap, "vertex %d is not finite", i + 1);
                return MPRT__BAD;
            }
            c[k] += q[k];
            if (i == 0 || q[k] < lo[k]) lo[k] = q[k];
            if (i == 0 || q[k] > hi[k]) hi[k] = q[k];
            if (fabs(q[k]) > mag) mag = fabs(q[k]);
        }
    }
    for (k = 0; k < 3; k++) {
        c[k] /= n;
        if (hi[k] - lo[k] > ext) ext = hi[k] - lo[k];
    }

    /* Newell's normal, summed about the centroid for accuracy */
    for (i = 0; i < n; i++) {
        double a[3], b[3];
        j = i + 1 == n ? 0 : i + 1;
        a[0] = (double)v[i].x - c[0];
        a[1] = (double)v[i].y - c[1];
        a[2] = (double)v[i].z - c[2];
        b[0] = (double)v[j].x - c[0];
        b[1] = (double)v[j].y - c[1];
        b[2] = (double)v[j].z - c[2];
        nrm[0] += a[1] * b[2] - a[2] * b[1];
        nrm[1] += a[2] * b[0] - a[0] * b[2];
        nrm[2] += a[0] * b[1] - a[1] * b[0];
    }
    len2 = nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2];
    len = sqrt(len2);

    /* Zero area: collinear or coincident vertices */
    area = 0.5 * len;
    tol = AREA_REL * ext * ext + 16.0 * (double)REAL_EPS * ext * (ext + mag);
    if (!(area > tol)) {
        if (err && errcap)
            snprintf(err, errcap, "zero area (%.3g, tolerance %.3g for extent %.3g)", area, tol, ext);
        return MPRT__DEGENERATE;
    }
    for (k = 0; k < 3; k++) nrm[k] /= len;
    d = nrm[0] * c[0] + nrm[1] * c[1] + nrm[2] * c[2];

    /* Planarity: every vertex within tolerance of the plane */
    for (i = 0; i < n; i++) {
        dev = fabs(nrm[0] * ((double)v[i].x - c[0]) + nrm[1] * ((double)v[i].y - c[1]) +
                   nrm[2] * ((double)v[i].z - c[2]));
        if (dev > worst) {
            worst = dev;
            worst_i = i;
        }
    }
    tol = PLANE_REL * ext + PLANE_ABS_REL * mag;
    if (worst > tol) {
        if (err && errcap)
            snprintf(err, errcap, "non-planar: vertex %d is %.3g off the plane, tolerance %.3g",
                     worst_i + 1, worst, tol);
        return MPRT__NONPLANAR;
    }

    p->normal = v3((real)nrm[0], (real)nrm[1], (real)nrm[2]);
    p->d = (real)d;
    err_set(err, errcap, "");
    return 0;
}

/* Shear-space coordinates of vertex v (the ray along +z through the origin). */
#define SHEAR(v, x, y)                 \
    do {                               \
        vec3 q_ = vsub((v), o);        \
        (x) = vdot(q_, mx);            \
        (y) = vdot(q_, my);            \
    } while (0)

int mprt__polygon_hit(const mprt__polygon *p, const vec3 *verts, const mprt__ray *ray, real tmin,
                      real tmax, real *t)
{
    const vec3 *v = verts + p->first;
    const int n = p->n;
    const vec3 o = ray->o, mx = ray->mx, my = ray->my;
    real dn, tt, ax, ay, bx, by, e;
    int i, wn = 0;

    if (n == 3) { /* a triangle: IC's test (ic.h) */
        mprt__tri tri;
        tri.v[0] = v[0];
        tri.v[1] = v[1];
        tri.v[2] = v[2];
        tri.normal = p->normal;
        tri.d = p->d;
        return mprt__tri_hit(&tri, ray, tmin, tmax, t);
    }

    /* Parallel rays never hit */
    dn = vdot(p->normal, ray->d);
    if (dn == 0) return 0;

    /* Other polygons: hits outside (tmin, tmax] first, before the edges */
    tt = (p->d - vdot(p->normal, o)) / dn;
    if (!(tt > tmin && tt <= tmax)) return 0;

    /* Winding number of the ray (the origin of shear space), starting with
     * the edge from the last vertex; E only where an edge crosses y = 0 */
    SHEAR(v[n - 1], ax, ay);
    for (i = 0; i < n; i++) {
        SHEAR(v[i], bx, by);
        if (ay <= 0) {
            if (by > 0) { /* upward crossing: count when the origin is left of a->b */
                e = ax * by - ay * bx;
                if (e > 0) wn++;
            }
        } else if (by <= 0) { /* downward crossing: count when right of a->b */
            e = ax * by - ay * bx;
            if (e < 0) wn--;
        }
        ax = bx;
        ay = by;
    }
    if (wn == 0) return 0;
    *t = tt;
    return 1;
}

#undef SHEAR

/* Weights of p in triangle (a, b, c) measured along n; returns the sum (0 if degenerate). */
static real tri_weights(vec3 a, vec3 b, vec3 c, vec3 n, vec3 p, real w[3])
{
    vec3 pa = vsub(a, p), pb = vsub(b, p), pc = vsub(c, p);
    w[0] = vdot(n, vcross(pb, pc));
    w[1] = vdot(n, vcross(pc, pa));
    w[2] = vdot(n, vcross(pa, pb));
    return w[0] + w[1] + w[2];
}

vec3 mprt__polygon_normal(const mprt__polygon *p, const vec3 *verts, const vec3 *vnormals, vec3 point)
{
    const vec3 *v, *vn;
    real w[3], sum, best = 0, score, bw[3] = {0, 0, 0};
    int i, besti = -1;
    vec3 r;

    if (!p->has_normals || !vnormals) return p->normal;
    v = verts + p->first;
    vn = vnormals + p->first;

    /* Fan triangle (v0, vi, vi+1) containing the point, else the least outside one */
    for (i = 1; i + 1 < p->n; i++) {
        sum = tri_weights(v[0], v[i], v[i + 1], p->normal, point, w);
        if (sum == 0) continue;
        w[0] /= sum;
        w[1] /= sum;
        w[2] /= sum;
        score = w[0] < w[1] ? w[0] : w[1];
        if (w[2] < score) score = w[2];
        if (besti < 0 || score > best) {
            best = score;
            besti = i;
            bw[0] = w[0];
            bw[1] = w[1];
            bw[2] = w[2];
            if (score >= 0) break;
        }
    }
    if (besti < 0) return p->normal;

    /* Interpolate the vertex normals with the barycentric weights */
    r = vscale(vn[0], bw[0]);
    r = vmadd(r, vn[besti], bw[1]);
    r = vmadd(r, vn[besti + 1], bw[2]);
    if (!(vdot(r, r) > 0)) return p->normal;
    return vnorm(r);
}

void mprt__polygon_bounds(const mprt__polygon *p, const vec3 *verts, vec3 *lo, vec3 *hi)
{
    const vec3 *v = verts + p->first;
    vec3 a = v[0], b = v[0];
    int i;
    for (i = 1; i < p->n; i++) {
        if (v[i].x < a.x) a.x = v[i].x;
        if (v[i].y < a.y) a.y = v[i].y;
        if (v[i].z < a.z) a.z = v[i].z;
        if (v[i].x > b.x) b.x = v[i].x;
        if (v[i].y > b.y) b.y = v[i].y;
        if (v[i].z > b.z) b.z = v[i].z;
    }
    *lo = a;
    *hi = b;
}

/* ---- Polygon/box overlap: streaming Sutherland-Hodgman --------------------
 * The polygon is clipped against the six slabs of the box with one stage per
 * plane, each keeping only its first and previous vertex, so no buffer is
 * needed for any vertex count.  The box is reported when a vertex reaches
 * the end of the pipeline.  This never misses; for a concave polygon it may
 * also report a box lying in a notch, where the clipped outline runs along a
 * box face between two arms of the polygon (conservative, as allowed). */

typedef struct {
    vec3 first, prev;
    int has;
} clip_stage;

typedef struct {
    clip_stage st[6];
    real bound[6];
    int out;
} clipper;

static int clip_inside(const clipper *c, int k, vec3 p)
{
    real x = vget(p, k >> 1);
    return (k & 1) ? x <= c->bound[k] : x >= c->bound[k];
}

static void clip_push(clipper *c, int k, vec3 p);

/* Edge a->b through stage k: emit the crossing point and/or b. */
static void clip_edge(clipper *c, int k, vec3 a, vec3 b)
{
    int ina = clip_inside(c, k, a), inb = clip_inside(c, k, b), axis = k >> 1;
    if (ina != inb) {
        real pa = vget(a, axis), pb = vget(b, axis), s = (c->bound[k] - pa) / (pb - pa);
        vec3 x = vadd(a, vscale(vsub(b, a), s));
        if (axis == 0) x.x = c->bound[k];
        else if (axis == 1) x.y = c->bound[k];
        else x.z = c->bound[k];
        clip_push(c, k + 1, x);
    }
    if (inb) clip_push(c, k + 1, b);
}

static void clip_push(clipper *c, int k, vec3 p)
{
    clip_stage *s;
    if (k == 6) {
        c->out++;
        return;
    }
    s = &c->st[k];
    if (!s->has) {
        s->first = p;
        s->has = 1;
    } else {
        clip_edge(c, k, s->prev, p);
    }
    s->prev = p;
}

int mprt__polygon_box(const mprt__polygon *p, const vec3 *verts, vec3 lo, vec3 hi)
{
    const vec3 *v = verts + p->first;
    const vec3 nrm = p->normal;
    vec3 plo, phi, ctr, h;
    real m, e, pad, dev = 0;
    clipper c;
    int i, k;

    /* Vertex bounds and the largest distance of a vertex from the plane */
    mprt__polygon_bounds(p, verts, &plo, &phi);
    for (i = 0; i < p->n; i++) {
        e = ABS(vdot(nrm, v[i]) - p->d);
        if (e > dev) dev = e;
    }

    /* Grow the box by a rounding allowance and by the polygon's non-planarity */
    m = vmaxabs(lo);
    if ((e = vmaxabs(hi)) > m) m = e;
    if ((e = vmaxabs(plo)) > m) m = e;
    if ((e = vmaxabs(phi)) > m) m = e;
    pad = R(64.0) * REAL_EPS * m + R(2.0) * dev;
    lo = vsub(lo, v3(pad, pad, pad));
    hi = vadd(hi, v3(pad, pad, pad));

    /* Bounding box reject */
    if (plo.x > hi.x || plo.y > hi.y || plo.z > hi.z || phi.x < lo.x || phi.y < lo.y ||
        phi.z < lo.z)
        return 0;

    /* Plane reject: the box's projection on the normal misses the plane */
    ctr = vscale(vadd(lo, hi), R(0.5));
    h = vsub(hi, ctr);
    e = ABS(nrm.x) * h.x + ABS(nrm.y) * h.y + ABS(nrm.z) * h.z;
    if (ABS(vdot(nrm, ctr) - p->d) > e + pad) return 0;

    /* Clip against the six slabs */
    for (k = 0; k < 3; k++) {
        c.bound[2 * k] = vget(lo, k);
        c.bound[2 * k + 1] = vget(hi, k);
    }
    for (k = 0; k < 6; k++) c.st[k].has = 0;
    c.out = 0;
    for (i = 0; i < p->n && !c.out; i++) clip_push(&c, 0, v[i]);
    for (k = 0; k < 6 && !c.out; k++)
        if (c.st[k].has) clip_edge(&c, k, c.st[k].prev, c.st[k].first);
    return c.out > 0;
}
