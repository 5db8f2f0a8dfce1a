/* test_cost.c: mprt_cost_children and mprt_cost_visits on a hand-built ray
 * tree whose costs are worked out here by hand; the counted pass (runs,
 * packets) against the fast one; threads sharing a large trace with the
 * same results; bad traces named.  (tests/test_cost_fast.py compares the C
 * pass with the numpy reference on the golden traces.) */
#include "check.h"
#include "mprt.h"
#include "tree_hand.h"

#include <stdlib.h>
#include <string.h>

static mprt_trace_ray rays[3];
static mprt_trace_visit visits[7];         /* tree_hand.h's six, and a seventh left zero */
static const int32_t prim_kind[2] = {0, 1};

static void build(void)
{
    memset(visits, 0, sizeof visits);
    tree_hand(rays, visits);
    visits[0].steps = 3;
    visits[1].tests[0] = 2;
    visits[1].tests[1] = 1;
    visits[1].vertices = 4;
    visits[1].prim = 0;
    visits[2].prim = 0;
    visits[2].suppressed = 1;
    visits[5].steps = 5;
}

/* Kernel k of stage s costs 10 * (s + 1) + k; overheads 100, 200, 300;
 * packets: 1000 + 10 x (s + 1) per send, per flit s + 1, receive 2000 +
 * 20 x (s + 1), per flit 2; a packet src -> dst of kind k has 5 + src + 3 dst + k flits. */
static void table(mprt_cost_table *t)
{
    int s, d, k;
    memset(t, 0, sizeof *t);
    for (s = 0; s < 3; s++) {
        for (k = 0; k < MPRT_COST_KERNELS; k++) t->kernel[s][k] = 10 * (s + 1) + k;
        t->overhead[s] = 100 * (s + 1);
        t->send_packet[s] = 1000 + 10 * (s + 1);
        t->send_flit[s] = s + 1;
        t->receive_packet[s] = 2000 + 20 * (s + 1);
        t->receive_flit[s] = 2;
        for (d = 0; d < 3; d++)
            for (k = 0; k < 4; k++) t->flits[s][d][k] = 5 + s + 3 * d + k;
    }
    t->lights = 2;
}

static int64_t F(int s, int d, int k) { return 5 + s + 3 * d + k; }

static void test_costs_by_hand(void)
{
    mprt_cost_table t;
    int64_t kids[12], p[6], x[6], y[6];
    int32_t f[6];
    char msg[200];
    build();
    table(&t);
    CHECK(mprt_cost_children(rays, 3, kids, msg, sizeof msg) == MPRT_OK);
    CHECK(kids[0 * 4 + MPRT_RAY_SHADOW] == 1 && kids[0 * 4 + MPRT_RAY_REFLECT] == 1 && kids[4 + 3] == 0);
    CHECK(mprt_cost_visits(&t, rays, kids, 3, prim_kind, 2, visits, 6, -1, 0, p, x, y, f, NULL, NULL, 4, msg,
                           sizeof msg) == MPRT_OK);
    /* OS: set-up (first) + 3 steps + visit; from SC; to IC */
    CHECK(p[0] == 100 + 10 + 3 * 11 + 12);
    CHECK(x[0] == 2020 + 2 * F(2, 0, 0));
    CHECK(y[0] == 1010 + 1 * F(0, 1, 0) && f[0] == F(0, 1, 0));
    /* IC: visit + 2 sphere + 1 polygon tests + 4 vertices + sphere hit; from OS; to SC */
    CHECK(p[1] == 200 + 20 + 2 * 21 + 22 + 4 * 25 + 26);
    CHECK(x[1] == 2040 + 2 * F(0, 1, 0));
    CHECK(y[1] == 1020 + 2 * F(1, 2, 0) && f[1] == F(1, 2, 0));
    /* SC shaded: shade + 2 lights + (2 made + 1 suppressed) keep + a shadow and a reflection child */
    CHECK(p[2] == 300 + 30 + 2 * 31 + 3 * 32 + 33 + 34);
    CHECK(x[2] == 2060 + 2 * F(1, 2, 0));
    CHECK(f[2] == F(2, 0, 3) + F(2, 0, 1) && y[2] == 2 * 1030 + 3 * f[2]);
    /* shadow ray: OS to SC, SC lit; reflection ray: OS left (no packet out) */
    CHECK(p[3] == 100 + 10 + 12 && y[3] == 1010 + F(0, 2, 3) && x[3] == 2020 + 2 * F(2, 0, 3));
    CHECK(p[4] == 300 + 36 && x[4] == 2060 + 2 * F(0, 2, 3) && y[4] == 0 && f[4] == 0);
    CHECK(p[5] == 100 + 10 + 5 * 11 + 12 && y[5] == 0 && x[5] == 2020 + 2 * F(2, 0, 1));
}

