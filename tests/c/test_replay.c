/* test_replay.c: the compiled replay (mprt_replay_*) on hand-built traces
 * whose timings are worked out here by hand (the same cases as the SimPy
 * model's tests/test_machine.py), its deadlock report, and its checks of
 * configurations and traces. */
#include "check.h"
#include "mprt.h"
#include "replay_hand.h"

#include <string.h>

/* A visit with no packet size (the ideal network does not read it). */
static void visit(hand *h, int64_t r, int stage, int made, int64_t cycles)
{
    visit_flits(h, r, stage, made, cycles, 0);
}

static mprt_replay_config model_m(void)
{
    mprt_replay_config c;
    mprt_replay_config_init(&c);
    return c;
}

static mprt_replay_config model_s(void)
{
    mprt_replay_config c;
    mprt_replay_config_init(&c);
    c.nstages = 1;
    c.stage_of[0] = c.stage_of[1] = c.stage_of[2] = 0;
    return c;
}

/* A replay made for c with the hand-built trace loaded. */
static mprt_replay *loaded(const hand *h, const mprt_replay_config *c)
{
    mprt_replay *r = NULL;
    CHECK(mprt_replay_create(c, &r) == MPRT_OK);
    CHECK(mprt_replay_load(r, h->rays, h->nr, h->visits, h->nv, h->process, h->receive, h->send) == MPRT_OK);
    return r;
}

/* Cycles of a run (-1: the run failed). */
static int64_t cycles(const hand *h, const mprt_replay_config *c, int64_t *log, size_t cap)
{
    mprt_replay *r;
    mprt_replay_info info;
    int64_t out = -1;
    if (mprt_replay_create(c, &r) != MPRT_OK) return -1;
    if (mprt_replay_load(r, h->rays, h->nr, h->visits, h->nv, h->process, h->receive, h->send) == MPRT_OK &&
        mprt_replay_run(r, log, cap) == MPRT_OK && mprt_replay_get_info(r, &info) == MPRT_OK)
        out = info.cycles;
    mprt_replay_destroy(r);
    return out;
}

static void test_one_ray(void)
{
    /* one OS visit of 10 + 2 cycles: 12 on M and on S */
    hand h = {0};
    mprt_replay_config m = model_m(), s = model_s();
    int64_t log[8 * 2];
    ray(&h, -1, MPRT_RAY_PRIMARY);
    visit(&h, 0, MPRT_STAGE_OS, 0, 10);
    h.receive[0] = 2;
    CHECK(cycles(&h, &m, log, 16) == 12);
    /* start at 0 on processor 0 (OS), end at 12 */
    CHECK(log[0] == 0 && log[1] == 0 && log[2] == 0 && log[3] == 0);
    CHECK(log[4] == 12 && log[5] == 1 && log[6] == 0 && log[7] == 0);
    CHECK(cycles(&h, &s, NULL, 0) == 12);
}

static void test_a_ray_with_a_return(void)
{
    /* OS 8 -> IC 25 (return) -> OS 7 -> IC 36 -> SC 53, back to back: 129 cycles */
    hand h = {0};
    mprt_replay_config m = model_m(), s = model_s();
    ray(&h, -1, MPRT_RAY_PRIMARY);
    visit(&h, 0, MPRT_STAGE_OS, 0, 8);
    visit(&h, 0, MPRT_STAGE_IC, 0, 25);
    visit(&h, 0, MPRT_STAGE_OS, 0, 7);
    visit(&h, 0, MPRT_STAGE_IC, 0, 36);
    visit(&h, 0, MPRT_STAGE_SC, 0, 53);
    CHECK(cycles(&h, &m, NULL, 0) == 129);
    CHECK(cycles(&h, &s, NULL, 0) == 129);
}

/* The primary (OS 10, IC 20, SC 30 making 2 rays), its shadow ray (OS 5, SC 4)
 * and its reflection (OS 6, IC 8, OS 3). */
static hand parent_and_children(void)
{
    hand h = {0};
    ray(&h, -1, MPRT_RAY_PRIMARY);
    ray(&h, 0, MPRT_RAY_SHADOW);
    ray(&h, 0, MPRT_RAY_REFLECT);
    visit(&h, 0, MPRT_STAGE_OS, 0, 10);
    visit(&h, 0, MPRT_STAGE_IC, 0, 20);
    visit(&h, 0, MPRT_STAGE_SC, 2, 30);
    visit(&h, 1, MPRT_STAGE_OS, 0, 5);
    visit(&h, 1, MPRT_STAGE_SC, 0, 4);
    visit(&h, 2, MPRT_STAGE_OS, 0, 6);
    visit(&h, 2, MPRT_STAGE_IC, 0, 8);
    visit(&h, 2, MPRT_STAGE_OS, 0, 3);
    return h;
}

static void test_parent_and_children(void)
{
    /* M: 0-10 OS, 10-30 IC, 30-60 SC; at 60 SC sends ray 1 (to the idle OS: 60-65)
     * then ray 2 (OS's receive FIFO).  65: OS hands ray 1 to the idle SC (65-69)
     * and takes ray 2 (65-71); 71-79 IC; 79-82 OS.  S: the sum, 86. */
    static const int64_t starts[8][2] = {{0, 0}, {10, 1}, {30, 2}, {60, 3}, {65, 4}, {65, 5}, {71, 6}, {79, 7}};
    hand h = parent_and_children();
    mprt_replay_config m = model_m(), s = model_s();
    int64_t log[8 * 11];
    int i, k = 0;
    CHECK(cycles(&h, &m, log, 88) == 82);
    for (i = 0; i < 16; i++) {
        const int64_t *e = log + 4 * i;
        if (e[1] != 0) continue;
        CHECK_MSG(k < 8 && e[0] == starts[k][0] && e[3] == starts[k][1], "start %d: cycle %lld visit %lld", k,
                  (long long)e[0], (long long)e[3]);
        k++;
    }
    CHECK(k == 8);
    CHECK(cycles(&h, &s, NULL, 0) == 86);
}

static void test_long_visits(void)
{
    /* a visit of 2^25 cycles does not fit the packed 8-byte records: the 16-byte ones give
     * the same machine (the last OS visit, at 79 on M and at 83 on S, now that long) */
    hand h = parent_and_children();
    mprt_replay_config m = model_m(), s = model_s();
    h.process[7] = (int64_t)1 << 25;
    CHECK(cycles(&h, &m, NULL, 0) == 79 + ((int64_t)1 << 25));
    CHECK(cycles(&h, &s, NULL, 0) == 83 + ((int64_t)1 << 25));
}

static void test_replicas_share_the_work(void)
{
    /* four primaries of 10 cycles on one stage of two processors: 20 cycles */
    hand h = {0};
    mprt_replay_config s = model_s();
    int i;
    for (i = 0; i < 4; i++) {
        ray(&h, -1, MPRT_RAY_PRIMARY);
        visit(&h, i, MPRT_STAGE_OS, 0, 10);
    }
    CHECK(cycles(&h, &s, NULL, 0) == 40);
    s.replicas[0] = 2;
    CHECK(cycles(&h, &s, NULL, 0) == 20);
    s.pes = 2;               /* two PEs: the dynamic DIS of the first admits all four at once */
    CHECK(cycles(&h, &s, NULL, 0) == 20);
    s.dis = MPRT_DIS_INTERLEAVED; /* two each: all four at once */
    CHECK(cycles(&h, &s, NULL, 0) == 10);
    s.window = 1;            /* one at a time per PE */
    CHECK(cycles(&h, &s, NULL, 0) == 20);
}

static void test_feeds_per_replica(void)
{
    /* four primaries of 30, 10, 10, 10 cycles on one stage of two processors, all admitted
     * at 0.  Shared: the second processor runs 10, 10, 10 while the first runs 30: 30 cycles.
     * Round-robin: the third goes to the first processor (after its 30), the fourth to the
     * second: 40.  Shortest queue: the third finds one each (a tie, the first), the fourth
     * two against one (the second): 40 too. */
    hand h = {0};
    mprt_replay_config s = model_s();
    int i;
    for (i = 0; i < 4; i++) {
        ray(&h, -1, MPRT_RAY_PRIMARY);
        visit(&h, i, MPRT_STAGE_OS, 0, i ? 10 : 30);
    }
    s.replicas[0] = 2;
    CHECK(cycles(&h, &s, NULL, 0) == 30);
    s.feed[0] = 1;
    CHECK(cycles(&h, &s, NULL, 0) == 40);
    s.feed[0] = 2;
    CHECK(cycles(&h, &s, NULL, 0) == 40);
    s.replicas[0] = 1;       /* one processor: every feed is the shared FIFO */
    CHECK(cycles(&h, &s, NULL, 0) == 60);
}

