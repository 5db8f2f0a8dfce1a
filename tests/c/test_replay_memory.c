/* test_replay_memory.c: level 3 of the compiled replay (mprt_replay_set_memory,
 * the memory fields of mprt_replay_config, mprt_replay_get_memory) on
 * hand-built traces whose stalls are worked out here by hand, and its checks
 * of memory configurations and data. */
#include "check.h"
#include "mprt.h"

#include <string.h>

#define MAXV 16

/* Primaries, each an OS visit of 1 cycle then an IC visit of 10 reading key 0
 * (and, with sc, an SC visit of 1 reading material 0). */
typedef struct {
    mprt_trace_ray rays[MAXV];
    mprt_trace_visit visits[MAXV];
    int64_t process[MAXV], receive[MAXV], send[MAXV];
    int32_t key[MAXV];
    size_t nr, nv;
} hand;

static void visit(hand *h, int64_t ray, int stage, int64_t cycles, int32_t key)
{
    mprt_trace_visit *v = &h->visits[h->nv];
    memset(v, 0, sizeof *v);
    v->ray = ray;
    v->stage = (uint8_t)stage;
    h->process[h->nv] = cycles;
    h->receive[h->nv] = h->send[h->nv] = 0;
    h->key[h->nv] = key;
    h->nv++;
}

static hand primaries(int n, int sc)
{
    hand h;
    int i;
    memset(&h, 0, sizeof h);
    for (i = 0; i < n; i++) {
        mprt_trace_ray *r = &h.rays[h.nr];
        r->id = (int64_t)h.nr++;
        r->parent = -1;
        r->kind = MPRT_RAY_PRIMARY;
        visit(&h, i, MPRT_STAGE_OS, 1, -1);
        visit(&h, i, MPRT_STAGE_IC, 10, 0);
        if (sc) visit(&h, i, MPRT_STAGE_SC, 1, -2);
    }
    return h;
}

/* Key 0 reads 3 items, 1 resident, and lines 5, 6, 5 (8-byte lines); material 0 one line. */
static const int32_t IC_ITEMS[1] = {3}, IC_RES[1] = {1}, SC_ITEMS[1] = {1}, SC_RES[1] = {0};
static const int64_t IC_START[2] = {0, 3}, IC_LINES[3] = {5, 6, 5}, SC_START[2] = {0, 1}, SC_LINES[1] = {0};

static mprt_replay_memory_data ic_data(void)
{
    mprt_replay_memory_data d = {1, 8, IC_ITEMS, IC_RES, IC_START, IC_LINES};
    return d;
}

static mprt_replay_memory_data sc_data(void)
{
    mprt_replay_memory_data d = {1, 32, SC_ITEMS, SC_RES, SC_START, SC_LINES};
    return d;
}

/* Model S; IC: a direct-mapped cache of 2 sets of 8-byte lines, ICGM latency 10, 4 bytes a
 * cycle (a line's transfer: 2 cycles). */
static mprt_replay_config model_s(int pes, int contention)
{
    mprt_replay_config c;
    mprt_replay_config_init(&c);
    c.nstages = 1;
    c.stage_of[0] = c.stage_of[1] = c.stage_of[2] = 0;
    c.pes = pes;
    c.dis = MPRT_DIS_BLOCKS;
    c.memory[0] = 1;
    c.cache_size[0] = 16;
    c.cache_line[0] = 8;
    c.cache_ways[0] = 1;
    c.gm_latency[0] = 10;
    c.gm_bandwidth[0] = 4;
    c.gm_contention[0] = contention;
    return c;
}

static mprt_replay *loaded(const hand *h, const mprt_replay_config *c)
{
    mprt_replay *r;
    mprt_replay_memory_data ic = ic_data(), sc = sc_data();
    CHECK(mprt_replay_create(c, &r) == MPRT_OK);
    CHECK(mprt_replay_load(r, h->rays, h->nr, h->visits, h->nv, h->process, h->receive, h->send) == MPRT_OK);
    CHECK(mprt_replay_set_memory(r, h->key, h->nv, &ic, &sc) == MPRT_OK);
    return r;
}

static int64_t run_cycles(mprt_replay *r)
{
    mprt_replay_info info;
    if (mprt_replay_run(r, NULL, 0) != MPRT_OK || mprt_replay_get_info(r, &info) != MPRT_OK) return -1;
    return info.cycles;
}

