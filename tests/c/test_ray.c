/* test_ray.c: the per-ray precomputation (mprt__ray_prepare) holds what
 * mprt_internal.h says it holds, bit for bit: inv = 1/d (a signed infinity
 * for a zero of either sign), sz = 1/d[kz], sx = -d[kx]/d[kz], sy =
 * -d[ky]/d[kz], and the shear rows mx, my with 1 on kx (ky), the shear
 * constant on kz and zeros elsewhere; directions with zero components,
 * negative zeros and ties between the largest components included. */
#include "check.h"
#include "geom.h"

static real comp(vec3 a, int k) { return k == 0 ? a.x : k == 1 ? a.y : a.z; }

static int same_bits(real a, real b) { return a == b && signbit(a) == signbit(b); }

static void test_prepared_fields_follow_their_definitions(void)
{
    static const real picks[] = {0, -0.0, 1, -1, 0.5, -2, 3};
    rng r;
    int i, k, bad = 0;
    rng_seed(&r, 7);
    for (i = 0; i < 20000; i++) {
        mprt__ray ray;
        real d[3], inv;
        for (k = 0; k < 3; k++)
            d[k] = rnd_int(&r, 0, 2) ? (real)rnd_in(&r, -4, 4) : picks[rnd_int(&r, 0, 6)];
        if (d[0] == 0 && d[1] == 0 && d[2] == 0) continue;
        mprt__ray_prepare(&ray, v3(1, 2, 3), v3(d[0], d[1], d[2]));
        for (k = 0; k < 3; k++) {
            inv = d[k] != 0 ? 1 / d[k] : signbit(d[k]) ? -(real)INFINITY : (real)INFINITY;
            if (!same_bits(comp(ray.inv, k), inv)) bad++;
            if (!same_bits(comp(ray.mx, k), k == ray.kx ? 1 : k == ray.kz ? ray.sx : 0)) bad++;
            if (!same_bits(comp(ray.my, k), k == ray.ky ? 1 : k == ray.kz ? ray.sy : 0)) bad++;
        }
        if (!same_bits(ray.sz, 1 / d[ray.kz]) || !same_bits(ray.sx, -d[ray.kx] / d[ray.kz]) ||
            !same_bits(ray.sy, -d[ray.ky] / d[ray.kz]))
            bad++;
    }
    CHECK_MSG(bad == 0, "%d fields differ from their definitions", bad);
}

int main(void)
{
    RUN(test_prepared_fields_follow_their_definitions);
    return CHECK_DONE();
}
