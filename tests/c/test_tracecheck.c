/* test_tracecheck.c: mprt_trace_checker_* on a hand-built ray tree: sound
 * in one chunk or a visit at a time, each range and each invariant broken
 * alone found (and of the right kind), the ranges alone passing a trace
 * whose invariants break, calls out of order refused.  (tests/
 * test_recordcheck.py compares it with the Python checkers on the golden
 * traces.) */
#include "check.h"
#include "mprt.h"
#include "tree_hand.h"

#include <math.h>
#include <string.h>

static mprt_trace_ray rays[3];
static mprt_trace_visit visits[6];
static mprt_trace_limits lim;

static void build(void)
{
    int i;
    tree_hand(rays, visits);        /* tree_hand.h's tree, with its pixel, light, depth and no voxel */
    for (i = 0; i < 3; i++) {
        rays[i].pixel = 5;
        rays[i].light = -1;
        rays[i].depth = (uint8_t)(i > 0);
        rays[i].contribution = 1.0;
    }
    rays[1].light = 0;
    for (i = 0; i < 6; i++) visits[i].voxel_id = -1;
    visits[0].steps = 2;
    visits[1].tests[0] = 1;
    visits[1].prim = 0;
    visits[1].voxel_id = 3;
    memset(&lim, 0, sizeof lim);
    lim.pixels = 16;
    lim.lights = 1;
    lim.max_depth = 5;
    lim.voxels = 8;
    lim.prims = 1;
    lim.steps = 6;
    lim.tests = 4;
    lim.vertices = 0;
    lim.invariants = 1;
}

/* The fault kind of the records as they are, checked in chunks of `chunk` visits. */
static int run(size_t chunk)
{
    mprt_trace_checker *c = mprt_trace_checker_create(&lim, rays, 3);
    size_t j;
    int rc;
    if (!c) return -1;
    rc = mprt_trace_checker_rays(c, 0, 1);
    if (!rc) rc = mprt_trace_checker_rays(c, 1, 3);
    for (j = 0; !rc && j < 6; j += chunk) rc = mprt_trace_checker_visits(c, visits + j, j + chunk > 6 ? 6 - j : chunk);
    if (!rc) rc = mprt_trace_checker_finish(c);
    CHECK(rc == MPRT_TRACE_SOUND ? mprt_trace_checker_errmsg(c)[0] == '\0' : mprt_trace_checker_errmsg(c)[0] != '\0');
    mprt_trace_checker_destroy(c);
    return rc;
}

static void test_sound(void)
{
    build();
    CHECK(run(6) == MPRT_TRACE_SOUND);
    CHECK(run(1) == MPRT_TRACE_SOUND);
    CHECK(run(4) == MPRT_TRACE_SOUND);
}

static void test_ranges(void)
{
    build(); rays[1].id = 2; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); rays[2].parent = 3; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); rays[0].pixel = 16; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); rays[1].light = 1; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); rays[2].kind = 4; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); rays[2].depth = 6; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); rays[0].contribution = NAN; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[5].ray = 3; CHECK(run(1) == MPRT_TRACE_RANGE);
    build(); visits[1].voxel_id = 8; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[1].prim = 1; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[0].steps = 7; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[1].tests[3] = 5; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[1].vertices = 1; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[2].stage = 3; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[2].outcome = 9; CHECK(run(6) == MPRT_TRACE_RANGE);
    build(); visits[4].suppressed = 4; CHECK(run(6) == MPRT_TRACE_RANGE);
}

static void invariant(void)
{
    CHECK(run(6) == MPRT_TRACE_INVARIANT);
    CHECK(run(1) == MPRT_TRACE_INVARIANT);
    lim.invariants = 0;
    CHECK(run(6) == MPRT_TRACE_SOUND);
}

static void test_invariants(void)
{
    mprt_trace_visit t;
    build(); rays[2].parent = -1; invariant();                 /* a non-primary without a parent */
    build(); rays[2].depth = 0; rays[0].depth = 1; rays[1].depth = 1; invariant();    /* shallower */
    build(); rays[2].pixel = 6; invariant();                   /* another pixel */
    build(); visits[2].made = 1; invariant();                  /* made differs from the children */
    build(); visits[1].outcome = MPRT_OUT_RETURN; invariant(); /* IC/return then SC */
    build(); visits[5].outcome = MPRT_OUT_TO_IC; invariant();  /* ends with to_ic */
    build(); visits[3].stage = MPRT_STAGE_IC; visits[3].outcome = MPRT_OUT_BLOCKED; visits[4].ray = 2;
    invariant();                                               /* a ray without visits */
    build(); t = visits[4]; visits[4] = visits[5]; visits[5] = t; invariant();    /* ray 1 split */
    build(); rays[1].kind = MPRT_RAY_REFLECT; invariant();     /* lit, not a shadow ray */
    build(); rays[2].kind = MPRT_RAY_SHADOW; invariant();      /* a shadow ray that left */
    build(); visits[0].tests[0] = 1; invariant();              /* tests in OS */
    build(); visits[1].steps = 1; invariant();                 /* steps in IC */
    build(); t = visits[2]; visits[2] = visits[3]; visits[3] = t; invariant();    /* before its parent's SC */
    build(); visits[0].stage = MPRT_STAGE_IC; visits[0].outcome = MPRT_OUT_RETURN; invariant();  /* IC first */
}

static void test_out_of_order(void)
{
    mprt_trace_checker *c;
    build();
    c = mprt_trace_checker_create(&lim, rays, 3);
    CHECK(c != NULL);
    CHECK(mprt_trace_checker_visits(c, visits, 6) == MPRT_TRACE_RANGE);    /* before the rays */
    CHECK(mprt_trace_checker_finish(c) == MPRT_TRACE_RANGE);               /* the fault stays */
    mprt_trace_checker_destroy(c);
    c = mprt_trace_checker_create(&lim, rays, 3);
    CHECK(mprt_trace_checker_rays(c, 1, 3) == MPRT_TRACE_RANGE);
    mprt_trace_checker_destroy(c);
    CHECK(mprt_trace_checker_create(NULL, rays, 3) == NULL);
    CHECK(mprt_trace_checker_rays(NULL, 0, 0) == MPRT_TRACE_RANGE);
    mprt_trace_checker_destroy(NULL);
    c = mprt_trace_checker_create(&lim, NULL, 0);           /* no rays, no visits: sound */
    CHECK(c && mprt_trace_checker_rays(c, 0, 0) == 0 && mprt_trace_checker_visits(c, NULL, 0) == 0 &&
          mprt_trace_checker_finish(c) == 0);
    mprt_trace_checker_destroy(c);
}

int main(void)
{
    RUN(test_sound);
    RUN(test_ranges);
    RUN(test_invariants);
    RUN(test_out_of_order);
    return CHECK_DONE();
}
