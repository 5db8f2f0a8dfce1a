/* test_replay_ring.c: the compiled replay's ring (level 2) on hand-built traces
 * whose timings are worked out here by hand (as tests/test_fidelity_ring.py's),
 * a ring deadlock and its report, and the checks of packet sizes and ring
 * configurations. */
#include "check.h"
#include "mprt.h"
#include "replay_hand.h"

#include <string.h>

/* Model M's stages on a ring of `classes` buffer classes, 1 cycle per flit. */
static mprt_replay_config ring_m(int classes)
{
    mprt_replay_config c;
    mprt_replay_config_init(&c);
    c.ring = 1;
    c.buffer_classes = classes;
    c.flit_time = 1;
    return c;
}

static const int64_t kid2[4] = {2, 2, 2, 2};

static mprt_replay *loaded(const hand *h, const mprt_replay_config *c)
{
    mprt_replay *r = NULL;
    CHECK(mprt_replay_create(c, &r) == MPRT_OK);
    CHECK(mprt_replay_load(r, h->rays, h->nr, h->visits, h->nv, h->process, h->receive, h->send) == MPRT_OK);
    CHECK(mprt_replay_set_flits(r, h->flits, h->nv, kid2, 4, 0) == MPRT_OK);
    return r;
}

static void test_hand_worked_ring_run(void)
{
    /* The primary (OS 10, IC 20, SC 30 making 2 rays), its shadow ray (OS 5, SC 4)
     * and its reflection (OS 6, IC 8, OS 3); 3 flits per visit's packet, 2 per child:
     * a packet over h links takes h + 2 cycles (a child h + 1).  OS 0-10; OS->IC
     * 10-13, IC 13-33; IC->SC 33-36, SC 36-66; ray 1 to OS 66-68, OS 68-73; ray 2
     * injected when ray 1's tail has left, 68-70, into OS's FIFO; OS->SC (2 links)
     * 73-77, SC 77-81; OS takes ray 2 73-79; OS->IC 79-82, IC 82-90; IC->OS
     * (2 links) 90-94, OS 94-97. */
    static const int64_t starts[8][2] = {{0, 0}, {13, 1}, {36, 2}, {68, 3}, {73, 5}, {77, 4}, {82, 6}, {94, 7}};
    hand h = {0};
    mprt_replay_config c = ring_m(3);
    mprt_replay *r;
    mprt_replay_info info;
    mprt_replay_node nodes[3];
    int64_t log[8 * 9], links[3];
    int e, n = 0;
    ray(&h, -1, MPRT_RAY_PRIMARY);
    ray(&h, 0, MPRT_RAY_SHADOW);
    ray(&h, 0, MPRT_RAY_REFLECT);
    visit_flits(&h, 0, MPRT_STAGE_OS, 0, 10, 3);
    visit_flits(&h, 0, MPRT_STAGE_IC, 0, 20, 3);
    visit_flits(&h, 0, MPRT_STAGE_SC, 2, 30, 0);
    visit_flits(&h, 1, MPRT_STAGE_OS, 0, 5, 3);
    visit_flits(&h, 1, MPRT_STAGE_SC, 0, 4, 0);
    visit_flits(&h, 2, MPRT_STAGE_OS, 0, 6, 3);
    visit_flits(&h, 2, MPRT_STAGE_IC, 0, 8, 3);
    visit_flits(&h, 2, MPRT_STAGE_OS, 0, 3, 0);
    r = loaded(&h, &c);
    CHECK(mprt_replay_run(r, log, 8 * 9) == MPRT_OK);
    CHECK(mprt_replay_get_info(r, &info) == MPRT_OK && info.cycles == 97 && info.events == 16);
    for (e = 0; e < info.events; e++)
        if (log[4 * e + 1] == 0) {
            CHECK(n < 8 && log[4 * e] == starts[n][0] && log[4 * e + 3] == starts[n][1]);
            n++;
        }
    CHECK(n == 8);
    /* links OS->IC: 3 + 3 (the first of OS->SC's) + 3; IC->SC: 3 + 3 + 3; SC->OS: 2 + 2 + 3 */
    CHECK(mprt_replay_get_links(r, links, 3) == MPRT_OK);
    CHECK(links[0] == 9 && links[1] == 9 && links[2] == 7);
    CHECK(mprt_replay_get_links(r, links, 2) == MPRT_ERR_CAPACITY);
    /* OS's receive FIFO: a slot reserved from each header's claim to its delivery to
     * the idle OS (ray 1: 67-68; ray 7: 92-94) or to OS taking it (ray 2: reserved at 69,
     * filled at 70, taken at 73): 1 + 2 + 4 packet-cycles, one packet put */
    CHECK(mprt_replay_get_nodes(r, nodes, 3) == MPRT_OK);
    CHECK(nodes[0].receive_max == 1 && nodes[0].receive_puts == 1 && nodes[0].receive_area == 7);
    CHECK(nodes[0].send_puts == 3 && nodes[0].receive_reserved == 0);
    mprt_replay_destroy(r);
}

