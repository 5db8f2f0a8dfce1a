/* fuzz_machine.c: the fuzz target over the compiled replay (mprt_replay_*):
 * a machine configuration, a trace of ray trees and per-visit costs, all made
 * from the input bytes, loaded and replayed.
 *
 * The trace is built to be well formed (trees of rays whose visits go OS, IC,
 * ..., SC, SC visits making the children), then, when the input asks for it,
 * damaged: a record's ray, stage, kind, parent or made count overwritten with
 * an input byte, a cost made negative or huge, the arrays cut short, or
 * records (rays or visits, with their costs) overwritten or appended as the
 * input's raw bytes, so that the loader meets arbitrary arrays.  The
 * configuration takes every field from the input, in and out of range.  Bytes
 * after those (none in older inputs: then level 1) may add the ring (buffer
 * classes, flit time, packet sizes) and the memories (caches, lines, ways,
 * latency, bandwidth, ports, and per-key data of a few lines), so levels 2
 * and 3 and both together are fuzzed too.
 *
 * Besides crashes, hangs and sanitizer reports, it aborts when
 *   - a call fails without a message, or a well-formed trace is refused;
 *   - a finished run has not retired every ray, or its cycles are below the
 *     longest visit or (one stage, one processor, one PE, no memories) differ
 *     from the sum of all visits' cycles (model S never waits);
 *   - a second run of the same configuration gives other cycles (determinism),
 *     or a deadlock is reported by one run and not the other;
 *   - the work bound (mprt_replay_work_bound) is above a finished run's cycles,
 *     or (one stage, one processor, one PE, no memories) differs from them.
 *
 * Built like fuzz_nff.c: with clang and libFuzzer (make fuzz), and with gcc and
 * the sanitizers as a replay of tests/fuzz/corpus_machine in make test. */
#include "mprt.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FAIL(...)                                                                                  \
    do {                                                                                           \
        fprintf(stderr, "fuzz_machine: ");                                                         \
        fprintf(stderr, __VA_ARGS__);                                                              \
        fputc('\n', stderr);                                                                       \
        abort();                                                                                   \
    } while (0)

enum { MAX_RAYS = 96, MAX_VISITS = 512, MAX_KIDS = 3, MAX_DEPTH = 3 };

typedef struct {
    const uint8_t *p;
    size_t n, i;
} bytes;

static unsigned next(bytes *b)
{
    return b->i < b->n ? b->p[b->i++] : 0u;
}

typedef struct {
    mprt_trace_ray rays[MAX_RAYS];
    mprt_trace_visit visits[MAX_VISITS];
    int64_t process[MAX_VISITS], receive[MAX_VISITS], send[MAX_VISITS];
    size_t nr, nv;
    int depth[MAX_RAYS];
} trace;

static int add_visit(trace *t, int64_t ray, int stage, int made, bytes *b)
{
    mprt_trace_visit *v;
    if (t->nv == MAX_VISITS) return -1;
    v = &t->visits[t->nv];
    memset(v, 0, sizeof *v);
    v->ray = ray;
    v->stage = (uint8_t)stage;
    v->made = (uint8_t)made;
    v->prim = -1;
    v->voxel_id = -1;
    t->process[t->nv] = 1 + (int64_t)(next(b) % 24);   /* a visit lasts at least a cycle */
    t->receive[t->nv] = (int64_t)(next(b) % 4);
    t->send[t->nv] = (int64_t)(next(b) % 4);
    t->nv++;
    return 0;
}

/* Rays of one tree, breadth first (a parent's id below its children's), each
 * ray's visits together: (OS, IC) pairs, then SC making its children, or a last
 * OS (the ray left).  Returns -1 when the arrays are full (add_tree then takes
 * the partial tree back: rays without visits would make the trace ill formed). */
