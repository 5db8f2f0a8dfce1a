/* replay_memory.c: level 3 of the compiled replay, the memories (see mprt.h and
 * python/mprt/machine/memory.py, whose rules it follows step for step).
 *
 * Per memory (IC data behind ICGM, SC data behind SCGM) the caller gives, per
 * key (a voxel, a material), the items a visit reads and how many of them are
 * resident, and the lines it reads outside resident memory.  A run gives every
 * PE a local memory per modelled memory: a cache (flat arrays, nsets x ways
 * line numbers in LRU order, most recent first; no per-set allocation) and its
 * figures; the global memory has one port, or one per PE.  When a visit starts
 * (mprt__replay_stall) its lines go through the cache, and each miss is read
 * after the previous one's data is back: from the port's first free cycle,
 * for the line's transfer, plus the latency.  The stall is when the last data
 * is back, less the start.
 *
 * A look-up of a key right after a look-up of the same key in the same cache (a
 * repeat) leaves the cache as it was, and its misses depend on the key and the
 * cache's shape alone, so they are worked out once (the first repeat runs the look-up)
 * and kept for every later repeat, in every PE and every run of that shape.  Proof,
 * one set at a time, x1..xm the key's lines that map to it in the order read (a line
 * may recur): after any look-up, if they hold at least `ways` distinct lines the set
 * holds the last `ways` of them by last use, whatever it held before; else it holds
 * all of them, by last use, in front of what it held before less them, in its order.
 * Reading x1..xm again: in the first case the set ends the same by the same rule, and
 * its misses follow from a state the key alone made; in the second every line hits
 * (none is evicted, as fewer than `ways` distinct lines are touched), none of the
 * rest moves, and the order by last use is the same.  (A key without lines touches
 * nothing and leaves the last look-up as it was.)
 *
 * The misses of a visit are read one after the other, so only their number counts:
 * the first waits for the port (free at cycle p, the visit starting at t) until
 * s = max(t, p); each takes its transfer and then the latency, the next one starting
 * when the data is back (then the port is free again, as the latency is >= 0).  With
 * n misses the data is back at s + n (xfer + lat), the port is free at
 * s + n xfer + (n - 1) lat, and the reads waited s - t.
 *
 * A cache is never allocated larger than its data can fill: with more sets
 * than lines (numbers 0..L-1) every line has a set of its own, as it has with
 * L sets (line mod L = line); a set never holds more lines than map to it, so
 * ways beyond that never evict.  So the arrays hold at most about 2L lines per
 * PE whatever the configured size, and the result is the configured cache's.
 *
 * A key of many lines (a coarse grid's voxel list through a small cache) is looked up
 * set by set from a summary made once per key and shape (replay_summary.c). */
#include "replay_memory.h"


#define MAX_READS ((int64_t)1 << 62)
#define MAX_LINE ((int64_t)1 << 40)

static const char *NAME[2] = {"IC", "SC"};

static int pow2(int64_t x) { return x > 0 && (x & (x - 1)) == 0; }

/* ---- the configuration ---------------------------------------------------------- */

int mprt__replay_memory_check(mprt_replay *r, const mprt_replay_config *c)
{
    int t;
    for (t = 0; t < 2; t++) {
        int64_t size = c->cache_size[t], line = c->cache_line[t], ways = c->cache_ways[t];
        if (c->memory[t] != 0 && c->memory[t] != 1)
            return fail(r, MPRT_ERR_INVALID_ARG, "memory[%d]: must be 0 or 1 (%s data modelled), not %d", t,
                        NAME[t], c->memory[t]);
        if (!c->memory[t]) continue;
        if (line < 1 || line > MAX_LINE || !pow2(line))
            return fail(r, MPRT_ERR_INVALID_ARG, "cache_line[%d]: must be a power of two up to 2^40 bytes, not %lld",
                        t, (long long)line);
        if (size < 0 || size > MPRT_REPLAY_MAX_CACHE)
            return fail(r, MPRT_ERR_INVALID_ARG, "cache_size[%d]: must be 0 (no cache) to 2^40 bytes, not %lld", t,
                        (long long)size);
        if (size > 0) {
            if (ways < 1 || ways > size / line)
                return fail(r, MPRT_ERR_INVALID_ARG, "cache_ways[%d]: must be 1..%lld (cache_size / cache_line), "
                            "not %lld", t, (long long)(size / line), (long long)ways);
            if (size % (line * ways))
                return fail(r, MPRT_ERR_INVALID_ARG, "cache_size[%d]: %lld bytes is not a whole number of sets of "
                            "%lld ways x %lld-byte lines", t, (long long)size, (long long)ways, (long long)line);
        }
        if (c->gm_latency[t] < 0 || c->gm_latency[t] > MAX_READS)
            return fail(r, MPRT_ERR_INVALID_ARG, "gm_latency[%d]: must be 0..2^62 cycles, not %lld", t,
                        (long long)c->gm_latency[t]);
        if (c->gm_bandwidth[t] < 1)
            return fail(r, MPRT_ERR_INVALID_ARG, "gm_bandwidth[%d]: must be >= 1 byte per cycle, not %lld", t,
                        (long long)c->gm_bandwidth[t]);
        if (c->gm_contention[t] != 0 && c->gm_contention[t] != 1)
            return fail(r, MPRT_ERR_INVALID_ARG, "gm_contention[%d]: must be 0 or 1, not %d", t,
                        c->gm_contention[t]);
    }
    return MPRT_OK;
}