static void test_counted_pass_agrees(void)
{
    mprt_cost_table t;
    int64_t kids[12], p[6], x[6], y[6], p2[6], x2[6], y2[6];
    int32_t f[6], f2[6], runs[6 * MPRT_COST_KERNELS], pk[18];
    build();
    table(&t);
    CHECK(mprt_cost_children(rays, 3, kids, NULL, 0) == MPRT_OK);
    CHECK(mprt_cost_visits(&t, rays, kids, 3, prim_kind, 2, visits, 6, -1, 0, p, x, y, f, NULL, NULL, 1, NULL, 0) ==
          MPRT_OK);
    CHECK(mprt_cost_visits(&t, rays, kids, 3, prim_kind, 2, visits, 6, -1, 0, p2, x2, y2, f2, runs, pk, 1, NULL,
                           0) == MPRT_OK);
    CHECK(!memcmp(p, p2, sizeof p) && !memcmp(x, x2, sizeof x) && !memcmp(y, y2, sizeof y) && !memcmp(f, f2, sizeof f));
    CHECK(runs[0] == 1 && runs[1] == 3 && runs[2] == 1);                 /* OS: set-up, steps, visit */
    CHECK(runs[2 * MPRT_COST_KERNELS + 1] == 2 && runs[2 * MPRT_COST_KERNELS + 2] == 3);   /* lights, keep */
    CHECK(pk[3 * 2 + 1] == 2 && pk[3 * 2 + 2] == f[2]);                  /* SC: 2 packets out */
}

static void test_threads_give_the_same_results(void)
{
    size_t reps = ((size_t)1 << 21) / 6 + 1, nv = 6 * reps, nr = 3 * reps, i;
    mprt_trace_ray *r = malloc(nr * sizeof *r);
    mprt_trace_visit *v = malloc(nv * sizeof *v);
    int64_t *kids = malloc(4 * nr * sizeof *kids), *p1 = malloc(nv * sizeof *p1), *p4 = malloc(nv * sizeof *p4);
    int32_t *f1 = malloc(nv * sizeof *f1), *f4 = malloc(nv * sizeof *f4);
    mprt_cost_table t;
    char msg[200];
    CHECK(r && v && kids && p1 && p4 && f1 && f4);
    if (!(r && v && kids && p1 && p4 && f1 && f4)) goto done;
    build();
    table(&t);
    for (i = 0; i < reps; i++) {
        size_t k;
        for (k = 0; k < 3; k++) {
            r[3 * i + k] = rays[k];
            r[3 * i + k].id = (int64_t)(3 * i + k);
            if (rays[k].parent >= 0) r[3 * i + k].parent = (int64_t)(3 * i);
        }
        for (k = 0; k < 6; k++) {
            v[6 * i + k] = visits[k];
            v[6 * i + k].ray = (int64_t)(3 * i) + visits[k].ray;
            v[6 * i + k].steps = (int32_t)(i % 7);
        }
    }
    CHECK(mprt_cost_children(r, nr, kids, msg, sizeof msg) == MPRT_OK);
    CHECK(mprt_cost_visits(&t, r, kids, nr, prim_kind, 2, v, nv, -1, 0, p1, NULL, NULL, f1, NULL, NULL, 1, msg,
                           sizeof msg) == MPRT_OK);
    CHECK(mprt_cost_visits(&t, r, kids, nr, prim_kind, 2, v, nv, -1, 0, p4, NULL, NULL, f4, NULL, NULL, 4, msg,
                           sizeof msg) == MPRT_OK);
    CHECK(!memcmp(p1, p4, nv * sizeof *p1) && !memcmp(f1, f4, nv * sizeof *f1));
    /* the first visit at fault is named, whichever thread meets it */
    v[nv - 2].stage = 5;
    v[nv / 2 + 1].stage = 4;
    CHECK(mprt_cost_visits(&t, r, kids, nr, prim_kind, 2, v, nv, -1, 0, p4, NULL, NULL, NULL, NULL, NULL, 3, msg,
                           sizeof msg) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(msg, "stage 4 is not OS, IC or SC") != NULL);
done:
    free(r);
    free(v);
    free(kids);
    free(p1);
    free(p4);
    free(f1);
    free(f4);
}

