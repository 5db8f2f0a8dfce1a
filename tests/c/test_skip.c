/* test_skip.c: empty-space skipping changes no count.  A jump across a
 * block of voxels (mprt__dda_jump) moves the walk exactly as the
 * step-by-step walk moves it, never past the block: to the voxel where the
 * walk leaves the block, or short of it where a run of the walk's sums
 * ends, or to the walk's end, with the same count of voxels entered; the
 * runs reproduce the walk's rounded additions bit for bit; and the
 * chessboard distance transform the blocks come from is exact.  Whole
 * traces with and without jumps: tests/test_skip.py. */
#include "check.h"
#include "dda.h"
#include "geom.h"

#include <stdint.h>

/* Three spheres: two at opposite corners of the box [0,8]^3, one inside. */
static mprt_scene *corner_scene(void)
{
    static const double spheres[3][4] = {{1, 1, 1, 1}, {7, 7, 7, 1}, {5, 2, 6, 0.5}};
    mprt_scene *s;
    int i;
    mprt_scene_create(&s);
    for (i = 0; i < 3; i++) mprt_scene_add_sphere(s, spheres[i], spheres[i][3]);
    return s;
}

static mprt_grid *make_grid(const mprt_scene *s, int nx, int ny, int nz)
{
    mprt_grid *g;
    int st = mprt_grid_create(s, nx, ny, nz, 0, &g);
    CHECK_MSG(st == MPRT_OK, "%s", mprt_grid_errmsg(g));
    return g;
}

/* Same walk state, bit for bit. */
static int same_state(const mprt__dda *a, const mprt__dda *b)
{
    int k;
    for (k = 0; k < 3; k++)
        if (a->cell[k] != b->cell[k] || a->tnext[k] != b->tnext[k]) return 0;
    return a->voxel == b->voxel && a->t_enter == b->t_enter && a->t_exit == b->t_exit;
}

/* A random ray that is often hard: origins snapped onto voxel boundaries,
 * directions along axes, face diagonals and the main diagonal. */
static void hard_ray(rng *r, const mprt_grid *g, vec3 *o, vec3 *d)
{
    double p[3], v[3];
    int a, kind = rnd_int(r, 0, 3);
    for (a = 0; a < 3; a++) {
        double lo = (double)vget(g->lo, a), ext = (double)vget(g->hi, a) - lo;
        p[a] = lo + rnd_in(r, -0.3, 1.3) * ext;
        if (rnd_int(r, 0, 2) == 0) /* onto a voxel boundary */
            p[a] = lo + (double)rnd_int(r, 0, g->n[a]) * (double)vget(g->cell, a);
        v[a] = rnd_in(r, -1, 1);
        if (kind == 1 && a > 0) v[a] = 0;                                   /* along an axis */
        if (kind == 2) v[a] = a == 2 ? 0 : (rnd_int(r, 0, 1) ? 1 : -1);     /* a face diagonal */
        if (kind == 3) v[a] = rnd_int(r, 0, 1) ? 1 : -1;                    /* a main diagonal */
    }
    if (kind == 1 && v[0] == 0) v[0] = 1;
    *o = vd(p[0], p[1], p[2]);
    *d = vd(v[0], v[1], v[2]);
}

/* Whether the plain walk from w, taking n steps, stays in the block whose
 * last voxel per axis in the ray's direction is last[] for all but the last
 * voxel it enters; *out is its state after the n steps, *ended whether the
 * walk ended right there (a further step fails). */
static int plain_steps(const mprt_grid *g, const mprt__dda *w, const int last[3], int32_t n, mprt__dda *out,
                       int *ended)
{
    int a, inside = 1;
    int32_t k;
    mprt__dda probe;
    *out = *w;
    for (k = 0; k < n; k++) {
        for (a = 0; a < 3; a++)
            if ((out->cell[a] - last[a]) * out->step[a] > 0) inside = 0; /* left the block too early */
        if (!mprt__dda_next(g, out)) return 0;
    }
    probe = *out;
    *ended = !mprt__dda_next(g, &probe);
    return inside;
}