static void test_sc_makes_the_primaries(void)
{
    /* making a primary costs SC 4 cycles, then OS runs it 12: 16 */
    hand h = {0};
    mprt_replay_config m = model_m();
    mprt_replay *r;
    mprt_replay_node nodes[3];
    ray(&h, -1, MPRT_RAY_PRIMARY);
    visit(&h, 0, MPRT_STAGE_OS, 0, 12);
    m.gen_cycles = 4;
    CHECK(cycles(&h, &m, NULL, 0) == 16);
    r = loaded(&h, &m);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK);
    CHECK(mprt_replay_get_nodes(r, nodes, 3) == MPRT_OK);
    CHECK(nodes[2].generated == 1 && nodes[0].generated == 0);
    mprt_replay_destroy(r);
}

/* The work bound of the configuration set (-1: the call failed). */
static int64_t bound(mprt_replay *r, const mprt_replay_config *c)
{
    int64_t b = -1;
    if (mprt_replay_set_config(r, c) != MPRT_OK || mprt_replay_work_bound(r, &b) != MPRT_OK) return -1;
    return b;
}

static void test_work_bound(void)
{
    /* four primaries: OS 10, 30, 10, 10 cycles (the second with a receive of 2), the third
     * with an IC visit of 7 and an SC visit of 5 */
    hand h = {0};
    mprt_replay_config s = model_s(), m = model_m();
    mprt_replay *r;
    int64_t b = 0;
    int i;
    for (i = 0; i < 4; i++) {
        ray(&h, -1, MPRT_RAY_PRIMARY);
        visit(&h, i, MPRT_STAGE_OS, 0, i == 1 ? 30 : 10);
        if (i == 2) {
            visit(&h, i, MPRT_STAGE_IC, 0, 7);
            visit(&h, i, MPRT_STAGE_SC, 0, 5);
        }
    }
    h.receive[1] = 2;
    CHECK(mprt_replay_create(&s, &r) == MPRT_OK);
    CHECK(mprt_replay_work_bound(r, &b) == MPRT_ERR_STATE && strstr(mprt_replay_errmsg(r), "no trace loaded"));
    CHECK(mprt_replay_load(r, h.rays, h.nr, h.visits, h.nv, h.process, h.receive, h.send) == MPRT_OK);
    CHECK(bound(r, &s) == 74 && cycles(&h, &s, NULL, 0) == 74);   /* S never waits: its work */
    CHECK(bound(r, &m) == 62);              /* OS: 10 + 32 + 10 + 10 */
    s.replicas[0] = 4;                      /* 74 over four, rounded up */
    CHECK(bound(r, &s) == 19);
    s.replicas[0] = 1;
    s.pes = 2;                              /* blocks: 42 and 32 */
    s.dis = MPRT_DIS_BLOCKS;
    CHECK(bound(r, &s) == 42);
    s.dis = MPRT_DIS_INTERLEAVED;           /* trees 0, 2: 32; trees 1, 3: 42 */
    CHECK(bound(r, &s) == 42);
    s.dis = MPRT_DIS_DYNAMIC;               /* 74 over both PEs */
    CHECK(bound(r, &s) == 37);
    m.gen_cycles = 20;                      /* SC makes the four primaries: 5 + 80 */
    CHECK(bound(r, &m) == 85 && cycles(&h, &m, NULL, 0) >= 85);
    m.pes = 5;                              /* more PEs than primaries (one idles): a bound all the same */
    CHECK(bound(r, &m) > 0 && bound(r, &m) <= cycles(&h, &m, NULL, 0));
    CHECK(mprt_replay_work_bound(r, NULL) == MPRT_ERR_INVALID_ARG);
    CHECK(mprt_replay_work_bound(NULL, &b) == MPRT_ERR_INVALID_ARG);
    mprt_replay_destroy(r);
}

