/* prim_cone.c: open cone frustums and cylinders (NFF "c"): the lateral
 * surface between the rims of two discs, no caps.
 *
 * Both hit routines work in the cone's frame (u, v, w) with the origin first
 * moved along the ray to the point nearest the frustum's middle, so the
 * quadratic's coefficients stay of the size of the object even for far
 * origins (the discriminant does not change under that shift).  Roots use
 * q = -(b + sign(b) sqrt(disc)), s0 = q/A, s1 = C/q; A == 0 (a ray parallel
 * to a generator, or to a cylinder's axis) leaves only C/q. */
#include "ic.h"

#include <stdio.h>


int mprt__cone_prepare(mprt__cone *c, char *err, size_t errcap)
{
    double b[3], a[3], ax[3], len, mag = 0, w[3], u[3], v[3], sign, s, t;
    int k;

    /* Finite input, radii */
    b[0] = (double)c->base.x;
    b[1] = (double)c->base.y;
    b[2] = (double)c->base.z;
    a[0] = (double)c->apex.x;
    a[1] = (double)c->apex.y;
    a[2] = (double)c->apex.z;
    for (k = 0; k < 3; k++) {
        if (!isfinite(b[k]) || !isfinite(a[k])) {
            if (err && errcap) snprintf(err, errcap, "base or apex is not finite");
            return MPRT__BAD;
        }
        if (fabs(b[k]) > mag) mag = fabs(b[k]);
        if (fabs(a[k]) > mag) mag = fabs(a[k]);
    }
    if (!isfinite((double)c->rb) || !isfinite((double)c->ra)) {
        if (err && errcap) snprintf(err, errcap, "radius is not finite");
        return MPRT__BAD;
    }
    if (c->rb < 0 || c->ra < 0) {
        if (err && errcap)
            snprintf(err, errcap, "negative radius (base %g, apex %g)", (double)c->rb, (double)c->ra);
        return MPRT__BAD;
    }
    if (c->rb == 0 && c->ra == 0) {
        if (err && errcap) snprintf(err, errcap, "both radii are zero");
        return MPRT__BAD;
    }

    /* Axis: the ends must differ by more than rounding */
    for (k = 0; k < 3; k++) ax[k] = a[k] - b[k];
    len = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    if (!(len > 16.0 * (double)REAL_EPS * mag)) {
        if (err && errcap)
            snprintf(err, errcap, "base and apex coincide (distance %g)", len);
        return MPRT__BAD;
    }
    for (k = 0; k < 3; k++) w[k] = ax[k] / len;

    /* Right-handed orthonormal frame u, v, w (Duff et al. 2017) */
    sign = w[2] >= 0 ? 1.0 : -1.0;
    s = -1.0 / (sign + w[2]);
    t = w[0] * w[1] * s;
    u[0] = 1.0 + sign * w[0] * w[0] * s;
    u[1] = sign * t;
    u[2] = -sign * w[0];
    v[0] = t;
    v[1] = sign + w[1] * w[1] * s;
    v[2] = -w[1];

    c->w = v3((real)w[0], (real)w[1], (real)w[2]);
    c->u = v3((real)u[0], (real)u[1], (real)u[2]);
    c->v = v3((real)v[0], (real)v[1], (real)v[2]);
    c->len = (real)len;
    c->slope = (real)(((double)c->ra - (double)c->rb) / len);
    if (err && errcap) err[0] = '\0';
    return 0;
}

void mprt__cone_ball(const mprt__cone *c, mprt__ball *b)
{
    const real half = R(0.5) * c->len, rmax = c->rb > c->ra ? c->rb : c->ra;
    b->c = vmadd(c->base, c->w, half);
    b->r2 = half * half + rmax * rmax;
}

/* Shared set-up: shift the origin to the ray point nearest the frustum's
 * middle m, reject rays missing the bounding sphere about m, and express the
 * shifted origin (relative to the base) and the direction in (u, v, w).
 * Returns 0 on a reject; *tc is the shift. */