static void test_a_jump_ends_where_the_plain_walk_leaves_the_block(void)
{
    mprt_scene *s = corner_scene();
    static const int dims[][3] = {{8, 8, 8}, {13, 5, 9}, {1, 7, 30}, {40, 40, 40}};
    rng r;
    int gi, i, bad = 0, jumps = 0, ended = 0, longest = 0;
    rng_seed(&r, 11);
    for (gi = 0; gi < 4; gi++) {
        mprt_grid *g = make_grid(s, dims[gi][0], dims[gi][1], dims[gi][2]);
        for (i = 0; i < 20000; i++) {
            mprt__ray ray;
            mprt__dda w, plain, jumped;
            int ok, plain_ended = 0;
            vec3 o, d;
            int32_t n_jump = 0, k, skip = rnd_int(&r, 0, 6), h = rnd_int(&r, 1, 12);
            real tmax = rnd_int(&r, 0, 3) == 0 ? (real)rnd_in(&r, 0, 12) : (real)INFINITY;
            int more_jump, last[3], a;
            hard_ray(&r, g, &o, &d);
            mprt__ray_prepare(&ray, o, d);
            if (!mprt__dda_start(g, &ray, 0, tmax, &w)) continue;
            /* start the jump somewhere along the walk (not past its end) */
            for (k = 0; k < skip; k++) {
                mprt__dda next = w;
                if (!mprt__dda_next(g, &next)) break;
                w = next;
            }
            /* a block of up to h voxels ahead on each axis, clipped to the grid */
            for (a = 0; a < 3; a++) {
                int c = w.cell[a] + w.step[a] * rnd_int(&r, 0, h);
                last[a] = c < 0 ? 0 : c >= g->n[a] ? g->n[a] - 1 : c;
            }
            jumped = w;
            more_jump = mprt__dda_jump(g, &jumped, last, &n_jump);
            jumps++;
            ended += !more_jump;
            /* the jump moved as the plain walk does, within the block, and
             * either landed on a voxel (past at least one crossing) or ended
             * where the plain walk ends */
            ok = plain_steps(g, &w, last, more_jump ? n_jump - 1 : n_jump, &plain, &plain_ended);
            if (ok && more_jump) {
                ok = mprt__dda_next(g, &plain) && same_state(&plain, &jumped) && n_jump >= 1;
                for (a = 0; a < 3; a++) /* the landing voxel lies outside the block or at a run's end */
                    longest += (jumped.cell[a] - last[a]) * jumped.step[a] > 0;
            } else if (ok) {
                ok = plain_ended;
            }
            if (!ok && bad++ < 5)
                fprintf(stderr, "grid %d ray %d h %d: jump %d (%d voxels)\n", gi, i, (int)h, more_jump, (int)n_jump);
        }
        mprt_grid_destroy(g);
    }
    CHECK_MSG(bad == 0, "%d of %d jumps differ from the plain walk", bad, jumps);
    /* every way out was exercised: walks ending in the block, leaving it,
     * and stopping short of it at the end of a run */
    CHECK(ended > 1000 && longest > 1000 && jumps - ended - longest > 1000);
    mprt_scene_destroy(s);
}

/* Sums of d from s made one by one and by runs: every run start gives
 * s + k inc equal to k rounded additions for every k it covers, including
 * exact ties (d an odd number of half ulps of s) and binade ends. */
static void test_runs_sum_as_the_walk_sums(void)
{
    rng r;
    int i, bad = 0, runs = 0, ties = 0, long_runs = 0;
    rng_seed(&r, 5);
    for (i = 0; i < 20000; i++) {
        real s = (real)ldexp(1 + rnd(&r), rnd_int(&r, -20, 20)), d, t;
        mprt__run run;
        int k;
        if (i % 4 == 0) { /* an exact tie: d = (q + 1/2) ulps of s */
            int e;
            double u;
            frexp((double)s, &e);
            u = ldexp(1.0, e - MPRT__MANT);
            d = (real)(((double)rnd_int(&r, 0, 1000) + 0.5) * u);
            ties++;
        } else {
            d = (real)((double)s * ldexp(rnd(&r), -rnd_int(&r, 0, 30)));
        }
        if (!(d > 0) || !mprt__run_start(s, d, &run)) continue;
        runs++;
        t = s;
        for (k = 1; k <= 5000 && s + (real)(k - 1) * run.inc <= run.last; k++) {
            t += d;
            if (t != s + (real)k * run.inc) {
                if (bad++ < 5)
                    fprintf(stderr, "s %a d %a: %d additions give %a, the run %a\n", (double)s, (double)d, k, (double)t,
                            (double)(s + (real)k * run.inc));
                break;
            }
        }
        long_runs += k > 100;
    }
    CHECK_MSG(bad == 0, "%d runs differ from the additions", bad);
    CHECK(runs > 10000 && ties > 1000 && long_runs > 1000);
}

/* The chessboard distance transform equals the brute-force minimum over the
 * cells holding 0 of the largest per-axis distance (255 when there are none). */