static void test_work_bound_window(void)
{
    /* four primaries, each OS 10, IC 7, SC 5 making a reflection (OS 4, IC 6): chains of 32
     * cycles.  On model M with window 1 the trees run one after another, 4 x 32, where the
     * stages' work alone bounds at OS's 4 x 14 */
    hand h = {0};
    mprt_replay_config m = model_m();
    mprt_replay *r;
    int i;
    for (i = 0; i < 4; i++) {
        int64_t p = (int64_t)h.nr;
        ray(&h, -1, MPRT_RAY_PRIMARY);
        ray(&h, p, MPRT_RAY_REFLECT);
        visit(&h, p, MPRT_STAGE_OS, 0, 10);
        visit(&h, p, MPRT_STAGE_IC, 0, 7);
        visit(&h, p, MPRT_STAGE_SC, 1, 5);
        visit(&h, p + 1, MPRT_STAGE_OS, 0, 4);
        visit(&h, p + 1, MPRT_STAGE_IC, 0, 6);
    }
    r = loaded(&h, &m);
    m.window = 1;
    CHECK(bound(r, &m) == 128 && cycles(&h, &m, NULL, 0) == 128);
    m.window = 3;                           /* three trees at a time: 43, below OS's 56 */
    CHECK(bound(r, &m) == 56 && cycles(&h, &m, NULL, 0) >= 56);
    m.window = 1;
    m.pes = 2;                              /* dynamic DIS: 128 over both PEs */
    CHECK(bound(r, &m) == 64 && cycles(&h, &m, NULL, 0) == 64);
    m.dis = MPRT_DIS_BLOCKS;                /* each PE its two trees */
    CHECK(bound(r, &m) == 64 && cycles(&h, &m, NULL, 0) == 64);
    m.dis = MPRT_DIS_DYNAMIC;
    m.gen_cycles = 3;                       /* SC makes each primary first: 4 x 35 over both */
    CHECK(bound(r, &m) == 70 && cycles(&h, &m, NULL, 0) == 70);
    mprt_replay_destroy(r);
}

static void test_work_bound_counts_a_ray_from_os(void)
{
    /* a ray begins on OS whatever its first record says (as in the SimPy model): tree 0's
     * reflection, recorded on IC, runs on OS beside tree 1's IC visit.  Window 2 on model M:
     * OS 0-1 (tree 0), 1-2 (tree 1), SC 1-2, then IC and the reflection's OS 2-12, SC 12-13.
     * The bound counts 12 on OS, not 20 on IC */
    hand h = {0};
    mprt_replay_config m = model_m();
    mprt_replay *r;
    ray(&h, -1, MPRT_RAY_PRIMARY);
    ray(&h, 0, MPRT_RAY_REFLECT);
    ray(&h, -1, MPRT_RAY_PRIMARY);
    visit(&h, 0, MPRT_STAGE_OS, 0, 1);
    visit(&h, 0, MPRT_STAGE_SC, 1, 1);
    visit(&h, 1, MPRT_STAGE_IC, 0, 10);
    visit(&h, 2, MPRT_STAGE_OS, 0, 1);
    visit(&h, 2, MPRT_STAGE_IC, 0, 10);
    visit(&h, 2, MPRT_STAGE_SC, 0, 1);
    m.window = 2;
    r = loaded(&h, &m);
    CHECK(bound(r, &m) == 12 && cycles(&h, &m, NULL, 0) == 13);
    mprt_replay_destroy(r);
}

static void test_busy_record(void)
{
    /* four primaries of 10 cycles on one processor, window 2: trees 0 and 1 at cycle 0
     * (busy 0), tree 2 when tree 0 retires (10, busy 10), tree 3 at 20 (busy 20) */
    hand h = {0};
    mprt_replay_config s = model_s();
    mprt_replay *r;
    int64_t busy[4], when[4];
    int i;
    for (i = 0; i < 4; i++) {
        ray(&h, -1, MPRT_RAY_PRIMARY);
        visit(&h, i, MPRT_STAGE_OS, 0, 10);
    }
    s.window = 2;
    r = loaded(&h, &s);
    CHECK(mprt_replay_get_tree_busy(r, busy, 4) == MPRT_ERR_STATE);     /* nothing run */
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK);
    CHECK(mprt_replay_get_tree_busy(r, busy, 4) == MPRT_OK);             /* not recorded: -1 */
    CHECK(busy[0] == -1 && busy[3] == -1);
    CHECK(mprt_replay_record_busy(r, 1) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK);
    CHECK(mprt_replay_get_tree_busy(r, busy, 3) == MPRT_ERR_CAPACITY);
    CHECK(mprt_replay_get_tree_busy(r, busy, 4) == MPRT_OK);
    CHECK(mprt_replay_get_trees(r, NULL, when, 4) == MPRT_OK);
    CHECK(when[0] == 0 && when[1] == 0 && when[2] == 10 && when[3] == 20);
    CHECK(busy[0] == 0 && busy[1] == 0 && busy[2] == 10 && busy[3] == 20);
    CHECK(mprt_replay_record_busy(NULL, 1) == MPRT_ERR_INVALID_ARG);
    mprt_replay_destroy(r);
}