/* Four rays OS, IC, OS, IC, SC of 1-4 cycles and 2-flit packets: on one buffer class
 * an OS->IC header waits at OS for IC's buffer, held by an IC->OS packet whose header
 * waits at SC for OS's buffer. */
static hand four_rays(void)
{
    static const int64_t d[20] = {1, 2, 2, 1, 1, 2, 3, 2, 2, 1, 3, 4, 2, 1, 1, 1, 1, 2, 2, 1};
    static const int st[5] = {MPRT_STAGE_OS, MPRT_STAGE_IC, MPRT_STAGE_OS, MPRT_STAGE_IC, MPRT_STAGE_SC};
    hand h = {0};
    int k, v;
    for (k = 0; k < 4; k++) ray(&h, -1, MPRT_RAY_PRIMARY);
    for (k = 0; k < 4; k++)
        for (v = 0; v < 5; v++) visit_flits(&h, k, st[v], 0, d[5 * k + v], 2);
    return h;
}

static void test_ring_deadlock(void)
{
    hand h = four_rays();
    mprt_replay_config c = ring_m(1);
    mprt_replay *r = loaded(&h, &c);
    mprt_replay_info info;
    int64_t buffers[3], waiting[12];
    size_t nw = 0;
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_STATE);
    CHECK(strstr(mprt_replay_errmsg(r), "deadlock") != NULL);
    CHECK(mprt_replay_get_info(r, &info) == MPRT_OK && info.deadlocked == 1 && info.cycles == -1);
    CHECK(mprt_replay_get_ring(r, 0, buffers, 3, waiting, 12, &nw) == MPRT_OK);
    /* OS holds OS->IC (0 x 4 + 1), IC and SC the IC->OS packet (1 x 4 + 0) */
    CHECK(buffers[0] == 1 && buffers[1] == 4 && buffers[2] == 4);
    CHECK(nw == 2);
    CHECK(waiting[0] == 0 && waiting[1] == 1 && waiting[2] == 0 && waiting[3] == 0);
    CHECK(waiting[4] == 1 && waiting[5] == 0 && waiting[6] == 2 && waiting[7] == 0);
    CHECK(mprt_replay_get_ring(r, 0, buffers, 3, waiting, 4, &nw) == MPRT_ERR_CAPACITY && nw == 2);
    CHECK(mprt_replay_get_ring(r, 1, buffers, 3, waiting, 12, &nw) == MPRT_ERR_INVALID_ARG);
    /* the structured pool (a class per hop) completes */
    c = ring_m(3);
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK);
    CHECK(mprt_replay_get_info(r, &info) == MPRT_OK && info.retired == 4 && info.cycles > 0);
    mprt_replay_destroy(r);
}