static int add_tree_records(trace *t, bytes *b)
{
    size_t first = t->nr, r;
    if (t->nr == MAX_RAYS) return -1;
    memset(&t->rays[t->nr], 0, sizeof t->rays[0]);
    t->rays[t->nr].id = (int64_t)t->nr;
    t->rays[t->nr].parent = -1;
    t->rays[t->nr].kind = MPRT_RAY_PRIMARY;
    t->depth[t->nr] = 1;
    t->nr++;
    for (r = first; r < t->nr; r++) {
        unsigned pairs = next(b) % 4, k, kids = 0;
        int shaded = (next(b) & 3) != 0;
        for (k = 0; k < pairs; k++)
            if (add_visit(t, (int64_t)r, MPRT_STAGE_OS, 0, b) || add_visit(t, (int64_t)r, MPRT_STAGE_IC, 0, b))
                return -1;
        if (!shaded) {
            if (add_visit(t, (int64_t)r, MPRT_STAGE_OS, 0, b)) return -1;
            continue;
        }
        if (t->depth[r] < MAX_DEPTH) kids = next(b) % (MAX_KIDS + 1);
        if (t->nr + kids > MAX_RAYS) kids = 0;
        if (pairs == 0 && add_visit(t, (int64_t)r, MPRT_STAGE_OS, 0, b)) return -1;
        if (add_visit(t, (int64_t)r, MPRT_STAGE_SC, (int)kids, b)) return -1;
        for (k = 0; k < kids; k++) {
            mprt_trace_ray *c = &t->rays[t->nr];
            memset(c, 0, sizeof *c);
            c->id = (int64_t)t->nr;
            c->parent = (int64_t)r;
            c->kind = (uint8_t)(1 + next(b) % 3);
            t->depth[t->nr] = t->depth[r] + 1;
            t->nr++;
        }
    }
    return 0;
}

static int add_tree(trace *t, bytes *b)
{
    size_t nr = t->nr, nv = t->nv;
    if (add_tree_records(t, b) == 0) return 0;
    t->nr = nr;
    t->nv = nv;
    return -1;
}

static void config(mprt_replay_config *c, bytes *b)
{
    int k;
    mprt_replay_config_init(c);
    c->nstages = 1 + (int)(next(b) % 3);
    for (k = 0; k < 3; k++) c->stage_of[k] = (int)(next(b) % (unsigned)c->nstages);
    c->stage_of[0] = 0;                               /* some stage runs each subtask: the usual case */
    if (c->nstages == 3) c->stage_of[1] = 1, c->stage_of[2] = 2;
    for (k = 0; k < 3; k++) {
        c->replicas[k] = 1 + (int)(next(b) % 3);
        c->receive_fifo[k] = (int64_t)(next(b) % 6);  /* 0: unbounded */
        c->send_fifo[k] = (int64_t)(next(b) % 6);
        c->feed[k] = (int)(next(b) % 3);
    }
    c->pes = 1 + (int)(next(b) % 3);
    c->dis = (int)(next(b) % 3);
    c->window = 1 + (int64_t)(next(b) % 12);
    c->gen_cycles = (int64_t)(next(b) % 4);
    if (next(b) == 0xff) {                            /* out of range, now and then */
        unsigned w = next(b) % 6;
        if (w == 0) c->nstages = (int)next(b) - 128;
        if (w == 1) c->replicas[0] = -(int)next(b);
        if (w == 2) c->pes = 0;
        if (w == 3) c->window = -1;
        if (w == 4) c->dis = 7;
        if (w == 5) c->feed[1] = 9;
    }
}

/* The memory data of levels 3 from the input: 3 keys of 0 to 3 lines each, line numbers up
 * to 63 (or far, now and then), items and resident items; visits read key (byte % 4) - 1. */
typedef struct {
    int32_t key[MAX_VISITS], items[3], res[3];
    int64_t start[4], lines[9];
} memdata;