static int cone_local(const mprt__cone *c, const mprt__ray *ray, real *tc, real o[3], real d[3])
{
    const real half = R(0.5) * c->len;
    mprt__ball ball;
    vec3 om, e, p;
    real dd, s;

    /* Origin shift: tc = (m - o).d / d.d, e = o + tc d - m */
    mprt__cone_ball(c, &ball);
    om = vsub(ball.c, ray->o);
    dd = vdot(ray->d, ray->d);
    if (!(dd > 0)) return 0;
    if (mprt__line_misses(om, ray->d, dd, ball.r2)) return 0; /* a clear miss of the bounding sphere */
    s = vdot(om, ray->d) / dd;
    e = vsub(vscale(ray->d, s), om);

    /* Bounding sphere of the frustum */
    if (vdot(e, e) > ball.r2 * (1 + R(64.0) * REAL_EPS)) return 0;

    /* Local coordinates, origin at the base */
    p = vmadd(e, c->w, half);
    o[0] = vdot(p, c->u);
    o[1] = vdot(p, c->v);
    o[2] = vdot(p, c->w);
    d[0] = vdot(ray->d, c->u);
    d[1] = vdot(ray->d, c->v);
    d[2] = vdot(ray->d, c->w);
    *tc = s;
    return 1;
}

/* Accept the nearer of two roots (shifted parameters) that lies in (tmin,
 * tmax] and between the rims. */
static int cone_pick(const mprt__cone *c, real tc, real oz, real dz, real s0, real s1, real tmin,
                     real tmax, real *t)
{
    real tt, z;
    if (s0 > s1) {
        tt = s0;
        s0 = s1;
        s1 = tt;
    }
    tt = tc + s0;
    if (tt > tmin && tt <= tmax) {
        z = oz + s0 * dz;
        if (z >= 0 && z <= c->len) {
            *t = tt;
            return 1;
        }
    }
    tt = tc + s1;
    if (tt > tmin && tt <= tmax) {
        z = oz + s1 * dz;
        if (z >= 0 && z <= c->len) {
            *t = tt;
            return 1;
        }
    }
    return 0;
}

int mprt__cylinder_hit(const mprt__cone *c, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    real o[3], d[3], tc, a, b, cc, r2, fx, fy, disc, q, s0, s1;

    if (!cone_local(c, ray, &tc, o, d)) return 0;

    /* x^2 + y^2 = r^2: a s^2 + 2 b s + cc = 0; a == 0 runs along the axis */
    a = d[0] * d[0] + d[1] * d[1];
    if (a == 0) return 0;
    b = o[0] * d[0] + o[1] * d[1];
    r2 = c->rb * c->rb;
    cc = o[0] * o[0] + o[1] * o[1] - r2;

    /* Discriminant as a (r^2 - |f|^2), f the 2D closest point to the axis */
    fx = o[0] - (b / a) * d[0];
    fy = o[1] - (b / a) * d[1];
    disc = a * (r2 - (fx * fx + fy * fy));
    if (disc < 0) return 0;

    /* Stable roots */
    q = b >= 0 ? -(b + SQRT(disc)) : -(b - SQRT(disc));
    s0 = q / a;
    s1 = q != 0 ? cc / q : s0;
    return cone_pick(c, tc, o[2], d[2], s0, s1, tmin, tmax, t);
}

int mprt__cone_hit(const mprt__cone *c, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    real o[3], d[3], tc, k, r0, a, b, cc, disc, q, s0, s1;

    if (!cone_local(c, ray, &tc, o, d)) return 0;

    /* x^2 + y^2 = (rb + k z)^2 with r0 the radius at the origin's height:
     * a s^2 + 2 b s + cc = 0 */
    k = c->slope;
    r0 = c->rb + k * o[2];
    a = d[0] * d[0] + d[1] * d[1] - (k * d[2]) * (k * d[2]);
    b = o[0] * d[0] + o[1] * d[1] - (k * d[2]) * r0;
    cc = o[0] * o[0] + o[1] * o[1] - r0 * r0;
    disc = b * b - a * cc;
    if (disc < 0) return 0;

    /* Stable roots; with a == 0 (parallel to a generator) only cc/q exists */
    q = b >= 0 ? -(b + SQRT(disc)) : -(b - SQRT(disc));
    if (q == 0) { /* b == 0 and a cc == 0: a double root at s = 0, or no root */
        if (a == 0) return 0;
        s0 = s1 = 0;
    } else if (a == 0) {
        s0 = s1 = cc / q;
    } else {
        s0 = q / a;
        s1 = cc / q;
    }
    return cone_pick(c, tc, o[2], d[2], s0, s1, tmin, tmax, t);
}