static void test_bad_traces_are_named(void)
{
    mprt_cost_table t;
    int64_t kids[12], p[6];
    char msg[200];
    build();
    table(&t);
    rays[2].parent = 7;
    CHECK(mprt_cost_children(rays, 3, kids, msg, sizeof msg) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(msg, "ray 2: parent 7 is not a ray") != NULL);
    build();
    rays[1].kind = 6;
    CHECK(mprt_cost_children(rays, 3, kids, msg, sizeof msg) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(msg, "ray 1: kind 6") != NULL);
    build();
    CHECK(mprt_cost_children(rays, 3, kids, msg, sizeof msg) == MPRT_OK);
    visits[3].ray = 3;
    CHECK(mprt_cost_visits(&t, rays, kids, 3, prim_kind, 2, visits, 6, -1, 0, p, NULL, NULL, NULL, NULL, NULL, 1,
                           msg, sizeof msg) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(msg, "visit 3: ray 3 is not a ray") != NULL);
    build();
    visits[1].prim = 2;
    CHECK(mprt_cost_visits(&t, rays, kids, 3, prim_kind, 2, visits, 6, -1, 0, p, NULL, NULL, NULL, NULL, NULL, 1,
                           msg, sizeof msg) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(msg, "visit 1: primitive 2") != NULL);
    CHECK(mprt_cost_visits(NULL, rays, kids, 3, prim_kind, 2, visits, 6, -1, 0, p, NULL, NULL, NULL, NULL, NULL, 1,
                           msg, sizeof msg) == MPRT_ERR_INVALID_ARG);
}

/* The replay loaded with the visits priced as they load runs as the one
 * loaded with mprt_cost_visits's arrays, and gives the same flits; a chunk
 * of the replay's pricing that fails names the visit. */
static void test_priced_loading_agrees(void)
{
    mprt_cost_table t;
    mprt_replay_config c;
    mprt_replay *a = NULL, *b = NULL;
    mprt_replay_info ia, ib;
    int64_t kids[12], p[6], x[6], y[6];
    int32_t f[6], f2[6];
    build();
    table(&t);
    CHECK(mprt_cost_children(rays, 3, kids, NULL, 0) == MPRT_OK);
    CHECK(mprt_cost_visits(&t, rays, kids, 3, prim_kind, 2, visits, 6, -1, 0, p, x, y, f, NULL, NULL, 1, NULL, 0) ==
          MPRT_OK);
    mprt_replay_config_init(&c);
    CHECK(mprt_replay_create(&c, &a) == MPRT_OK && mprt_replay_create(&c, &b) == MPRT_OK);
    CHECK(mprt_replay_load(a, rays, 3, visits, 6, p, x, y) == MPRT_OK);
    CHECK(mprt_replay_load_priced(b, rays, 3, visits, 6, &t, kids, prim_kind, 2, f2) == MPRT_OK);
    CHECK(!memcmp(f, f2, sizeof f));
    CHECK(mprt_replay_run(a, NULL, 0) == MPRT_OK && mprt_replay_run(b, NULL, 0) == MPRT_OK);
    CHECK(mprt_replay_get_info(a, &ia) == MPRT_OK && mprt_replay_get_info(b, &ib) == MPRT_OK);
    CHECK(ia.cycles > 0 && ia.cycles == ib.cycles && ia.retired == ib.retired);
    CHECK(mprt_replay_load_priced(b, rays, 3, visits, 6, &t, kids, prim_kind, 0, NULL) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(b), "cannot cost this trace: visit 1: primitive") != NULL);
    CHECK(mprt_replay_load_priced(b, rays, 3, visits, 6, NULL, kids, prim_kind, 2, NULL) == MPRT_ERR_INVALID_ARG);
    mprt_replay_destroy(a);
    mprt_replay_destroy(b);
}

/* Level 3's memory keys: IC visits their voxel, SC visits naming a primitive
 * -2 - its material, the rest -1; references counted per key. */
static void test_visit_keys(void)
{
    int64_t mat[2] = {1, 0}, vref[8], mref[2];
    int32_t keys[6];
    char msg[200];
    build();
    visits[1].voxel_id = 5;
    CHECK(mprt_visit_keys(visits, 6, mat, 2, keys, vref, 8, mref, 2, msg, sizeof msg) == MPRT_OK);
    CHECK(keys[0] == -1 && keys[1] == 5 && keys[2] == -2 - 1 && keys[3] == -1 && keys[4] == -1 && keys[5] == -1);
    CHECK(vref[5] == 1 && vref[0] == 0 && mref[1] == 1 && mref[0] == 0);
    visits[1].voxel_id = 8;
    CHECK(mprt_visit_keys(visits, 6, mat, 2, keys, vref, 8, mref, 2, msg, sizeof msg) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(msg, "visit 1") != NULL);
}

int main(void)
{
    RUN(test_costs_by_hand);
    RUN(test_counted_pass_agrees);
    RUN(test_threads_give_the_same_results);
    RUN(test_bad_traces_are_named);
    RUN(test_priced_loading_agrees);
    RUN(test_visit_keys);
    return CHECK_DONE();
}