static void test_bad_rings_and_flits(void)
{
    hand h = four_rays();
    mprt_replay_config c = ring_m(3), m;
    mprt_replay *r = NULL;
    int64_t kids[4] = {2, 2, 2, 2}, keep;
    CHECK(mprt_replay_create(&c, &r) == MPRT_OK);
    CHECK(mprt_replay_set_flits(r, h.flits, h.nv, kids, 4, 0) == MPRT_ERR_STATE);      /* no trace yet */
    CHECK(mprt_replay_load(r, h.rays, h.nr, h.visits, h.nv, h.process, h.receive, h.send) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_STATE);
    CHECK(strstr(mprt_replay_errmsg(r), "mprt_replay_set_flits") != NULL);
    CHECK(mprt_replay_set_flits(r, h.flits, h.nv - 1, kids, 4, 0) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "19 entries for 20 visits") != NULL);
    CHECK(mprt_replay_set_flits(r, h.flits, h.nv, kids, 3, 0) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_replay_set_flits(r, h.flits, h.nv, kids, 4, -1) == MPRT_ERR_INVALID_ARG);
    keep = h.flits[7];
    h.flits[7] = 70000;
    CHECK(mprt_replay_set_flits(r, h.flits, h.nv, kids, 4, 0) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "flits[7]") != NULL);
    h.flits[7] = keep;
    kids[3] = -2;
    CHECK(mprt_replay_set_flits(r, h.flits, h.nv, kids, 4, 0) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "kid_flits[3]") != NULL);
    kids[3] = 2;
    CHECK(mprt_replay_set_flits(r, h.flits, h.nv, kids, 4, 0) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK);
    /* configurations */
    m = c;
    m.buffer_classes = 4;
    CHECK(mprt_replay_set_config(r, &m) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "ring.buffer_classes") != NULL);
    m = c;
    m.buffer_classes = 0;
    CHECK(mprt_replay_set_config(r, &m) == MPRT_ERR_INVALID_ARG);
    m = c;
    m.flit_time = 0;
    CHECK(mprt_replay_set_config(r, &m) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "ring.flit_time") != NULL);
    m = c;
    m.ring = 2;
    CHECK(mprt_replay_set_config(r, &m) == MPRT_ERR_INVALID_ARG);
    m = c;
    m.nstages = 1;
    m.stage_of[0] = m.stage_of[1] = m.stage_of[2] = 0;
    m.buffer_classes = 1;
    CHECK(mprt_replay_set_config(r, &m) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "at least 2 stages") != NULL);
    m = c;
    m.flit_time = INT64_MAX / 8;      /* could overflow the clock */
    CHECK(mprt_replay_set_config(r, &m) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "flit_time") != NULL);
    /* the ideal network's runs have no ring figures */
    m = c;
    m.ring = 0;
    CHECK(mprt_replay_set_config(r, &m) == MPRT_OK && mprt_replay_run(r, NULL, 0) == MPRT_OK);
    CHECK(mprt_replay_get_links(r, kids, 4) == MPRT_ERR_STATE);
    mprt_replay_destroy(r);
}

static void test_ring_runs_repeat_exactly(void)
{
    /* one load, several runs on and off the ring, in any order: the same cycles */
    hand h = four_rays();
    mprt_replay_config a = ring_m(3), b = ring_m(2), ideal;
    mprt_replay *r = loaded(&h, &a);
    mprt_replay_info info;
    int64_t first[3], again[3];
    int i;
    mprt_replay_config_init(&ideal);
    b.flit_time = 3;
    for (i = 0; i < 2; i++) {
        int64_t *out = i ? again : first;
        CHECK(mprt_replay_set_config(r, &a) == MPRT_OK && mprt_replay_run(r, NULL, 0) == MPRT_OK);
        CHECK(mprt_replay_get_info(r, &info) == MPRT_OK);
        out[0] = info.cycles;
        CHECK(mprt_replay_set_config(r, &ideal) == MPRT_OK && mprt_replay_run(r, NULL, 0) == MPRT_OK);
        CHECK(mprt_replay_get_info(r, &info) == MPRT_OK);
        out[1] = info.cycles;
        CHECK(mprt_replay_set_config(r, &b) == MPRT_OK && mprt_replay_run(r, NULL, 0) == MPRT_OK);
        CHECK(mprt_replay_get_info(r, &info) == MPRT_OK);
        out[2] = info.cycles;
    }
    CHECK(memcmp(first, again, sizeof first) == 0);
    CHECK(first[1] < first[0] && first[0] < first[2]);     /* the ring adds time; slower links more */
    mprt_replay_destroy(r);
}

int main(void)
{
    RUN(test_hand_worked_ring_run);
    RUN(test_ring_deadlock);
    RUN(test_bad_rings_and_flits);
    RUN(test_ring_runs_repeat_exactly);
    return CHECK_DONE();
}