static void test_deadlock(void)
{
    /* eight primaries OS -> IC -> OS of 1 cycle; OS: receive 3, send 1; IC: 1 and 1.
     * Window 8 fills both stages' FIFOs (3 + 1 + 1 + 1 + 1 + 1 = 8 rays); 7 cannot:
     * then OS, never idle, takes its 16 cycles. */
    hand h = {0};
    mprt_replay_config c = model_m();
    mprt_replay *r;
    mprt_replay_info info;
    mprt_replay_proc procs[3];
    int i;
    for (i = 0; i < 8; i++) {
        ray(&h, -1, MPRT_RAY_PRIMARY);
        visit(&h, i, MPRT_STAGE_OS, 0, 1);
        visit(&h, i, MPRT_STAGE_IC, 0, 1);
        visit(&h, i, MPRT_STAGE_OS, 0, 1);
    }
    c.receive_fifo[0] = 3;
    c.send_fifo[0] = 1;
    c.receive_fifo[1] = 1;
    c.send_fifo[1] = 1;
    c.window = 8;
    r = loaded(&h, &c);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_STATE);
    CHECK(strstr(mprt_replay_errmsg(r), "deadlock: the machine stopped with 8 of 8 rays") != NULL);
    CHECK(mprt_replay_get_info(r, &info) == MPRT_OK);
    CHECK(info.deadlocked == 1 && info.cycles == -1 && info.retired == 0);
    CHECK(mprt_replay_get_procs(r, procs, 3) == MPRT_OK);
    CHECK(procs[0].state == MPRT_PROC_BLOCKED && procs[0].pending == 1);
    c.window = 7;
    CHECK(mprt_replay_set_config(r, &c) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK);        /* the same load, another machine */
    CHECK(mprt_replay_get_info(r, &info) == MPRT_OK && info.cycles == 16);
    mprt_replay_destroy(r);
}

static void test_bad_configurations(void)
{
    mprt_replay_config c;
    mprt_replay *r;
    struct {
        int field;
        const char *msg;
    } cases[] = {{0, "nstages: must be 1, 2 or 3, not 0"}, {1, "stage_of[1]: the stage running IC must be 0..2"},
                 {2, "replicas[2]: must be"}, {3, "receive_fifo[0]: must be >= 0"}, {4, "pes: must be"},
                 {5, "dis: must be"}, {6, "window: must be >= 1"}, {7, "gen_cycles: must be >= 0"},
                 {8, "stage_of: stage 2 runs no subtask"}, {9, "feed[1]: must be shared (0), round-robin (1)"}};
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        mprt_replay_config_init(&c);
        switch (cases[i].field) {
        case 0: c.nstages = 0; break;
        case 1: c.stage_of[1] = 5; break;
        case 2: c.replicas[2] = 0; break;
        case 3: c.receive_fifo[0] = -1; break;
        case 4: c.pes = 0; break;
        case 5: c.dis = 7; break;
        case 6: c.window = 0; break;
        case 7: c.gen_cycles = -3; break;
        case 9: c.feed[1] = 3; break;
        default: c.stage_of[2] = 1; break;
        }
        CHECK(mprt_replay_create(&c, &r) == MPRT_ERR_INVALID_ARG);
        CHECK_MSG(r && strstr(mprt_replay_errmsg(r), cases[i].msg) != NULL, "%s", r ? mprt_replay_errmsg(r) : "");
        mprt_replay_destroy(r);
    }
}

/* Load h on M; the error message (or "" when it loads). */
static const char *load_error(const hand *h, mprt_replay **r)
{
    mprt_replay_config c = model_m();
    mprt_replay_create(&c, r);
    mprt_replay_load(*r, h->rays, h->nr, h->visits, h->nv, h->process, h->receive, h->send);
    return mprt_replay_errmsg(*r);
}