/* ---- the data --------------------------------------------------------------------- */

static void free_data(memory *m)
{
    free(m->info);
    free(m->lines);
    m->cap_info = m->cap_lines = 0;
    free(m->repeat);
    free(m->tags);
    free(m->where);
    m->tags = m->where = NULL;
    m->cap_tags = m->cap_where = 0;
    mprt__summary_free(m);
    m->info = NULL;
    m->lines = NULL;
    m->repeat = NULL;
    m->rep_sets = m->rep_ways = 0;
    free(m->least);
    m->least = NULL;
    m->cap_least = 0;
    m->least_sets = m->least_ways = 0;
    m->has = 0;
    m->nkeys = 0;
}

void mprt__replay_memory_free(mprt_replay *r)
{
    struct mprt__mem *M = r->mem;
    if (!M) return;
    mprt__replay_memory_free_run(r);
    free_data(&M->m[0]);
    free_data(&M->m[1]);
    free(M->key);
    free(M);
    r->mem = NULL;
}

/* Check and copy one memory's data. */
static int copy_data(mprt_replay *r, memory *m, int t, const mprt_replay_memory_data *d)
{
    size_t k, n = d->nkeys, nl;
    int64_t span = 0;
    if (d->line < 1 || d->line > MAX_LINE || !pow2(d->line))
        return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: line must be a power of two up to 2^40 bytes, "
                    "not %lld", NAME[t], (long long)d->line);
    if (n > ((size_t)1 << 40) || !d->line_start || (n && (!d->items || !d->resident)))
        return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: missing arrays or too many keys", NAME[t]);
    if (d->line_start[0] != 0)
        return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: line_start[0] must be 0", NAME[t]);
    for (k = 0; k < n; k++) {
        if (d->line_start[k + 1] < d->line_start[k])
            return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: line_start decreases at key %zu", NAME[t], k);
        if (d->items[k] < 0 || d->resident[k] < 0 || d->resident[k] > d->items[k])
            return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: key %zu reads %d items, %d resident", NAME[t], k,
                        d->items[k], d->resident[k]);
    }
    if (d->line_start[n] > (int64_t)1 << 40)
        return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: more than 2^40 lines", NAME[t]);
    nl = (size_t)d->line_start[n];
    if (nl && !d->lines) return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: lines missing", NAME[t]);
    for (k = 0; k < nl; k++) {
        if (d->lines[k] < 0 || d->lines[k] >= MAX_READS)
            return fail(r, MPRT_ERR_INVALID_ARG, "memory data %s: line %zu is %lld (0..2^62 needed)", NAME[t], k,
                        (long long)d->lines[k]);
        if (d->lines[k] >= span) span = d->lines[k] + 1;
    }
    /* the arrays of the data before are reused (a search sends other resident sizes in turn);
     * what was worked out from that data goes */
    if (mprt__replay_reserve((void **)&m->info, &m->cap_info, n + 1, sizeof *m->info) ||
        mprt__replay_reserve((void **)&m->lines, &m->cap_lines, nl + 1, sizeof *m->lines))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the %s memory data", NAME[t]);
    m->rep_sets = m->rep_ways = 0;      /* the next run's repeats, summaries and sets made anew */
    m->least_sets = m->least_ways = 0;  /* and the work bound's fewest misses */
    if (n != m->nkeys) {                /* and their per-key arrays sized anew */
        free(m->repeat);
        m->repeat = NULL;
        mprt__summary_free(m);
    }
    for (k = 0; k <= n; k++) {
        m->info[k].start = d->line_start[k];
        m->info[k].items = k < n ? d->items[k] : 0;
        m->info[k].res = k < n ? d->resident[k] : 0;
    }
    if (nl) memcpy(m->lines, d->lines, nl * sizeof *m->lines);
    m->nkeys = n;
    m->line = d->line;
    m->span = span;
    m->reads = 0;
    m->has = 1;
    return MPRT_OK;
}

