/* replay_summary.c: long look-ups by summary (level 3's caches, see replay_memory.c).
 *
 * A key that reads many lines through a small cache (a coarse grid's voxel list: hundreds
 * of lines through 128) is looked up set by set from a summary made once per key and
 * cache shape, instead of line by line.  In one set, let the key's lines be x1..xm in the
 * order read, y0, y1, ... its distinct lines in the order first read, and S the set before
 * the look-up (most recent first, empty ways last).
 * - A line read again within the key hits or misses as it would from an empty set: its
 *   distance back to its last read counts only the key's own lines.  So the misses are
 *   those of the look-up in an empty set less the first reads that hit in S.
 * - The first read of y_i hits iff y_i is in S, at a position p, and fewer than `ways`
 *   lines are ahead of it when it is read: p, plus one for each y_j (j < i) that was not
 *   ahead of it in S (not in S, or behind it), as reading one puts it in front.  Only the
 *   first `ways` of them can (the candidates).
 * - After the look-up the set holds the key's distinct lines by last use (the empty set's
 *   state after the key: `final`), then S's other lines in S's order, `ways` in all (the
 *   proof at the top of replay_memory.c).
 * In the empty set the first `ways` distinct lines are read before any is evicted, so
 * there are as many candidates as lines in `final`: n = min(ways, distinct lines).
 *
 * A summary (made in an empty scratch cache the first time the key is looked up with
 * this shape, and kept while the shape is): the empty set's misses, the sets touched,
 * and per set its first way's place in a PE's tags, n, the candidates, final.  It is made
 * only where reading it takes fewer steps than the lines (SUM_PAYS), with at most
 * SUM_MAX_WAYS ways; elsewhere, and if memory runs out, the caller looks the lines up. */
#include "replay_memory.h"

#define SUM_MAX_WAYS 16
#ifndef SUM_PAYS
#define SUM_PAYS 3          /* a summary's words x SUM_PAYS at most the key's lines */
#endif

void mprt__summary_free(memory *m)
{
    free(m->summ);
    free(m->sum);
    free(m->scratch);
    m->summ = m->sum = m->scratch = NULL;
    m->nsum = m->cap_sum = 0;
}

void mprt__summary_reset(memory *m)
{
    if (m->summ) memset(m->summ, 0, (m->nkeys + 1) * sizeof *m->summ);
    m->nsum = 0;
    free(m->scratch);
    m->scratch = NULL;
}

/* Make key k's summary at the end of m->sum: its place there + 1, or -1 where it does
 * not pay or memory runs out. */
static int64_t summarise(memory *m, int64_t k)
{
    const keyinfo *ki = &m->info[k];
    int64_t a = ki->start, b = ki[1].start, ways = m->ways, x, i, empty = 0, nset = 0, words = 2;
    size_t cells = (size_t)m->nsets * (size_t)m->ways, at = m->nsum, need = (size_t)(b - a) + 3;
    int64_t *sc, *cand, *sets, *o;
    int pays;
    if (ways > SUM_MAX_WAYS) return -1;         /* (the caller asks for keys of SUM_MIN_LINES or more) */
    if (!m->scratch) {          /* the empty cache, then the candidates by place (nsets x ways each) */
        if (!(m->scratch = malloc(2 * cells * sizeof *m->scratch))) return -1;
        for (i = 0; i < (int64_t)cells; i++) m->scratch[i] = -1;
    }
    sc = m->scratch;
    cand = sc + cells;
    /* the summary (at most need words), then the sets touched (at most a line each) */
    if (at + 2 * need > m->cap_sum) {          /* grown, keeping the summaries made */
        size_t cap = 2 * (at + 2 * need);
        int64_t *grown = cap < SIZE_MAX / sizeof *grown ? realloc(m->sum, cap * sizeof *grown) : NULL;
        if (!grown) return -1;
        m->sum = grown;
        m->cap_sum = cap;
    }
    sets = m->sum + at + need;
    for (x = a; x < b; x++) {
        int64_t line = m->lines[x], wh = m->where[x], *w = sc + wh;
        if (w[0] == line) continue;
        if (w[ways - 1] == -1) {        /* not full: a line read for the first time, candidate n */
            int64_t n = 0;
            while (w[n] != -1) n++;
            if (n == 0) sets[nset++] = wh;
            cand[wh + n] = line;
        }
        empty += !lru_touch(w, ways, line);
    }
    for (i = 0; i < nset; i++) {
        int64_t n = 0;
        while (n < ways && sc[sets[i] + n] != -1) n++;
        words += 2 + 2 * n;
    }
    o = m->sum + at;
    pays = words * SUM_PAYS <= b - a;
    if (pays) {
        o[0] = empty;
        o[1] = nset;
        o += 2;
    }
    for (i = 0; i < nset; i++) {
        int64_t n = 0, *w = sc + sets[i];
        while (n < ways && w[n] != -1) n++;
        if (pays) {
            o[0] = sets[i];
            o[1] = n;
            memcpy(o + 2, cand + sets[i], (size_t)n * sizeof *o);
            memcpy(o + 2 + n, w, (size_t)n * sizeof *o);
            o += 2 + 2 * n;
        }
        for (x = 0; x < n; x++) w[x] = -1;          /* the scratch cache empty again */
    }
    if (!pays) return -1;
    m->nsum = at + (size_t)words;
    return (int64_t)at + 1;
}

int64_t mprt__summary_look_up(memory *m, int64_t *tags, int64_t k)
{
    const int64_t *o;
    int64_t misses, nset, ways = m->ways, i;
    if (!m->summ && !(m->summ = calloc(m->nkeys + 1, sizeof *m->summ))) return -1;
    if (m->summ[k] == 0) m->summ[k] = summarise(m, k);
    if (m->summ[k] < 0) return -1;
    o = m->sum + (m->summ[k] - 1);
    misses = o[0];
    nset = o[1];
    o += 2;
    for (i = 0; i < nset; i++, o += 2 + 2 * o[1]) {
        int64_t *w = tags + o[0], n = o[1], p[SUM_MAX_WAYS], t[SUM_MAX_WAYS], j, c, q;
        const int64_t *cd = o + 2, *fin = o + 2 + n;
        uint32_t in_s = 0;                  /* S's places holding a candidate */
        for (j = 0; j < n; j++) {
            for (p[j] = -1, q = 0; q < ways; q++)
                if (w[q] == cd[j]) {
                    p[j] = q;
                    break;
                }
            if (p[j] >= 0) {
                int64_t ahead = p[j];
                for (c = 0; c < j; c++) ahead += p[c] < 0 || p[c] > p[j];
                misses -= ahead < ways;
                in_s |= (uint32_t)1 << p[j];
            }
        }
        memcpy(t, fin, (size_t)n * sizeof *t);
        for (c = n, q = 0; c < ways; q++)   /* then S's other lines (S has `ways`: enough) */
            if (!(in_s >> q & 1)) t[c++] = w[q];
        memcpy(w, t, (size_t)ways * sizeof *w);
    }
    return misses;
}
