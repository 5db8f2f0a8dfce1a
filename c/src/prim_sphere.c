/* prim_sphere.c: sphere intersection, normal, bounds and box overlap. */
#include "mprt_internal.h"


int mprt__sphere_hit(const mprt__sphere *s, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    vec3 oc, f;
    real a, b, c, r2, disc, q, t0, t1, tmp;

    /* Quadratic a t^2 + 2 b t + c = 0 with oc = o - centre */
    oc = vsub(ray->o, s->c);
    a = vdot(ray->d, ray->d);
    r2 = s->r * s->r;
    if (mprt__line_misses(oc, ray->d, a, r2)) return 0; /* a clear miss */
    b = vdot(oc, ray->d);
    c = vdot(oc, oc) - r2;

    /* Outside and moving away: both roots are negative */
    if (c > 0 && b > 0 && tmin >= 0) return 0;

    /* Discriminant b^2 - a c as a (r^2 - |f|^2), f = oc minus its projection
     * on d: the vector from the centre to the line's closest point.  No
     * cancellation between two large squares for far origins. */
    f = vmadd(oc, ray->d, -b / a);
    disc = a * (r2 - vdot(f, f));
    if (disc < 0) return 0;

    /* Stable roots: q = -(b + sign(b) sqrt(disc)), t0 = q/a, t1 = c/q */
    q = b >= 0 ? -(b + SQRT(disc)) : -(b - SQRT(disc));
    t0 = q / a;
    t1 = q != 0 ? c / q : t0;
    if (t0 > t1) {
        tmp = t0;
        t0 = t1;
        t1 = tmp;
    }

    /* Nearest root in (tmin, tmax] */
    if (t0 > tmin && t0 <= tmax) {
        *t = t0;
        return 1;
    }
    if (t1 > tmin && t1 <= tmax) {
        *t = t1;
        return 1;
    }
    return 0;
}

vec3 mprt__sphere_normal(const mprt__sphere *s, vec3 p)
{
    vec3 n = vnorm(vsub(p, s->c));
    return vdot(n, n) > 0 ? n : v3(0, 0, 1);
}

void mprt__sphere_bounds(const mprt__sphere *s, vec3 *lo, vec3 *hi)
{
    vec3 r = v3(s->r, s->r, s->r);
    *lo = vsub(s->c, r);
    *hi = vadd(s->c, r);
}

int mprt__sphere_box(const mprt__sphere *s, vec3 lo, vec3 hi)
{
    real pad, r2, dmin2 = 0, dmax2 = 0, m, lc, hc, e;

    /* Grow the box by a rounding allowance relative to the magnitudes involved */
    m = vmaxabs(lo);
    e = vmaxabs(hi);
    if (e > m) m = e;
    e = vmaxabs(s->c);
    if (e > m) m = e;
    pad = R(64.0) * REAL_EPS * (m + s->r);

    /* Squared distances from the centre to the nearest and farthest box points */
#define AXIS(k)                                                           \
    lc = lo.k - pad - s->c.k;                                             \
    hc = hi.k + pad - s->c.k;                                             \
    if (lc > 0) dmin2 += lc * lc;                                         \
    else if (hc < 0) dmin2 += hc * hc;                                    \
    e = -lc > hc ? -lc : hc;                                              \
    dmax2 += e * e;
    AXIS(x)
    AXIS(y)
    AXIS(z)
#undef AXIS

    /* The surface touches the box unless the box misses the ball or lies inside it */
    r2 = s->r * s->r;
    return dmin2 <= r2 && dmax2 >= r2;
}