int mprt_replay_set_memory(mprt_replay *r, const int32_t *key, size_t nvisits, const mprt_replay_memory_data *ic,
                           const mprt_replay_memory_data *sc)
{
    const mprt_replay_memory_data *d[2];
    struct mprt__mem *M;
    size_t j;
    int t, rc = MPRT_OK;
    if (!r) return MPRT_ERR_INVALID_ARG;
    r->errmsg[0] = '\0';
    mprt__replay_free_run(r);
    if (!r->loaded)
        rc = fail(r, MPRT_ERR_STATE, "no trace loaded (mprt_replay_load)");
    else if (nvisits != r->nv)
        rc = fail(r, MPRT_ERR_INVALID_ARG, "memory keys: %zu given, the trace has %zu visits", nvisits, r->nv);
    else if (nvisits && !key)
        rc = fail(r, MPRT_ERR_INVALID_ARG, "memory keys: missing");
    else if (!r->mem && !(r->mem = calloc(1, sizeof *r->mem)))
        rc = fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the memory data");
    if (rc != MPRT_OK) {                /* a failed call keeps no data */
        mprt__replay_memory_free(r);
        return rc;
    }
    M = r->mem;             /* (the arrays of the data before are reused: copy_data) */
    M->m[0].has = M->m[1].has = 0;
    d[0] = ic;
    d[1] = sc;
    for (t = 0; t < 2 && rc == MPRT_OK; t++)
        if (d[t]) rc = copy_data(r, &M->m[t], t, d[t]);
    if (rc == MPRT_OK && mprt__replay_reserve((void **)&M->key, &M->cap_key, nvisits + 1, sizeof *M->key))
        rc = fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %zu memory keys", nvisits);
    for (j = 0; j < nvisits && rc == MPRT_OK; j++) {
        int32_t k = key[j];
        memory *m = &M->m[k >= 0 ? 0 : 1];
        int64_t i = k >= 0 ? k : -2 - (int64_t)k;
        M->key[j] = k;
        if (k == -1 || !m->has) continue;       /* (a memory without data cannot be modelled) */
        if (i >= (int64_t)m->nkeys) {
            rc = fail(r, MPRT_ERR_INVALID_ARG, "memory keys: visit %zu reads %s key %lld, not among the %zu given",
                      j, NAME[k >= 0 ? 0 : 1], (long long)i, m->nkeys);
            break;
        }
        m->reads += m->info[i + 1].start - m->info[i].start;
        if (m->reads > MAX_READS) m->reads = MAX_READS;
    }
    M->nv = nvisits;
    r->cx_ok = 0;                       /* (the work bound's chains were for the data before) */
    if (rc != MPRT_OK) mprt__replay_memory_free(r);
    return rc;
}

/* ---- a run ------------------------------------------------------------------------- */

void mprt__replay_memory_free_run(mprt_replay *r)
{
    int t;
    r->mem_on = 0;
    r->mem_bound = 0;
    r->mem_key = NULL;
    if (!r->mem) return;
    for (t = 0; t < 2; t++) {
        memory *m = &r->mem->m[t];
        free(m->port_free);
        free(m->loc);
        m->port_free = NULL;           /* (tags and where stay for the next run: build_one) */
        m->loc = NULL;
        m->on = 0;
    }
}

/* Sets and ways the arrays need for the configured cache (see the top). */
static void cache_shape(memory *m, int64_t size, int64_t line, int64_t ways)
{
    int64_t nsets = size / (line * ways), span = m->span > 0 ? m->span : 1;
    m->pow2 = 0;
    if (nsets > span) {
        nsets = span;
    } else if (pow2(nsets)) {
        m->pow2 = 1;
    }
    if (ways > (span + nsets - 1) / nsets) ways = (span + nsets - 1) / nsets;
    m->nsets = nsets;
    m->ways = ways;
}

