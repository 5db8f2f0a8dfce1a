/* ray.c: per-ray precomputation shared by the intersection routines. */
#include "mprt_internal.h"

/* 1/x with a signed infinity for a zero of either sign (no division by zero). */
static real inverse(real x)
{
    if (x != 0) return 1 / x;
    return signbit(x) ? -(real)INFINITY : (real)INFINITY;
}

void mprt__ray_prepare(mprt__ray *ray, vec3 o, vec3 d)
{
    real a[3], ax, ay, az;
    int kx, ky, kz, tmp;

    ray->o = o;
    ray->d = d;

    /* Reciprocal direction for slab and DDA set-up */
    ray->inv = v3(inverse(d.x), inverse(d.y), inverse(d.z));

    /* Dominant axis kz; kx, ky follow it cyclically (Woop, Benthin, Wald 2013) */
    ax = (real)fabs((double)d.x);
    ay = (real)fabs((double)d.y);
    az = (real)fabs((double)d.z);
    kz = ax >= ay ? (ax >= az ? 0 : 2) : (ay >= az ? 1 : 2);
    kx = kz == 2 ? 0 : kz + 1;
    ky = kx == 2 ? 0 : kx + 1;
    a[0] = d.x;
    a[1] = d.y;
    a[2] = d.z;

    /* Keep the permuted frame right-handed when the ray runs toward -kz */
    if (a[kz] < 0) {
        tmp = kx;
        kx = ky;
        ky = tmp;
    }
    ray->kx = kx;
    ray->ky = ky;
    ray->kz = kz;

    /* Shear constants: p -> (p[kx] + sx p[kz], p[ky] + sy p[kz], sz p[kz]) */
    if (a[kz] != 0) {
        ray->sx = -a[kx] / a[kz];
        ray->sy = -a[ky] / a[kz];
        ray->sz = 1 / a[kz];
    } else { /* zero direction: no hit is possible, keep the fields finite */
        ray->sx = ray->sy = 0;
        ray->sz = 0;
    }
    /* The shear rows as vectors, for branch-free dot products */
    {
        real mxa[3] = {0, 0, 0}, mya[3] = {0, 0, 0};
        mxa[kx] = 1;
        mxa[kz] = ray->sx;
        mya[ky] = 1;
        mya[kz] = ray->sy;
        ray->mx = v3(mxa[0], mxa[1], mxa[2]);
        ray->my = v3(mya[0], mya[1], mya[2]);
    }
}