static void levels_2_and_3(mprt_replay_config *c, const trace *t, size_t nv, bytes *b, mprt_replay *r,
                           memdata *m, int64_t *flits)
{
    unsigned what = next(b), k, i;
    int64_t kid[4];
    mprt_replay_memory_data d;
    if (what & 1) {                                   /* the ring */
        c->ring = c->nstages >= 2 || next(b) == 0xff;
        c->buffer_classes = 1 + (int)(next(b) % (unsigned)(c->nstages > 0 && c->nstages < 4 ? c->nstages : 1));
        c->flit_time = 1 + (int64_t)(next(b) % 3);
        for (i = 0; i < nv; i++) flits[i] = (int64_t)(next(b) % 6);
        for (k = 0; k < 4; k++) kid[k] = (int64_t)(next(b) % 4);
        if (mprt_replay_set_flits(r, flits, nv, kid, 4, (int64_t)(next(b) % 3)) != MPRT_OK &&
            !mprt_replay_errmsg(r)[0])
            FAIL("set_flits failed without a message");
    }
    if (what & 6) {                                   /* the memories: IC (2), SC (4) */
        m->start[0] = 0;
        for (k = 0; k < 3; k++) {
            unsigned n = next(b) % 4;
            m->items[k] = (int32_t)(next(b) % 5);
            m->res[k] = (int32_t)(next(b) % 3);
            if (m->res[k] > m->items[k] && next(b) != 0xfc) m->res[k] = m->items[k];   /* else: refused */
            m->start[k + 1] = m->start[k] + n;
            for (i = 0; i < n; i++)
                m->lines[m->start[k] + i] = next(b) == 0xfe ? (int64_t)1 << 30 : (int64_t)(next(b) % 64);
        }
        for (i = 0; i < nv; i++) {
            unsigned x = next(b) % 5;
            m->key[i] = x == 0 ? -1 : x <= 2 ? (int32_t)(x - 1) : -(int32_t)(x - 1);   /* -2, -3: SC keys */
        }
        for (k = 0; k < 2; k++) {
            if (!(what & (2u << k))) continue;
            c->memory[k] = 1;
            c->cache_line[k] = (int64_t)1 << (next(b) % 4);
            c->cache_ways[k] = 1 + (int64_t)(next(b) % 3);
            c->cache_size[k] = c->cache_line[k] * c->cache_ways[k] * (int64_t)(next(b) % 5);   /* 0: none */
            if (next(b) == 0xfd) c->cache_size[k] = MPRT_REPLAY_MAX_CACHE;                       /* huge */
            c->gm_latency[k] = (int64_t)(next(b) % 9);
            c->gm_bandwidth[k] = 1 + (int64_t)(next(b) % 8);
            c->gm_contention[k] = (int)(next(b) & 1);
        }
        d.nkeys = 3;
        d.line = c->cache_line[0] ? c->cache_line[0] : 1;
        d.items = m->items;
        d.resident = m->res;
        d.line_start = m->start;
        d.lines = m->lines;
        {
            mprt_replay_memory_data e = d;
            e.line = c->cache_line[1] ? c->cache_line[1] : 1;
            if (mprt_replay_set_memory(r, m->key, nv, (what & 2) ? &d : NULL, (what & 4) ? &e : NULL) != MPRT_OK) {
                if (!mprt_replay_errmsg(r)[0]) FAIL("set_memory failed without a message");
#ifdef FUZZ_STATS
                fprintf(stderr, "set_memory: %s\n", mprt_replay_errmsg(r));
#endif
            }
        }
    }
    (void)t;
    if (mprt_replay_set_config(r, c) != MPRT_OK && !mprt_replay_errmsg(r)[0]) FAIL("set_config failed without a message");
}

/* Damage one record or cost (returns 1 when something was damaged). */
static int damage(trace *t, bytes *b)
{
    unsigned what = next(b) % 8;
    size_t i;
    if (t->nv == 0 || t->nr == 0) return 0;
    i = next(b) % t->nv;
    switch (what) {
    case 0: t->visits[i].ray = (int64_t)next(b) - 8; return 1;
    case 1: t->visits[i].stage = (uint8_t)next(b); return 1;
    case 2: t->visits[i].made = (uint8_t)next(b); return 1;
    case 3: t->rays[i % t->nr].parent = (int64_t)next(b) - 2; return 1;
    case 4: t->rays[i % t->nr].kind = (uint8_t)next(b); return 1;
    case 5: t->process[i] = -(int64_t)next(b) - 1; return 1;
    case 6: t->process[i] = INT64_MAX / (1 + (int64_t)next(b)); return 1;
    default: t->rays[i % t->nr].id = (int64_t)next(b); return 1;
    }
}

/* Records as the input's raw bytes (the loader must refuse whatever it cannot index): a run
 * of 1 to 32 rays or visits from a record number on, overwritten or appended (up to the
 * arrays' capacity); visits' costs raw 64-bit values too, now and then.  Returns 1. */
static int raw_records(trace *t, bytes *b)
{
    unsigned what = next(b), k;
    int visits = (int)(what & 1);
    size_t count = visits ? t->nv : t->nr, cap = visits ? MAX_VISITS : MAX_RAYS;
    size_t at = next(b) % (count + 1), n = 1 + next(b) % 32, i, j;
    for (i = at; i < at + n && i < cap; i++) {
        uint8_t *rec = visits ? (uint8_t *)&t->visits[i] : (uint8_t *)&t->rays[i];
        size_t size = visits ? sizeof t->visits[0] : sizeof t->rays[0];
        for (j = 0; j < size; j++) rec[j] = (uint8_t)next(b);
        if (visits) {
            int64_t *cost[3] = {&t->process[i], &t->receive[i], &t->send[i]};
            for (k = 0; k < 3; k++) {
                uint64_t v = 0;
                if (what & 2)
                    for (j = 0; j < 8; j++) v = v << 8 | next(b);
                else
                    v = next(b) % 24;
                memcpy(cost[k], &v, sizeof v);
            }
        }
        if (i >= count) count = i + 1;
    }
    if (visits)
        t->nv = count;
    else
        t->nr = count;
    return 1;
}

