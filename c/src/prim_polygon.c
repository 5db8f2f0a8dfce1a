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
#include <stdlib.h>
#include <string.h>


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

/* Where edge a->b crosses the plane x_axis = bound (the one formula of both
 * clippers below, so that they agree bit for bit). */
static vec3 clip_cross(vec3 a, vec3 b, int axis, real bound)
{
    real pa = vget(a, axis), pb = vget(b, axis), s = (bound - pa) / (pb - pa);
    vec3 x = vadd(a, vscale(vsub(b, a), s));
    if (axis == 0) x.x = bound;
    else if (axis == 1) x.y = bound;
    else x.z = bound;
    return x;
}

/* Edge a->b through stage k: emit the crossing point and/or b. */
static void clip_edge(clipper *c, int k, vec3 a, vec3 b)
{
    int ina = clip_inside(c, k, a), inb = clip_inside(c, k, b);
    if (ina != inb) clip_push(c, k + 1, clip_cross(a, b, k >> 1, c->bound[k]));
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

/* The polygon's vertex bounds and its largest vertex distance from its plane. */
static void polygon_extent(const mprt__polygon *p, const vec3 *verts, vec3 *plo, vec3 *phi, real *dev)
{
    const vec3 *v = verts + p->first;
    real e;
    int i;
    mprt__polygon_bounds(p, verts, plo, phi);
    *dev = 0;
    for (i = 0; i < p->n; i++) {
        e = ABS(vdot(p->normal, v[i]) - p->d);
        if (e > *dev) *dev = e;
    }
}

/* Grow the box by a rounding allowance (m: the largest coordinate magnitude
 * of box and polygon) and by the polygon's non-planarity dev, then reject it
 * by bounding boxes and by the plane: 0 when rejected, else 1 with the box
 * grown. */
static int polygon_box_pre(const mprt__polygon *p, vec3 plo, vec3 phi, real dev, real m, vec3 *blo, vec3 *bhi)
{
    const vec3 nrm = p->normal;
    vec3 ctr, h, lo = *blo, hi = *bhi;
    real e, pad = R(64.0) * REAL_EPS * m + R(2.0) * dev;
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
    *blo = lo;
    *bhi = hi;
    return 1;
}

int mprt__polygon_box(const mprt__polygon *p, const vec3 *verts, vec3 lo, vec3 hi)
{
    const vec3 *v = verts + p->first;
    vec3 plo, phi;
    real m, e, dev;
    clipper c;
    int i, k;

    polygon_extent(p, verts, &plo, &phi, &dev);
    m = vmaxabs(lo);
    if ((e = vmaxabs(hi)) > m) m = e;
    if ((e = vmaxabs(plo)) > m) m = e;
    if ((e = vmaxabs(phi)) > m) m = e;
    if (!polygon_box_pre(p, plo, phi, dev, m, &lo, &hi)) return 0;

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

/* ---- The same test against many boxes --------------------------------------
 * mprt__polybox_test answers as mprt__polygon_box does, bit for bit, for
 * less work: the bounds and non-planarity are found once per polygon, and
 * the clipper runs one whole stage at a time (Sutherland-Hodgman in batch),
 * keeping the outline clipped to the x slab and then to the y slab for the
 * last bounds it met, so that boxes sharing those bounds (a column of
 * voxels, a row of a column) clip the polygon once.  A stage in batch
 * receives the same points in the same order as the streaming stage and
 * computes each crossing with the same formula, so the last stage's outline
 * is empty exactly when the streaming clipper reports nothing. */

void mprt__polybox_set(mprt__polybox *b, const mprt__polygon *p, const vec3 *verts)
{
    real e;
    b->p = p;
    b->v = verts + p->first;
    polygon_extent(p, verts, &b->plo, &b->phi, &b->dev);
    b->mag = vmaxabs(b->plo);
    if ((e = vmaxabs(b->phi)) > b->mag) b->mag = e;
    b->have_x = b->have_y = 0;
}

void mprt__polybox_free(mprt__polybox *b)
{
    int i;
    for (i = 0; i < 4; i++) free(b->buf[i]);
    memset(b, 0, sizeof *b);
}

/* Stage k (slab face k: axis k / 2, low side for even k) on the closed
 * outline in[0 .. m), into buffer i; -1 when memory runs out. */
static int clip_slab(mprt__polybox *b, int i, const vec3 *in, size_t m, int k, real bound)
{
    const int axis = k >> 1, high = k & 1;
    size_t j, o = 0;
    vec3 *out;
    int ina, inb;
    if (b->cap[i] < 2 * m) {
        size_t nc = 2 * m < 64 ? 64 : 4 * m;
        out = realloc(b->buf[i], nc * sizeof *out);
        if (!out) return -1;
        b->buf[i] = out;
        b->cap[i] = nc;
    }
    out = b->buf[i];
    if (m) {
        ina = high ? vget(in[0], axis) <= bound : vget(in[0], axis) >= bound;
        for (j = 1; j <= m; j++) {
            const vec3 a = in[j - 1], c = in[j == m ? 0 : j];
            inb = high ? vget(c, axis) <= bound : vget(c, axis) >= bound;
            if (ina != inb) out[o++] = clip_cross(a, c, axis, bound);
            if (inb) out[o++] = c;
            ina = inb;
        }
    }
    b->len[i] = o;
    return 0;
}

int mprt__polybox_test(mprt__polybox *b, vec3 lo, vec3 hi, real mbox)
{
    size_t j;
    if (!polygon_box_pre(b->p, b->plo, b->phi, b->dev, mbox > b->mag ? mbox : b->mag, &lo, &hi)) return 0;
    if (!b->have_x || memcmp(&b->xkey[0], &lo.x, sizeof lo.x) || memcmp(&b->xkey[1], &hi.x, sizeof hi.x)) {
        b->have_x = b->have_y = 0;
        if (clip_slab(b, 0, b->v, (size_t)b->p->n, 0, lo.x) || clip_slab(b, 1, b->buf[0], b->len[0], 1, hi.x))
            return -1;
        b->xkey[0] = lo.x;
        b->xkey[1] = hi.x;
        b->have_x = 1;
    }
    if (!b->have_y || memcmp(&b->ykey[0], &lo.y, sizeof lo.y) || memcmp(&b->ykey[1], &hi.y, sizeof hi.y)) {
        b->have_y = 0;
        if (clip_slab(b, 2, b->buf[1], b->len[1], 2, lo.y) || clip_slab(b, 3, b->buf[2], b->len[2], 3, hi.y))
            return -1;
        b->ykey[0] = lo.y;
        b->ykey[1] = hi.y;
        b->have_y = 1;
    }
    /* the z slab (into buffer 0, scratch once the x slab is done): the last
     * stage emits a point when one of its inputs is inside */
    if (clip_slab(b, 0, b->buf[3], b->len[3], 4, lo.z)) return -1;
    for (j = 0; j < b->len[0]; j++)
        if (b->buf[0][j].z <= hi.z) return 1;
    return 0;
}