static int build_one(mprt_replay *r, int t)
{
    const mprt_replay_config *c = &r->cfg;
    memory *m = &r->mem->m[t];
    size_t pes = (size_t)c->pes, cells, a, nl;
    int64_t per;
    const char *env;
    int reshaped;
    m->on = 1;
    m->cached = c->cache_size[t] > 0;
    m->xfer = (c->cache_line[t] + c->gm_bandwidth[t] - 1) / c->gm_bandwidth[t];
    m->latency = c->gm_latency[t];
    m->nports = c->gm_contention[t] ? 1 : c->pes;
    m->port_free = calloc((size_t)m->nports, sizeof *m->port_free);
    m->loc = calloc(pes, sizeof *m->loc);
    if (!m->port_free || !m->loc) return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the %s memory", NAME[t]);
    if (!m->cached) return MPRT_OK;
    cache_shape(m, c->cache_size[t], c->cache_line[t], c->cache_ways[t]);
    env = getenv("MPRT_CACHE_SUMMARY");           /* "0": every line looked up (tests compare the two) */
    m->summaries = !(env && strcmp(env, "0") == 0);
    per = m->nsets * m->ways;       /* at most about 2 x span (< 2^63) */
    if (per < 0 || (uint64_t)per > (uint64_t)MPRT_REPLAY_MAX_CACHE_ENTRIES / pes)
        return fail(r, MPRT_ERR_INVALID_ARG, "cache_size[%d]: the %s caches would hold %zu PEs x %lld entries per PE "
                    "(sets x ways the data can fill), more than 2^28 in all", t, NAME[t], pes, (long long)per);
    cells = (size_t)per * pes;
    nl = (size_t)m->info[m->nkeys].start;
    /* the tags and the lines' sets are kept from run to run (fresh pages cost more than the
     * runs of small traces), the sets while the cache's shape stays */
    reshaped = !m->where || m->rep_sets != m->nsets || m->rep_ways != m->ways;
    if (mprt__replay_reserve((void **)&m->tags, &m->cap_tags, cells, sizeof *m->tags) ||
        (reshaped && mprt__replay_reserve((void **)&m->where, &m->cap_where, nl + 1, sizeof *m->where)))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "cache_size[%d]: out of memory for the %s caches of %zu PEs", t,
                    NAME[t], pes);
    for (a = 0; a < cells; a++) m->tags[a] = -1;     /* (line numbers are >= 0) */
    for (a = 0; reshaped && a < nl; a++)
        m->where[a] = (m->pow2 ? (m->lines[a] & (m->nsets - 1)) : m->lines[a] % m->nsets) * m->ways;
    if (!m->repeat && !(m->repeat = malloc((m->nkeys + 1) * sizeof *m->repeat)))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the %s caches' repeats", NAME[t]);
    if (reshaped) {     /* another shape: its repeats are unknown */
        memset(m->repeat, 0, (m->nkeys + 1) * sizeof *m->repeat);
        mprt__summary_reset(m);
        m->rep_sets = m->nsets;
        m->rep_ways = m->ways;
    }
    return MPRT_OK;
}

int mprt__replay_memory_build(mprt_replay *r)
{
    const mprt_replay_config *c = &r->cfg;
    int64_t room = INT64_MAX / 2 - r->total - c->gen_cycles * r->ntrees;
    int t, rc;
    mprt__replay_memory_free_run(r);
    for (t = 0; t < 2; t++) {
        memory *m;
        int64_t each;
        if (!c->memory[t]) continue;
        if (!r->mem || !r->mem->m[t].has || r->mem->nv != r->nv)
            return fail(r, MPRT_ERR_STATE, "memory[%d]: the %s memory is modelled but has no data "
                        "(mprt_replay_set_memory)", t, NAME[t]);
        m = &r->mem->m[t];
        if (m->line != c->cache_line[t])
            return fail(r, MPRT_ERR_INVALID_ARG, "cache_line[%d]: %lld bytes, but the %s memory data has lines of "
                        "%lld", t, (long long)c->cache_line[t], NAME[t], (long long)m->line);
        rc = build_one(r, t);
        if (rc != MPRT_OK) return rc;
        /* every read adds at most its transfer and the latency to the run's time */
        each = m->xfer + m->latency;
        if (m->reads && each > (room - r->mem_bound) / m->reads)
            return fail(r, MPRT_ERR_INVALID_ARG, "gm_latency[%d]: %lld line reads of up to %lld cycles each, with "
                        "the visits' cycles, could exceed 2^62 cycles", t, (long long)m->reads, (long long)each);
        r->mem_bound += m->reads * each;
        r->mem_on = 1;
        r->mem_key = r->mem->key;
    }
    return MPRT_OK;
}