static void test_bad_traces(void)
{
    hand h;
    mprt_replay *r;
    int i;
    for (i = 0; i < 6; i++) {
        h = parent_and_children();
        switch (i) {
        case 0: h.rays[1].id = 7; break;                 /* ids out of order */
        case 1: h.rays[0].kind = MPRT_RAY_SHADOW; break; /* no primary first */
        case 2: h.rays[1].parent = 2; break;             /* parent after child */
        case 3: h.visits[3].ray = 9; break;              /* no such ray */
        case 4: h.process[4] = 0; break;                 /* a visit of no cycles */
        default: h.visits[2].made = 1; break;            /* SC made 2 rays, says 1 */
        }
        {
            static const char *msgs[] = {"ray ids are not 0..n-1 in order", "the first ray is not a primary ray",
                                         "ray 1 is not stored after its parent", "a visit names a ray that does not exist",
                                         "visit 4: costs must be >= 0 and a visit must last at least 1 cycle",
                                         "visit 2 made 1 rays but 2 have it as parent"};
            const char *m = load_error(&h, &r);
            CHECK_MSG(strstr(m, msgs[i]) != NULL, "case %d: %s", i, m);
            CHECK(mprt_replay_run(r, NULL, 0) == MPRT_ERR_STATE);  /* nothing loaded */
            mprt_replay_destroy(r);
        }
    }
}

/* More PEs than primary rays: the PEs without a tree stay idle, under every DIS. */
static void test_idle_pes(void)
{
    static const int dis[] = {MPRT_DIS_DYNAMIC, MPRT_DIS_BLOCKS, MPRT_DIS_INTERLEAVED};
    hand h = parent_and_children();
    mprt_replay_config c = model_m();
    mprt_replay *r;
    mprt_replay_info one, many;
    mprt_replay_pe pe[3];
    int d, p;
    r = loaded(&h, &c);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK && mprt_replay_get_info(r, &one) == MPRT_OK);
    mprt_replay_destroy(r);
    for (d = 0; d < 3; d++) {
        int busy = 0;
        c = model_m();
        c.pes = 3;
        c.dis = dis[d];
        r = loaded(&h, &c);
        CHECK_MSG(mprt_replay_run(r, NULL, 0) == MPRT_OK, "dis %d: %s", dis[d], mprt_replay_errmsg(r));
        CHECK(mprt_replay_get_info(r, &many) == MPRT_OK && many.cycles == one.cycles);
        CHECK(mprt_replay_get_pes(r, pe, 3) == MPRT_OK);
        for (p = 0; p < 3; p++) {
            if (pe[p].admitted) {
                busy++;
                CHECK(pe[p].admitted == 1 && pe[p].retired == 3 && pe[p].end == one.cycles);
            } else {
                CHECK(pe[p].retired == 0 && pe[p].end == 0 && pe[p].max_live == 0 && pe[p].visits[0] == 0);
            }
        }
        CHECK_MSG(busy == 1, "dis %d: %d PEs ran the one tree", dis[d], busy);
        mprt_replay_destroy(r);
    }
}

static void test_runs_repeat_exactly(void)
{
    hand h = parent_and_children();
    mprt_replay_config c = model_m();
    mprt_replay *r;
    mprt_replay_pe a, b;
    r = loaded(&h, &c);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK && mprt_replay_get_pes(r, &a, 1) == MPRT_OK);
    CHECK(mprt_replay_run(r, NULL, 0) == MPRT_OK && mprt_replay_get_pes(r, &b, 1) == MPRT_OK);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
    /* the PE's costs are the trace's: OS 10 + 5 + 6 + 3, IC 20 + 8, SC 30 + 4 */
    CHECK(a.processing[0] == 24 && a.processing[1] == 28 && a.processing[2] == 34);
    CHECK(a.visits[0] == 4 && a.visits[1] == 2 && a.visits[2] == 2 && a.retired == 3);
    CHECK(mprt_replay_get_pes(r, &a, 0) == MPRT_ERR_CAPACITY);
    mprt_replay_destroy(r);
}

int main(void)
{
    RUN(test_one_ray);
    RUN(test_a_ray_with_a_return);
    RUN(test_parent_and_children);
    RUN(test_long_visits);
    RUN(test_replicas_share_the_work);
    RUN(test_feeds_per_replica);
    RUN(test_sc_makes_the_primaries);
    RUN(test_deadlock);
    RUN(test_bad_configurations);
    RUN(test_bad_traces);
    RUN(test_idle_pes);
    RUN(test_runs_repeat_exactly);
    RUN(test_busy_record);
    RUN(test_work_bound);
    RUN(test_work_bound_window);
    RUN(test_work_bound_counts_a_ray_from_os);
    return CHECK_DONE();
}