static void test_misses_hits_and_stalls(void)
{
    /* ray 0: OS 0-1; IC at 1: line 5 misses (set 1), 6 misses (set 0), 5 hits.  Reads: the
     * first from 1, port free at 3, data at 1 + 2 + 10 = 13; the second from 13, data at 25:
     * stall 24, IC ends at 1 + 10 + 24 = 35.  Ray 1: OS 35-36, IC 36-46, all hits. */
    hand h = primaries(2, 0);
    mprt_replay_config c = model_s(1, 1);
    mprt_replay *r = loaded(&h, &c);
    mprt_replay_memory m[2];
    mprt_replay_proc p;
    int64_t stall[1];
    CHECK(run_cycles(r) == 46);
    CHECK(mprt_replay_get_memory(r, m, 1, stall, 1) == MPRT_ERR_CAPACITY);
    CHECK(mprt_replay_get_memory(r, m, 2, stall, 1) == MPRT_OK);
    CHECK(m[0].stall == 24 && stall[0] == 24);
    CHECK(m[0].cache_accesses == 6 && m[0].cache_hits == 4);
    CHECK(m[0].resident_accesses == 6 && m[0].resident_hits == 2);
    CHECK(m[0].gm_accesses == 2 && m[0].gm_busy == 4 && m[0].gm_queued == 0);
    CHECK(m[1].stall == 0 && m[1].gm_accesses == 0);      /* SC data not modelled */
    CHECK(mprt_replay_get_procs(r, &p, 1) == MPRT_OK && p.busy == 46);
    /* no cache: every line outside resident memory is read, 3 x 12 cycles each visit */
    c.cache_size[0] = 0;
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(run_cycles(r) == 2 * (1 + 10 + 36));
    /* the largest cache allowed (2^37 sets): no conflicts, arrays no larger than the data */
    c.cache_size[0] = MPRT_REPLAY_MAX_CACHE;
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(run_cycles(r) == 46);
    /* one set of one way: 5, 6, 5 all miss; the second ray finds 5, then misses 6 and 5 */
    c.cache_size[0] = 8;
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(run_cycles(r) == (1 + 10 + 36) + (1 + 10 + 24));
    mprt_replay_destroy(r);
}

static int64_t work_bound(mprt_replay *r, const mprt_replay_config *c)
{
    int64_t b = -1;
    if (mprt_replay_set_config(r, c) != MPRT_OK || mprt_replay_work_bound(r, &b) != MPRT_OK) return -1;
    return b;
}

static void test_work_bound_with_memories(void)
{
    /* two rays of OS 1 and IC 10 cycles on model S: 22 cycles of work.  With the cache, a visit
     * may read nothing: 22.  Without: each IC visit reads its 3 lines at 2 + 10 cycles at
     * least, 22 + 72 = 94, the run's cycles exactly (one processor, its reads never queued).
     * Two PEs on a shared port, without the cache: a PE's work 11 + 36 = 47, below the run's
     * 73 (the second PE's reads wait for the port until 27: 1 + 10 + 26 + 36). */
    hand h = primaries(2, 0);
    mprt_replay_config c = model_s(1, 1);
    mprt_replay *r = loaded(&h, &c);
    CHECK(work_bound(r, &c) == 22 && run_cycles(r) == 46);
    c.cache_size[0] = 0;
    CHECK(work_bound(r, &c) == 94 && run_cycles(r) == 94);
    c.pes = 2;
    CHECK(work_bound(r, &c) == 47 && run_cycles(r) == 73);
    c.memory[0] = 0;                    /* not modelled: no stalls */
    CHECK(work_bound(r, &c) == 11);
    /* one set of one way: lines 5 and 6 cannot both be there when a visit begins, so each IC
     * visit misses once at least whatever came before: 22 + 2 x 12, below the run's 82 */
    c.memory[0] = 1;
    c.pes = 1;
    c.cache_size[0] = 8;
    CHECK(work_bound(r, &c) == 46 && run_cycles(r) == 82);
    c.cache_size[0] = 16;               /* two sets, or (below) two ways: both lines fit */
    CHECK(work_bound(r, &c) == 22);
    c.cache_ways[0] = 2;
    CHECK(work_bound(r, &c) == 22);
    mprt_replay_destroy(r);
}

