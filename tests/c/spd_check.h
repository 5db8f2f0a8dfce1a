/* spd_check.h: what the SPD generator tests share: the scenes and their
 * size factors, generating one, and the tolerances. */
#ifndef MPRT_TEST_SPD_CHECK_H
#define MPRT_TEST_SPD_CHECK_H

#include "check.h"
#include "mprt_internal.h"

#include <stdlib.h>
#include <string.h>

#define REF_DIR "../data/spd-reference/"
#define PI 3.141592653589793
/* Tolerance for values the source defines exactly (wider if built with MPRT_SINGLE). */
#define NEAR (REAL_EPS > 1e-10 ? 1e-5 : 1e-12)

/* The scenes, in the order of names[]. */
enum { BALLS, GEARS, MOUNT, RINGS, TETRA, TREE, NSCENES };
static const char *const names[NSCENES] = {"balls", "gears", "mount", "rings", "tetra", "tree"};
static const int default_size[NSCENES] = {4, 4, 6, 7, 6, 11};
static const int max_size[NSCENES] = {8, 69, 12, 135, 12, 23};

static inline mprt_scene *gen(const char *name, int size)
{
    mprt_scene *s = NULL;
    int st;
    CHECK(mprt_scene_create(&s) == MPRT_OK);
    if (!s) return NULL;
    st = mprt_scene_spd(s, name, size);
    CHECK_MSG(st == MPRT_OK, "spd %s %d: %s", name, size, mprt_scene_errmsg(s));
    if (st != MPRT_OK) {
        mprt_scene_destroy(s);
        return NULL;
    }
    return s;
}

static inline long long ipow(long long b, int e)
{
    long long r = 1;
    while (e-- > 0) r *= b;
    return r;
}

#endif
