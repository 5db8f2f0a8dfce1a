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
    real ax, ay, az, akx, aky, akz, sx, sy;
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
    akz = vget(d, kz);

    /* Keep the permuted frame right-handed when the ray runs toward -kz */
    if (akz < 0) {
        tmp = kx;
        kx = ky;
        ky = tmp;
    }
    ray->kx = kx;
    ray->ky = ky;
    ray->kz = kz;
    akx = vget(d, kx);
    aky = vget(d, ky);

    /* Shear constants: p -> (p[kx] + sx p[kz], p[ky] + sy p[kz], sz p[kz]);
     * sz = 1 / d[kz] is inv[kz] */
    if (akz != 0) {
        sx = -akx / akz;
        sy = -aky / akz;
        ray->sz = vget(ray->inv, kz);
    } else { /* zero direction: no hit is possible, keep the fields finite */
        sx = sy = 0;
        ray->sz = 0;
    }
    ray->sx = sx;
    ray->sy = sy;
    /* The shear rows as vectors, for branch-free dot products (selected
     * component by component: a store at a variable index followed by a
     * vector load stalls on store forwarding) */
    ray->mx = v3(kx == 0 ? 1 : kz == 0 ? sx : 0, kx == 1 ? 1 : kz == 1 ? sx : 0, kx == 2 ? 1 : kz == 2 ? sx : 0);
    ray->my = v3(ky == 0 ? 1 : kz == 0 ? sy : 0, ky == 1 ? 1 : kz == 1 ? sy : 0, ky == 2 ? 1 : kz == 2 ? sy : 0);
}