/* Lines a .. b through the cache whose sets are at tags (a PE's), of ways ways: the
 * misses.  Called with ways a constant where it is 2 or 4, so that the compiler
 * unrolls the look-up for them. */
INLINE int64_t look_up(const memory *m, int64_t *tags, int64_t ways, int64_t a, int64_t b)
{
    const int64_t *lines = m->lines, *where = m->where;
    int64_t reads = 0;
    for (; a < b; a++) {
        int64_t x = lines[a], *w = tags + where[a];
        if (w[0] != x && !lru_touch(w, ways, x)) reads++;
    }
    return reads;
}

int64_t mprt__replay_stall(mprt_replay *r, int i, int64_t j)
{
    struct mprt__mem *M = r->mem;
    int32_t key = M->key[j];
    int pe = r->procs[i].pe;
    memory *m;
    local_mem *lm;
    const keyinfo *ki;
    int64_t k, a, b, now = r->now, s, *port, reads;
    if (key == -1) return 0;
    m = &M->m[key >= 0 ? 0 : 1];
    if (!m->on) return 0;
    k = key >= 0 ? key : -2 - (int64_t)key;
    lm = &m->loc[pe];
    ki = &m->info[k];
    lm->fig.resident_accesses += ki->items;
    lm->fig.resident_hits += ki->res;
    a = ki->start;
    b = ki[1].start;
    if (a == b) return 0;
    reads = b - a;                      /* without a cache, every line */
    if (m->cached) {
        int64_t *tags = m->tags + (size_t)pe * (size_t)m->nsets * (size_t)m->ways, ways = m->ways;
        if (lm->last == k + 1 && m->repeat[k]) {
            reads = m->repeat[k] - 1;   /* a repeat: nothing changes (see the top) */
        } else {
            reads = m->summaries && b - a >= SUM_MIN_LINES ? mprt__summary_look_up(m, tags, k) : -1;
            if (reads >= 0)
                ;                       /* a long look-up, by its summary (replay_summary.c) */
            else if (ways == 4)
                reads = look_up(m, tags, 4, a, b);
            else if (ways == 2)
                reads = look_up(m, tags, 2, a, b);
            else
                reads = look_up(m, tags, ways, a, b);
            if (lm->last == k + 1) m->repeat[k] = reads + 1;
            lm->last = k + 1;
        }
        lm->fig.cache_accesses += b - a;
        lm->fig.cache_hits += b - a - reads;
        if (!reads) return 0;
    }
    port = &m->port_free[m->nports == 1 ? 0 : pe];
    s = now > *port ? now : *port;
    *port = s + reads * m->xfer + (reads - 1) * m->latency;
    lm->fig.gm_accesses += reads;
    lm->fig.gm_busy += reads * m->xfer;
    lm->fig.gm_queued += s - now;
    lm->fig.stall += s - now + reads * (m->xfer + m->latency);
    return s - now + reads * (m->xfer + m->latency);
}

/* ---- figures ------------------------------------------------------------------------ */

int mprt_replay_get_memory(const mprt_replay *r, mprt_replay_memory *out, size_t cap, int64_t *stall,
                           size_t stall_cap)
{
    int p, t, i;
    if (!r || !r->ran) return MPRT_ERR_STATE;
    if (!out || (stall_cap && !stall)) return MPRT_ERR_INVALID_ARG;
    if (cap < 2 * (size_t)r->cfg.pes || (stall && stall_cap < (size_t)r->nproc)) return MPRT_ERR_CAPACITY;
    for (p = 0; p < r->cfg.pes; p++)
        for (t = 0; t < 2; t++) {
            const memory *m = r->mem ? &r->mem->m[t] : NULL;
            if (m && m->on)
                out[2 * p + t] = m->loc[p].fig;
            else
                memset(&out[2 * p + t], 0, sizeof *out);
        }
    for (i = 0; stall && i < r->nproc; i++) stall[i] = r->procs[i].stall;
    return MPRT_OK;
}
