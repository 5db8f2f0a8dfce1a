/* replay_bound.c: mprt_replay_work_bound, a lower bound of a run's cycles with nothing run
 * (see mprt.h): the stages' work over their processors, and the trees' lifetimes over the
 * DIS window, a tree living at least its critical path (its visits' cycles, the ring's
 * least times between stages, the memories' reads no state of them can spare) and its work
 * on each stage over the stage's replicas.  Its parts are worked out once a load (the
 * chains of visits alone), once per key and cache shape (the fewest misses), or per
 * configuration, kept while the mapping, flit time and memories stay. */
#include "replay_memory.h"

/* ---- the memories' reads -------------------------------------------------------------- */

/* Per key, the fewest misses any look-up of it takes in a cache of nsets sets of ways ways
 * (line x in set x mod nsets): of the d distinct lines of the key a set holds, at most ways
 * can be there when the look-up begins, so at least d - ways miss, whatever came before.
 * One pass over the keys' lines: a line's last key and a set's last key and count mark
 * what this key has seen (with more sets than line numbers no set holds two lines). */
static int least_misses(memory *m, int64_t nsets, int64_t ways)
{
    size_t k;
    int32_t *seen, *stamp;
    int64_t *count, span = m->span > 0 ? m->span : 1;
    if (m->least && m->least_sets == nsets && m->least_ways == ways) return MPRT_OK;
    if (mprt__replay_reserve((void **)&m->least, &m->cap_least, m->nkeys + 1, sizeof *m->least))
        return MPRT_ERR_OUT_OF_MEMORY;
    /* (line numbers past 2^24, or keys past 2^31: none counted, rather than arrays that large) */
    if (nsets >= span || span > ((int64_t)1 << 24) || m->nkeys >= (size_t)INT32_MAX) {
        memset(m->least, 0, (m->nkeys + 1) * sizeof *m->least);
    } else {
        seen = malloc((size_t)span * sizeof *seen);
        stamp = malloc((size_t)nsets * sizeof *stamp);
        count = malloc((size_t)nsets * sizeof *count);
        if (!seen || !stamp || !count) {
            free(seen);
            free(stamp);
            free(count);
            return MPRT_ERR_OUT_OF_MEMORY;
        }
        memset(seen, 0xff, (size_t)span * sizeof *seen);
        memset(stamp, 0xff, (size_t)nsets * sizeof *stamp);
        for (k = 0; k < m->nkeys; k++) {
            int64_t miss = 0, a = m->info[k].start, b = m->info[k + 1].start;
            if (b - a > ways) {         /* (no set gets more than ways lines of fewer) */
                for (; a < b; a++) {
                    int64_t x = m->lines[a], st = x % nsets;
                    if (seen[x] == (int32_t)k) continue;
                    seen[x] = (int32_t)k;
                    if (stamp[st] != (int32_t)k) {
                        stamp[st] = (int32_t)k;
                        count[st] = 0;
                    }
                    if (++count[st] > ways) miss++;
                }
            }
            m->least[k] = miss;
        }
        free(seen);
        free(stamp);
        free(count);
    }
    m->least_sets = nsets;
    m->least_ways = ways;
    return MPRT_OK;
}

/* A memory's reads each wait for the one before to be back: at least a transfer and the
 * latency a line read (the port's queue only adds).  Without a cache a visit reads every
 * line of its key; with one, at least the misses no state of the cache can spare (above).
 * Data that does not fit the configuration (the run refuses it), reads that could pass
 * 2^62 cycles, or no room to work the misses out, add nothing.
 * each[t]: memory t's least cycles a line read (0: nothing to add); 0 when neither adds. */
int mprt__replay_memory_each(mprt_replay *r, int64_t *each)
{
    struct mprt__mem *M = r->mem;
    const mprt_replay_config *c = &r->cfg;
    int t;
    each[0] = each[1] = 0;
    if (!M || M->nv != r->nv) return 0;
    for (t = 0; t < 2; t++) {
        memory *m = &M->m[t];
        int64_t size = c->cache_size[t], line = c->cache_line[t], ways = c->cache_ways[t];
        if (c->memory[t] && m->has && m->line == line && c->gm_bandwidth[t] > 0) {
            each[t] = (line + c->gm_bandwidth[t] - 1) / c->gm_bandwidth[t] + c->gm_latency[t];
            if (m->reads && each[t] > (INT64_MAX / 8) / m->reads) each[t] = 0;
            if (size > 0 && (ways < 1 || size % (line * ways) || least_misses(m, size / (line * ways), ways)))
                each[t] = 0;
        }
    }
    return each[0] || each[1];
}

int64_t mprt__replay_memory_lines(const mprt_replay *r, int64_t j, const int64_t *each)
{
    const struct mprt__mem *M = r->mem;
    int32_t key = M->key[j];
    int t = key >= 0 ? 0 : 1;
    int64_t k = key >= 0 ? key : -2 - (int64_t)key;
    if (key == -1 || !each[t]) return 0;
    if (r->cfg.cache_size[t] > 0) return M->m[t].least[k] * each[t];
    return (M->m[t].info[k + 1].start - M->m[t].info[k].start) * each[t];
}

