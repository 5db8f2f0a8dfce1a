/* replay_hand.h: hand-built traces for the compiled replay's C tests
 * (test_replay.c, test_replay_ring.c): rays (parent, kind) and visits (ray,
 * stage, rays made) with their costs and packet sizes. */
#ifndef MPRT_TEST_REPLAY_HAND_H
#define MPRT_TEST_REPLAY_HAND_H

#include "mprt.h"

#include <string.h>

#define MAXV 64

typedef struct {
    mprt_trace_ray rays[MAXV];
    mprt_trace_visit visits[MAXV];
    int64_t process[MAXV], receive[MAXV], send[MAXV], flits[MAXV];
    size_t nr, nv;
} hand;

static inline void ray(hand *h, int64_t parent, int kind)
{
    mprt_trace_ray *r = &h->rays[h->nr];
    memset(r, 0, sizeof *r);
    r->id = (int64_t)h->nr;
    r->parent = parent;
    r->kind = (uint8_t)kind;
    h->nr++;
}

/* A visit of `cycles` processing cycles (no communication) whose packet is `flits` flits. */
static inline void visit_flits(hand *h, int64_t r, int stage, int made, int64_t cycles, int64_t flits)
{
    mprt_trace_visit *v = &h->visits[h->nv];
    memset(v, 0, sizeof *v);
    v->ray = r;
    v->stage = (uint8_t)stage;
    v->made = (uint8_t)made;
    h->process[h->nv] = cycles;
    h->receive[h->nv] = h->send[h->nv] = 0;
    h->flits[h->nv] = flits;
    h->nv++;
}

#endif
