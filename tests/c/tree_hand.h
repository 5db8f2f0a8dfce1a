/* tree_hand.h: the hand-built ray tree of test_cost.c and test_tracecheck.c: a
 * primary ray 0 (OS to_ic, IC hit, SC shaded making a shadow ray 1 and a
 * reflection ray 2); ray 1: OS to_sc, SC lit; ray 2: OS left.  Its three rays
 * and six visits, every other field zero (prim -1); each test adds what it
 * reads (counts, pixels, limits). */
#ifndef MPRT_TEST_TREE_HAND_H
#define MPRT_TEST_TREE_HAND_H

#include "mprt.h"

#include <string.h>

static inline void tree_hand(mprt_trace_ray rays[3], mprt_trace_visit visits[6])
{
    static const int vs[6][4] = {   /* ray, stage, outcome, made */
        {0, MPRT_STAGE_OS, MPRT_OUT_TO_IC, 0}, {0, MPRT_STAGE_IC, MPRT_OUT_HIT, 0},
        {0, MPRT_STAGE_SC, MPRT_OUT_SHADED, 2}, {1, MPRT_STAGE_OS, MPRT_OUT_TO_SC, 0},
        {1, MPRT_STAGE_SC, MPRT_OUT_LIT, 0}, {2, MPRT_STAGE_OS, MPRT_OUT_LEFT, 0}};
    int i;
    memset(rays, 0, 3 * sizeof *rays);
    memset(visits, 0, 6 * sizeof *visits);
    for (i = 0; i < 3; i++) rays[i].id = i;
    rays[0].parent = -1;
    rays[1].parent = rays[2].parent = 0;
    rays[1].kind = MPRT_RAY_SHADOW;
    rays[2].kind = MPRT_RAY_REFLECT;
    for (i = 0; i < 6; i++) {
        visits[i].ray = vs[i][0];
        visits[i].stage = (uint8_t)vs[i][1];
        visits[i].outcome = (uint8_t)vs[i][2];
        visits[i].made = (uint8_t)vs[i][3];
        visits[i].prim = -1;
    }
}

#endif