/* ---- the trees' chains and the bound --------------------------------------------------- */

/* Flit times a packet from node s to node d takes at least on the ring: its header's hops,
 * then the rest of its flits (none to its own node). */
INLINE int64_t ring_latency(const mprt_replay *r, int s, int d, int64_t flits)
{
    int k = r->cfg.nstages;
    if (s == d) return 0;
    return ((d - s + k) % k + (flits > 1 ? flits - 1 : 0)) * r->cfg.flit_time;
}

/* Each tree's critical path into out: the longest chain of its visits' cycles, a ray's
 * visits one after the other and the rays an SC visit made after it.  With ring (its
 * packets' sizes set), each step between stages also takes the packet's least time on the
 * ring (a primary SC made too); with reads (mprt__replay_memory_each's), each visit the
 * least stalls of its memory's reads, also summed by stage into fl (3 per tree).  The rays'
 * first visits go on a stack with their start (nothing recurses). */
static int chains(mprt_replay *r, int64_t *out, int64_t *ex, int64_t *fl, int ring, const int64_t *reads)
{
    const int *on = r->cfg.stage_of;
    int64_t t, most = 1, *stack;
    for (t = 0; t < r->ntrees; t++) {   /* a tree's rays are at most its visits */
        int64_t n = (t + 1 < r->ntrees ? r->tree_first[t + 1] : (int64_t)r->nv) - r->tree_first[t];
        if (n > most) most = n;
    }
    if (!(stack = malloc(2 * (size_t)most * sizeof *stack)))
        return fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the trees' critical paths");
    for (t = 0; t < r->ntrees; t++) {
        int64_t n = 0, cp = 0, x = r->tree_first[t];
        if (fl) fl[3 * t] = fl[3 * t + 1] = fl[3 * t + 2] = 0;
        if (ex) ex[3 * t] = ex[3 * t + 1] = ex[3 * t + 2] = 0;
        stack[n++] = x;                 /* a primary SC made comes from SC's stage */
        stack[n++] = ring && r->cfg.gen_cycles > 0 ? ring_latency(r, on[2], on[0], r->pflits[x]) : 0;
        while (n) {
            int64_t at = stack[--n], j = stack[--n], nx;
            int sub = 0;                /* a ray begins on OS */
            for (;; j++) {              /* the ray's visits: the next one is j + 1 */
                vinfo v = r->wide ? r->vi[j] : unpack_visit(r->vp[j]);
                int64_t d = v.dur;
                nx = v.next;
                at += d;
                if (ex) ex[3 * t + sub] += d;   /* (by the subtask running it, as the run does) */
                if (reads) {
                    int64_t m = mprt__replay_memory_lines(r, j, reads);
                    at += m;
                    fl[3 * t + on[sub]] += m;   /* (the stage running it) */
                }
                if ((nx & 3) != NEXT_VISIT) break;
                if (ring) at += ring_latency(r, on[sub], on[(nx >> 2) & 3], r->pflits[j + 1]);
                sub = (int)((nx >> 2) & 3);
            }
            if (at > cp) cp = at;
            if ((nx & 3) == NEXT_CHILDREN) {
                int64_t c, a = nx >> 10, b = a + ((nx >> 2) & 255);
                for (c = a; c < b; c++) {
                    stack[n++] = r->child[c];
                    stack[n++] = at + (ring ? ring_latency(r, on[sub], on[0], r->pflits[r->child[c]]) : 0);
                }
            }
        }
        out[t] = cp;
    }
    free(stack);
    return MPRT_OK;
}

/* The trees' critical paths for the configuration set: the visits' cycles alone, or with
 * the ring's and the memories' least times (a run's), with *fl the memories' least stalls
 * per tree and stage (NULL: none), kept while what they depend on stays (a search's designs
 * differ in FIFOs, replicas and PEs more often); and *ex each tree's visits' cycles by the
 * subtask that runs them (a ray's first visit on OS, as in a run).  What depends on the
 * trace alone is worked out once a load. */