vec3 mprt__cone_normal(const mprt__cone *c, vec3 p)
{
    vec3 q = vsub(p, c->base), radial;
    real x = vdot(q, c->u), y = vdot(q, c->v), rho = SQRT(x * x + y * y);

    /* Gradient of rho^2 - (rb + k z)^2 on the surface: radial - k w */
    radial = rho > 0 ? vscale(vadd(vscale(c->u, x), vscale(c->v, y)), 1 / rho) : c->u;
    return vnorm(vmadd(radial, c->w, -c->slope));
}

void mprt__cone_bounds(const mprt__cone *c, vec3 *lo, vec3 *hi)
{
    const vec3 w = c->w;
    vec3 e, eb, ea, l1, h1, l2, h2;

    /* A rim of radius r about axis w spans r sqrt(1 - w_i^2) along axis i */
    e = v3(SQRT(w.y * w.y + w.z * w.z), SQRT(w.x * w.x + w.z * w.z), SQRT(w.x * w.x + w.y * w.y));
    eb = vscale(e, c->rb);
    ea = vscale(e, c->ra);
    l1 = vsub(c->base, eb);
    h1 = vadd(c->base, eb);
    l2 = vsub(c->apex, ea);
    h2 = vadd(c->apex, ea);
    *lo = v3(l1.x < l2.x ? l1.x : l2.x, l1.y < l2.y ? l1.y : l2.y, l1.z < l2.z ? l1.z : l2.z);
    *hi = v3(h1.x > h2.x ? h1.x : h2.x, h1.y > h2.y ? h1.y : h2.y, h1.z > h2.z ? h1.z : h2.z);
}

void mprt__cone_box_prepare(const mprt__cone *c, mprt__cone_extent *x)
{
    real e;
    x->mag = vmaxabs(c->base);
    if ((e = vmaxabs(c->apex)) > x->mag) x->mag = e;
    mprt__cone_bounds(c, &x->lo, &x->hi);
    x->lip = SQRT(1 + c->slope * c->slope);
}

int mprt__cone_box(const mprt__cone *c, vec3 lo, vec3 hi)
{
    mprt__cone_extent x;
    real m = vmaxabs(lo), e;
    if ((e = vmaxabs(hi)) > m) m = e;
    mprt__cone_box_prepare(c, &x);
    return mprt__cone_box_with(c, &x, lo, hi, m);
}

int mprt__cone_box_with(const mprt__cone *c, const mprt__cone_extent *x, vec3 lo, vec3 hi, real mbox)
{
    vec3 blo = x->lo, bhi = x->hi, ctr, h, q, corner;
    real m, pad, zc, zh, y_, z, rho, g, hd, r, xx;
    int i;

    /* Grow the box by a rounding allowance */
    m = mbox > x->mag ? mbox : x->mag;
    pad = R(64.0) * REAL_EPS * (m + c->len);
    lo = vsub(lo, v3(pad, pad, pad));
    hi = vadd(hi, v3(pad, pad, pad));

    /* Bounding box of the two rims */
    if (blo.x > hi.x || blo.y > hi.y || blo.z > hi.z || bhi.x < lo.x || bhi.y < lo.y ||
        bhi.z < lo.z)
        return 0;

    /* Box beyond either cap plane */
    ctr = vscale(vadd(lo, hi), R(0.5));
    h = vsub(hi, ctr);
    q = vsub(ctr, c->base);
    zc = vdot(q, c->w);
    zh = ABS(c->w.x) * h.x + ABS(c->w.y) * h.y + ABS(c->w.z) * h.z;
    if (zc + zh < 0 || zc - zh > c->len) return 0;

    /* Box wholly off the infinite cone: g = rho - (rb + k z) is
     * sqrt(1 + k^2)-Lipschitz and zero on the surface */
    xx = vdot(q, c->u);
    y_ = vdot(q, c->v);
    rho = SQRT(xx * xx + y_ * y_);
    g = rho - (c->rb + c->slope * zc);
    hd = vlen(h);
    if (ABS(g) > x->lip * hd) return 0;

    /* Box strictly inside the solid frustum (convex): all corners inside */
    for (i = 0; i < 8; i++) {
        corner = v3((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
        q = vsub(corner, c->base);
        z = vdot(q, c->w);
        if (!(z > 0 && z < c->len)) return 1;
        xx = vdot(q, c->u);
        y_ = vdot(q, c->v);
        r = c->rb + c->slope * z;
        if (!(xx * xx + y_ * y_ < r * r)) return 1;
    }
    return 0;
}
