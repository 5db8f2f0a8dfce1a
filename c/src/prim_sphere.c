/* prim_sphere.c: sphere intersection, normal, bounds and box overlap. */
#include "ic.h"

int mprt__sphere_hit(const mprt__sphere *s, const mprt__ray *ray, real tmin, real tmax, real *t)
{
    mprt__ball b;
    b.c = s->c;
    b.r2 = s->r * s->r;
    return mprt__ball_hit(&b, ray, vdot(ray->d, ray->d), tmin, tmax, t);
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
    real m = vmaxabs(lo), e = vmaxabs(hi);
    return mprt__sphere_box_with(s, lo, hi, e > m ? e : m, vmaxabs(s->c));
}

int mprt__sphere_box_with(const mprt__sphere *s, vec3 lo, vec3 hi, real mbox, real cmag)
{
    real pad, r2, dmin2 = 0, dmax2 = 0, m, lc, hc, e;

    /* Grow the box by a rounding allowance relative to the magnitudes involved */
    m = mbox > cmag ? mbox : cmag;
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