static const int64_t *critical_paths(mprt_replay *r, const int64_t **fl, const int64_t **ex)
{
    const mprt_replay_config *c = &r->cfg;
    int64_t each[2], room, sig[CX_SIG];
    int ring = c->ring && r->flits_set, mem = mprt__replay_memory_each(r, each), i = 0;
    size_t nt = (size_t)r->ntrees;
    *fl = NULL;
    if (r->cp_load != r->loads || !r->tree_cp) {
        if (RESERVE(r, tree_cp, cap_tree_cp, nt + 1) || RESERVE(r, tree_ex, cap_tree_ex, 3 * nt + 1) ||
            chains(r, r->tree_cp, r->tree_ex, NULL, 0, NULL) != MPRT_OK) {
            fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the trees' critical paths");
            return NULL;
        }
        r->cp_load = r->loads;
    }
    *ex = r->tree_ex;
    /* (every packet's least time at most what the run allows it: mprt_replay_run's check) */
    room = INT64_MAX / 8 - r->total - (c->gen_cycles > 0 ? c->gen_cycles * r->ntrees : 0);
    if (ring && c->flit_time > room / ((int64_t)(r->nv + nt) * (RING_MAX + r->max_flits) + 1)) ring = 0;
    if (!ring && !mem) return r->tree_cp;
    {
        int t;
        sig[i++] = r->loads;
        sig[i++] = c->nstages;
        for (t = 0; t < 3; t++) sig[i++] = c->stage_of[t];
        sig[i++] = ring ? c->flit_time : 0;
        sig[i++] = c->gen_cycles > 0;
        for (t = 0; t < 2; t++) {
            sig[i++] = each[t];
            sig[i++] = c->cache_size[t];
            sig[i++] = c->cache_line[t];
            sig[i++] = c->cache_ways[t];
        }
    }
    if (!r->cx_ok || memcmp(sig, r->cx_sig, sizeof sig) != 0) {
        r->cx_ok = 0;
        if (RESERVE(r, tree_cx, cap_tree_cx, nt + 1) || RESERVE(r, tree_fl, cap_tree_fl, 3 * nt + 1) ||
            chains(r, r->tree_cx, NULL, r->tree_fl, ring, mem ? each : NULL) != MPRT_OK) {
            fail(r, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the trees' critical paths");
            return NULL;
        }
        memcpy(r->cx_sig, sig, sizeof sig);
        r->cx_ok = 1;
    }
    *fl = mem ? r->tree_fl : NULL;
    return r->tree_cx;
}

int mprt_replay_work_bound(mprt_replay *r, int64_t *cycles)
{
    const mprt_replay_config *c;
    int64_t g, best = 0;
    const int64_t *cp, *fl, *ex;
    int p, k, s, rc;
    if (!r || !cycles) return MPRT_ERR_INVALID_ARG;
    r->errmsg[0] = '\0';
    if (!r->loaded) return fail(r, MPRT_ERR_STATE, "no trace loaded (mprt_replay_load)");
    c = &r->cfg;
    g = c->gen_cycles > 0 ? c->gen_cycles : 0;
    if ((rc = mprt__replay_check_figures(r)) != MPRT_OK) return rc;
    if (!(cp = critical_paths(r, &fl, &ex))) return MPRT_ERR_OUT_OF_MEMORY;
    /* (every sum below is at most the visits' cycles and the making's, under 2^62, and the
     * stalls, under 2^60 a memory: mprt__replay_memory_each) */
    for (p = 0; p < (c->dis == MPRT_DIS_DYNAMIC ? 1 : c->pes); p++) {
        int64_t t, first, stop, step, sw[3] = {0, 0, 0}, life = 0, b;
        if (c->dis == MPRT_DIS_DYNAMIC) {       /* every tree, over every PE */
            first = 0;
            stop = r->ntrees;
            step = 1;
        } else {                                /* as the run's DIS deals them */
            mprt__replay_deal(r, p, &first, &stop, &step);
        }
        for (t = first; t < stop; t += step) {
            /* the tree's work by stage: its visits' cycles, the making of its primary, and at
             * level 3 the stalls no cache can spare */
            int64_t tw[3] = {0, 0, 0}, lives = cp[t] + g;
            for (k = 0; k < 3; k++) tw[c->stage_of[k]] += ex[3 * t + k];
            tw[c->stage_of[MPRT_STAGE_SC]] += g;
            if (fl)
                for (s = 0; s < 3; s++) tw[s] += fl[3 * t + s];
            /* it lives at least its chain, and its work on a stage over the stage's replicas */
            for (s = 0; s < c->nstages; s++) {
                sw[s] += tw[s];
                b = (tw[s] + c->replicas[s] - 1) / c->replicas[s];
                if (b > lives) lives = b;
            }
            life += lives;
        }
        /* DIS admits a tree while fewer than window rays are live, and a tree in flight has one:
         * at most window trees of a PE at once (the dynamic DIS's: every PE's) */
        b = life / c->window + (life % c->window != 0);
        if (c->dis == MPRT_DIS_DYNAMIC) b = b / c->pes + (b % c->pes != 0);
        if (b > best) best = b;
        for (s = 0; s < c->nstages; s++) {
            /* one PE's share: its replicas; the dynamic DIS's: every PE's */
            int64_t n = (int64_t)c->replicas[s] * (c->dis == MPRT_DIS_DYNAMIC ? c->pes : 1);
            b = (sw[s] + n - 1) / n;
            if (b > best) best = b;
        }
    }
    *cycles = best;
    return MPRT_OK;
}