static void test_ports_shared_or_per_pe(void)
{
    /* two PEs, one ray each, their IC visits both start at 1 (PE 0 first, by rank).  Shared
     * port: PE 0 reads at 1 and 13 (stall 24); PE 1's first read waits for the port until 15
     * (queued 14), data at 27, the second at 39: stall 38, the run 1 + 10 + 38 = 49.  A port
     * per PE: both stall 24, 35 cycles. */
    hand h = primaries(2, 0);
    mprt_replay_config c = model_s(2, 1);
    mprt_replay *r = loaded(&h, &c);
    mprt_replay_memory m[4];
    CHECK(run_cycles(r) == 49);
    CHECK(mprt_replay_get_memory(r, m, 4, NULL, 0) == MPRT_OK);
    CHECK(m[0].stall == 24 && m[2].stall == 38 && m[2].gm_queued == 14 && m[0].gm_queued == 0);
    CHECK(m[0].cache_hits == 1 && m[2].cache_hits == 1);   /* a cache per PE */
    c.gm_contention[0] = 0;
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(run_cycles(r) == 35);
    CHECK(mprt_replay_get_memory(r, m, 4, NULL, 0) == MPRT_OK);
    CHECK(m[0].stall == 24 && m[2].stall == 24 && m[2].gm_queued == 0);
    mprt_replay_destroy(r);
}

static void test_sc_data(void)
{
    /* SC's material read uncached: latency 3, 32 bytes at 32 a cycle: 4 cycles per SC visit */
    hand h = primaries(1, 1);
    mprt_replay_config c = model_s(1, 1);
    mprt_replay *r;
    mprt_replay_memory m[2];
    c.memory[0] = 0;
    c.memory[1] = 1;
    c.cache_line[1] = 32;
    c.gm_latency[1] = 3;
    c.gm_bandwidth[1] = 32;
    r = loaded(&h, &c);
    CHECK(run_cycles(r) == 1 + 10 + 1 + 4);
    CHECK(mprt_replay_get_memory(r, m, 2, NULL, 0) == MPRT_OK);
    CHECK(m[1].stall == 4 && m[1].resident_accesses == 1 && m[1].resident_hits == 0 && m[0].stall == 0);
    mprt_replay_destroy(r);
}