static void test_chessboard_distance_matches_brute_force(void)
{
    static const int dims[][3] = {{7, 5, 9}, {12, 12, 3}, {1, 1, 20}, {16, 1, 16}, {9, 9, 9}};
    rng r;
    int di, bad = 0;
    rng_seed(&r, 3);
    for (di = 0; di < 5; di++) {
        const int *n = dims[di];
        int count = n[0] * n[1] * n[2], v, w, trial;
        uint8_t *d = malloc((size_t)count), *ref = malloc((size_t)count);
        for (trial = 0; trial < 20; trial++) {
            int dens = rnd_int(&r, 0, 40); /* per mille of cells holding 0; trial 0 holds none */
            for (v = 0; v < count; v++) d[v] = trial > 0 && rnd_int(&r, 0, 999) < dens ? 0 : 255;
            if (trial == 1) d[count / 2] = 0;
            for (v = 0; v < count; v++) {
                int best = 255, c[3] = {v % n[0], v / n[0] % n[1], v / (n[0] * n[1])};
                for (w = 0; w < count; w++)
                    if (d[w] == 0) {
                        int o[3] = {w % n[0], w / n[0] % n[1], w / (n[0] * n[1])}, m = 0, a;
                        for (a = 0; a < 3; a++)
                            if (abs(o[a] - c[a]) > m) m = abs(o[a] - c[a]);
                        if (m < best) best = m;
                    }
                ref[v] = (uint8_t)best;
            }
            CHECK(mprt__chessboard_distance(n, d) == MPRT_OK);
            for (v = 0; v < count; v++) bad += d[v] != ref[v];
        }
        free(d);
        free(ref);
    }
    CHECK_MSG(bad == 0, "%d cells differ from brute force", bad);
}

/* The walk's inner loop reads the plain bits (grid.h): set exactly for the
 * voxels that are empty and no jump starts from, nothing past the last
 * voxel.  And mprt__dda_seek, which reads them, stops at the same voxels
 * with the same counts as a walk of mprt__dda_next that looks at each
 * voxel's list: with jumps off (the default), at MPRT_SKIP's threshold and
 * wherever the grid allows (MPRT_JUMP_MIN=2). */
static void test_seek_stops_where_the_lists_are(void)
{
    static const char *modes[][2] = {{"MPRT_NO_SKIP", ""}, {"MPRT_SKIP", "1"}, {"MPRT_JUMP_MIN", "2"}};
    static const int dims[][3] = {{8, 8, 8}, {13, 5, 9}, {1, 7, 30}, {40, 40, 40}, {65, 3, 2}};
    mprt_scene *s = corner_scene();
    rng r;
    int m, gi, i, bad_bits = 0, bad_walks = 0, stops = 0;
    rng_seed(&r, 11);
    for (m = 0; m < 3; m++) {
        setenv(modes[m][0], modes[m][1], 1);
        for (gi = 0; gi < 5; gi++) {
            mprt_grid *g = make_grid(s, dims[gi][0], dims[gi][1], dims[gi][2]);
            long long v, words = (g->voxels + 63) / 64;
            for (v = 0; v < words * 64; v++) {
                int bit = (int)(g->plain[v >> 6] >> (v & 63) & 1);
                int want = v < g->voxels && g->start[v + 1] == g->start[v] && g->empty[v] < g->jump_min;
                if (bit != want) bad_bits++;
            }
            for (i = 0; i < 400; i++) {
                mprt__ray ray;
                mprt__dda a, b;
                vec3 o, d;
                int32_t na = 1, nb = 1;
                int more_a, more_b;
                hard_ray(&r, g, &o, &d);
                mprt__ray_prepare(&ray, o, d);
                if (!mprt__dda_start(g, &ray, 0, (real)INFINITY, &a)) continue;
                b = a;
                do {
                    more_a = mprt__dda_seek(g, &a, &na);
                    more_b = 1;
                    while (g->start[b.voxel + 1] == g->start[b.voxel])
                        if (!mprt__dda_next(g, &b)) {
                            more_b = 0;
                            break;
                        } else {
                            nb++;
                        }
                    if (more_a != more_b || na != nb || (more_a && !same_state(&a, &b))) {
                        bad_walks++;
                        break;
                    }
                    stops += more_a;
                    if (more_a) {
                        more_a = mprt__dda_next(g, &a);
                        more_b = mprt__dda_next(g, &b);
                        na += more_a;
                        nb += more_b;
                    }
                } while (more_a && more_b);
            }
            mprt_grid_destroy(g);
        }
        unsetenv(modes[m][0]);
    }
    CHECK_MSG(bad_bits == 0, "%d plain bits wrong", bad_bits);
    CHECK_MSG(bad_walks == 0, "%d walks differ", bad_walks);
    CHECK(stops > 500); /* the rays meet the spheres' voxels */
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_a_jump_ends_where_the_plain_walk_leaves_the_block);
    RUN(test_runs_sum_as_the_walk_sums);
    RUN(test_chessboard_distance_matches_brute_force);
    RUN(test_seek_stops_where_the_lists_are);
    return CHECK_DONE();
}