static int64_t run_once(mprt_replay *r, int *deadlocked)
{
    mprt_replay_info info;
    int rc = mprt_replay_run(r, NULL, 0);
    if (mprt_replay_get_info(r, &info) != MPRT_OK) FAIL("get_info failed after a run");
    *deadlocked = (int)info.deadlocked;
    if (rc != MPRT_OK) {
        if (!mprt_replay_errmsg(r)[0]) FAIL("run failed (%d) without a message", rc);
        return -1;
    }
    if (info.retired != info.rays) FAIL("finished with %lld of %lld rays retired", (long long)info.retired,
                                        (long long)info.rays);
    return info.cycles;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static trace t;
    static memdata md;
    static int64_t flits[MAX_VISITS];
    bytes b = {data, size, 0};
    mprt_replay_config c;
    mprt_replay *r = NULL;
    int damaged = 0, d1 = 0, d2 = 0, rc;
    unsigned trees, k;
    size_t nr, nv, i;
    int64_t c1, c2, total = 0, longest = 0;

    config(&c, &b);
    t.nr = t.nv = 0;
    trees = 1 + next(&b) % 8;
    for (k = 0; k < trees; k++)
        if (add_tree(&t, &b)) break;
    if (t.nr == 0) return 0;
    for (;;) {
        unsigned m = next(&b);
        if (m == 0xa5)
            damaged |= damage(&t, &b);
        else if (m == 0xa6)
            damaged |= raw_records(&t, &b);
        else
            break;
    }
    nr = t.nr;
    nv = t.nv;
    if (next(&b) == 0x5a) {                          /* cut short */
        nr -= nr ? next(&b) % (nr + 1) : 0;
        nv -= nv ? next(&b) % (nv + 1) : 0;
        damaged = 1;
    }
    rc = mprt_replay_create(&c, &r);
    if (rc != MPRT_OK) {
        if (!r) return 0;                            /* out of memory */
        if (!mprt_replay_errmsg(r)[0]) FAIL("create failed without a message");
        mprt_replay_destroy(r);
        return 0;
    }
    rc = mprt_replay_load(r, t.rays, nr, t.visits, nv, t.process, t.receive, t.send);
    if (rc != MPRT_OK) {
        if (!mprt_replay_errmsg(r)[0]) FAIL("load failed without a message");
        if (!damaged) FAIL("a well-formed trace was refused: %s", mprt_replay_errmsg(r));
        mprt_replay_destroy(r);
        return 0;
    }
    levels_2_and_3(&c, &t, nv, &b, r, &md, flits);
    c1 = run_once(r, &d1);
#ifdef FUZZ_STATS
    fprintf(stderr, "stats ring %d memory %d %d cycles %lld deadlock %d: %s\n", c.ring, c.memory[0], c.memory[1],
            (long long)c1, d1, mprt_replay_errmsg(r));
#endif
    c2 = run_once(r, &d2);
    if (c1 != c2 || d1 != d2) FAIL("two runs differ: %lld (deadlock %d) and %lld (deadlock %d)", (long long)c1, d1,
                                   (long long)c2, d2);
    if (c1 >= 0) {                  /* the work bound (nothing run) never exceeds a run */
        int64_t wb = -1;
        if (mprt_replay_work_bound(r, &wb) != MPRT_OK) FAIL("work bound refused after a run: %s", mprt_replay_errmsg(r));
        if (wb > c1) FAIL("work bound %lld above the run's %lld cycles", (long long)wb, (long long)c1);
        if (c.nstages == 1 && c.replicas[0] == 1 && c.pes == 1 && !c.memory[0] && !c.memory[1] && wb != c1)
            FAIL("one processor: work bound %lld, run %lld", (long long)wb, (long long)c1);
    }
    if (c1 >= 0 && !damaged) {
        for (i = 0; i < nv; i++) {
            int64_t v = t.process[i] + t.receive[i] + t.send[i];
            v = v < 1 ? 1 : v;
            total += v;
            longest = v > longest ? v : longest;
        }
        if (c1 < longest) FAIL("%lld cycles, below the longest visit's %lld", (long long)c1, (long long)longest);
        if (c.nstages == 1 && c.replicas[0] == 1 && c.pes == 1 && c.gen_cycles == 0 && !c.memory[0] &&
            !c.memory[1] && c1 != total)
            FAIL("one processor took %lld cycles for visits of %lld", (long long)c1, (long long)total);
    }
    mprt_replay_destroy(r);
    return 0;
}