static void test_bad_memory_configurations_and_data(void)
{
    hand h = primaries(2, 0);
    mprt_replay_config c = model_s(1, 1);
    mprt_replay *r;
    mprt_replay_memory_data ic = ic_data(), bad = ic_data();
    int64_t neg[3] = {5, -1, 5}, start[2] = {0, 3};
    int32_t keys[MAXV];
    /* configurations: each refused with a message naming the field */
    struct {
        int field;
        const char *msg;
    } cases[] = {{0, "cache_size[0]: must be 0 (no cache) to 2^40 bytes"}, {1, "cache_line[0]: must be a power of two"},
                 {2, "cache_ways[0]: must be 1..2"}, {3, "cache_size[0]: 24 bytes is not a whole number of sets"},
                 {4, "gm_bandwidth[0]: must be >= 1"}, {5, "gm_latency[0]: must be 0..2^62"},
                 {6, "memory[1]: must be 0 or 1"}, {7, "gm_contention[0]: must be 0 or 1"}};
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        c = model_s(1, 1);
        switch (cases[i].field) {
        case 0: c.cache_size[0] = (int64_t)1 << 60; break;
        case 1: c.cache_line[0] = 12; break;
        case 2: c.cache_ways[0] = 3; break;
        case 3: c.cache_size[0] = 24; c.cache_ways[0] = 2; break;
        case 4: c.gm_bandwidth[0] = 0; break;
        case 5: c.gm_latency[0] = -1; break;
        case 6: c.memory[1] = 2; break;
        default: c.gm_contention[0] = 5; break;
        }
        CHECK(mprt_replay_create(&c, &r) == MPRT_ERR_INVALID_ARG);
        CHECK_MSG(r && strstr(mprt_replay_errmsg(r), cases[i].msg) != NULL, "%s", r ? mprt_replay_errmsg(r) : "");
        mprt_replay_destroy(r);
    }
    /* data: checked, and a modelled memory without it is not run */
    c = model_s(1, 1);
    CHECK(mprt_replay_create(&c, &r) == MPRT_OK);
    CHECK(mprt_replay_set_memory(r, h.key, h.nv, &ic, NULL) == MPRT_ERR_STATE);        /* nothing loaded */
    CHECK(mprt_replay_load(r, h.rays, h.nr, h.visits, h.nv, h.process, h.receive, h.send) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_STATE);
    CHECK(strstr(mprt_replay_errmsg(r), "the IC memory is modelled but has no data") != NULL);
    CHECK(mprt_replay_set_memory(r, h.key, h.nv - 1, &ic, NULL) == MPRT_ERR_INVALID_ARG);
    bad.lines = neg;
    CHECK(mprt_replay_set_memory(r, h.key, h.nv, &bad, NULL) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "memory data IC: line 1 is -1") != NULL);
    bad = ic_data();
    start[1] = -1;
    bad.line_start = start;
    CHECK(mprt_replay_set_memory(r, h.key, h.nv, &bad, NULL) == MPRT_ERR_INVALID_ARG);
    memcpy(keys, h.key, sizeof keys);
    keys[1] = 7;
    CHECK(mprt_replay_set_memory(r, keys, h.nv, &ic, NULL) == MPRT_ERR_INVALID_ARG);
    CHECK(strstr(mprt_replay_errmsg(r), "visit 1 reads IC key 7") != NULL);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_STATE);          /* a failed call keeps no data */
    CHECK(mprt_replay_set_memory(r, h.key, h.nv, &ic, NULL) == MPRT_OK);
    c.cache_line[0] = 16;
    c.cache_size[0] = 32;
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_INVALID_ARG);     /* data in 8-byte lines */
    c = model_s(1, 1);
    c.gm_latency[0] = (int64_t)1 << 61;
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_INVALID_ARG);     /* could overflow */
    CHECK(strstr(mprt_replay_errmsg(r), "could exceed 2^62 cycles") != NULL);
    c = model_s(1, 1);
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(run_cycles(r) == 46);
    /* a new trace drops the last one's memory data */
    CHECK(mprt_replay_load(r, h.rays, h.nr, h.visits, h.nv, h.process, h.receive, h.send) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_STATE);
    CHECK(mprt_replay_get_memory(NULL, NULL, 0, NULL, 0) == MPRT_ERR_STATE);
    mprt_replay_destroy(r);
}

static void test_caches_of_more_than_2_28_entries_are_refused(void)
{
    /* key 0 reads lines 5, 2^27 and 5: a 2^40-byte direct-mapped cache of 8-byte lines needs a
     * set per line number up to 2^27 (2^27 + 1 entries a PE): 2 PEs are refused before the run */
    hand h = primaries(2, 0);
    mprt_replay_config c = model_s(2, 1);
    mprt_replay *r;
    int64_t far[3] = {5, (int64_t)1 << 27, 5};
    mprt_replay_memory_data ic = ic_data();
    ic.lines = far;
    c.cache_size[0] = MPRT_REPLAY_MAX_CACHE;
    CHECK(mprt_replay_create(&c, &r) == MPRT_OK);
    CHECK(mprt_replay_load(r, h.rays, h.nr, h.visits, h.nv, h.process, h.receive, h.send) == MPRT_OK);
    CHECK(mprt_replay_set_memory(r, h.key, h.nv, &ic, NULL) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_INVALID_ARG);
    CHECK_MSG(strstr(mprt_replay_errmsg(r), "cache_size[0]: the IC caches would hold 2 PEs x 134217729 entries per "
                                            "PE (sets x ways the data can fill), more than 2^28 in all") != NULL,
              "%s", mprt_replay_errmsg(r));
    /* the same cache on data of lines 5 and 6 is 7 entries a PE: it runs */
    CHECK(mprt_replay_set_memory(r, h.key, h.nv, &(mprt_replay_memory_data){1, 8, IC_ITEMS, IC_RES, IC_START,
                                                                           IC_LINES}, NULL) == MPRT_OK);
    CHECK(run_cycles(r) > 0);
    mprt_replay_destroy(r);
}

int main(void)
{
    RUN(test_caches_of_more_than_2_28_entries_are_refused);
    RUN(test_misses_hits_and_stalls);
    RUN(test_ports_shared_or_per_pe);
    RUN(test_work_bound_with_memories);
    RUN(test_sc_data);
    RUN(test_bad_memory_configurations_and_data);
    return CHECK_DONE();
}
