/* replay_memory.h: the memories' data and caches, shared by replay_memory.c (the
 * memories of level 3) and replay_summary.c (the summaries of long look-ups). */
#ifndef MPRT_REPLAY_MEMORY_H
#define MPRT_REPLAY_MEMORY_H
#include "replay.h"

/* A key's data, in one place (a visit reads all of it): its lines are
 * lines[start .. next key's start). */
typedef struct {
    int64_t start;
    int32_t items, res;
} keyinfo;

typedef struct {
    mprt_replay_memory fig;
    int64_t last;                /* the key of this cache's last look-up + 1 (0: none yet) */
} local_mem;

typedef struct {
    /* the data (mprt_replay_set_memory) */
    int has;
    size_t nkeys;
    int64_t line, span;          /* span: the largest line number + 1 */
    keyinfo *info;               /* per key + 1 */
    int64_t *lines;
    size_t cap_info, cap_lines;  /* (kept for the next data: mprt_replay_set_memory) */
    int64_t reads;               /* the visits' lines in all (at most MAX_READS): bounds a run's reads */
    /* a run */
    int on, cached, pow2, nports;
    int64_t nsets, ways, xfer, latency;
    int64_t *port_free;
    int64_t *tags;               /* per PE nsets x ways line numbers, most recently used first (-1: empty) */
    int64_t *where;              /* per entry of lines: its set's first way in a PE's tags (s x ways) */
    size_t cap_tags, cap_where;  /* (tags and where are kept from run to run: see build_one) */
    local_mem *loc;              /* per PE */
    /* kept from run to run while the data and the cache's shape stay */
    int64_t *repeat;             /* per key: a repeat's misses + 1 (0: not known yet) */
    int64_t rep_sets, rep_ways;  /* the shape they are for (0: none) */
    int64_t *summ;               /* per key: its summary's place in sum + 1 (0: not made yet; -1: none pays) */
    int64_t *sum;                /* the keys' summaries (replay_summary.c), for the same shape */
    size_t nsum, cap_sum;
    int64_t *scratch;            /* nsets x ways: the empty cache a summary is made in (-1: empty) */
    int summaries;               /* this run looks long keys up by summary (MPRT_CACHE_SUMMARY=0: never) */
    /* the work bound's: per key, the fewest misses any look-up of it takes in a cache of
     * least_sets x least_ways (0 x 0: not made for this data) */
    int64_t *least;
    size_t cap_least;
    int64_t least_sets, least_ways;
} memory;

struct mprt__mem {
    int32_t *key;                /* per visit */
    size_t cap_key;
    size_t nv;
    memory m[2];
};

/* Line x through a set of a cache (w: its ways, most recent first; -1 empty), not
 * its most recent line: 1 on a hit.  It becomes the set's most recent (front), the
 * lines before it moving back one; a miss drops the least recent (or an empty way). */
INLINE int lru_touch(int64_t *w, int64_t ways, int64_t x)
{
    int64_t i, prev = w[0], cur;
    int found = 0;
    if (ways == 4) {                  /* the loop below, unrolled */
        int64_t c1 = w[1], c2 = w[2], c3 = w[3];
        int f1 = c1 == x, f2 = f1 | (c2 == x);
        w[0] = x;
        w[1] = prev;
        w[2] = f1 ? c2 : c1;
        w[3] = f2 ? c3 : c2;
        return f2 | (c3 == x);
    }
    if (ways == 2) {
        found = w[1] == x;
        w[0] = x;
        w[1] = prev;
        return found;
    }
    w[0] = x;
    for (i = 1; i < ways; i++) {      /* no branch on where x is: ways is the trip count */
        cur = w[i];
        w[i] = found ? cur : prev;
        found |= cur == x;
        prev = cur;
    }
    return found;
}

#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif
/* Keys of fewer lines are always looked up line by line. */
#define SUM_MIN_LINES 12
/* A look-up of key k's lines through the cache whose sets are at tags, by the key's
 * summary (replay_summary.c): its misses, or -1 where a summary does not pay (the
 * caller looks the lines up one by one). */
int64_t mprt__summary_look_up(memory *m, int64_t *tags, int64_t k);
/* Forget the summaries (another cache shape), and free them. */
void mprt__summary_reset(memory *m);
void mprt__summary_free(memory *m);
#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif
