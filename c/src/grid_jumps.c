/* grid_jumps.c: the grid's empty space (grid.h, empty; grid.c makes the
 * lists).  The grid is split into macro cells of whole voxels, about cubic
 * in space (one voxel each on a grid of cubic voxels); each empty voxel
 * holds the chessboard distance from its macro cell to the nearest macro
 * cell with primitives, which lets the walk jump across the block of empty
 * macro cells around it (dda.h) with the same counts, when the environment
 * asks for jumps (mprt__grid_jump_threshold).
 *
 * The distance: the chessboard (L-infinity) distance in cells, capped at
 * 255, by two chamfer passes over the 26 neighbours with unit weights, the
 * first in raster order from the neighbours already visited, the second in
 * reverse.  This is exact for the chessboard metric: between any two cells
 * there is a shortest king's path whose steps go first forward then
 * backward in raster order (tests/c/test_skip.c compares it with brute
 * force; tests/c/grid_reference.c keeps the passes written plainly, which
 * test_grid_build.c compares with these). */
#include "grid.h"

#include <stdlib.h>
#include <string.h>

static unsigned min_u(unsigned a, unsigned b) { return a < b ? a : b; }

/* The two passes in few sweeps over memory, in loops of fixed length
 * that compilers vectorize: each row's 3-minimum along x is made once, when
 * the row is final, into a slice buffer (hc for this slice, hp the slice
 * before); a row's candidates are the 3-minimum across y of hp and the row
 * before's entry in hc; then the row is swept from the voxel just done. */
#define CHUNK 16

static void hmin3(const uint8_t *restrict r, uint8_t *restrict o, int n)
{
    size_t x = 1, k, m = (size_t)n - 1;
    if (n == 1) {
        o[0] = r[0];
        return;
    }
    o[0] = (uint8_t)min_u(r[0], r[1]);
    for (; x + CHUNK <= m; x += CHUNK) {
        const uint8_t *p = r + x;
        uint8_t *q = o + x;
        for (k = 0; k < CHUNK; k++) q[k] = (uint8_t)min_u(min_u(p[k - 1], p[k]), p[k + 1]);
    }
    for (; x < m; x++) o[x] = (uint8_t)min_u(min_u(r[x - 1], r[x]), r[x + 1]);
    o[m] = (uint8_t)min_u(r[m - 1], r[m]);
}

/* o = min(a, b, c) elementwise (rows may repeat at the borders) */
static void vmin3(const uint8_t *a, const uint8_t *b, const uint8_t *c, uint8_t *restrict o, int n)
{
    size_t x = 0, k;
    for (; x + CHUNK <= (size_t)n; x += CHUNK) {
        const uint8_t *pa = a + x, *pb = b + x, *pc = c + x;
        uint8_t *q = o + x;
        for (k = 0; k < CHUNK; k++) q[k] = (uint8_t)min_u(min_u(pa[k], pb[k]), pc[k]);
    }
    for (; x < (size_t)n; x++) o[x] = (uint8_t)min_u(min_u(a[x], b[x]), c[x]);
}

/* o = min(o, b) elementwise */
static void vmin2(uint8_t *restrict o, const uint8_t *restrict b, int n)
{
    size_t x = 0, k;
    for (; x + CHUNK <= (size_t)n; x += CHUNK) {
        const uint8_t *pb = b + x;
        uint8_t *q = o + x;
        for (k = 0; k < CHUNK; k++) q[k] = (uint8_t)min_u(q[k], pb[k]);
    }
    for (; x < (size_t)n; x++) o[x] = (uint8_t)min_u(o[x], b[x]);
}

/* cand = min(row, cand + 1) elementwise, then the sweep along the row */
static void sweep_row(uint8_t *restrict row, uint8_t *restrict cand, int n, int dir)
{
    size_t x = 0, k;
    unsigned left = 255;
    for (; x + CHUNK <= (size_t)n; x += CHUNK) {
        const uint8_t *r = row + x;
        uint8_t *c = cand + x;
        for (k = 0; k < CHUNK; k++) c[k] = (uint8_t)(c[k] < r[k] ? c[k] + 1 : r[k]);
    }
    for (; x < (size_t)n; x++) cand[x] = (uint8_t)(cand[x] < row[x] ? cand[x] + 1 : row[x]);
    if (dir > 0)
        for (x = 0; x < (size_t)n; x++) row[x] = (uint8_t)(left = min_u(cand[x], left + 1));
    else
        for (x = (size_t)n; x-- > 0;) row[x] = (uint8_t)(left = min_u(cand[x], left + 1));
}

static void chamfer_pass(const int n[3], uint8_t *d, uint8_t *h0, uint8_t *h1, uint8_t *cand, int dir)
{
    const int nx = n[0], ny = n[1], nz = n[2];
    const size_t slice = (size_t)nx * (size_t)ny;
    int j, k, y, z;
    for (k = 0; k < nz; k++) {
        uint8_t *cur, *hc = (k & 1) ? h1 : h0, *hp = (k & 1) ? h0 : h1;
        z = dir > 0 ? k : nz - 1 - k;
        cur = d + (size_t)z * slice;
        for (j = 0; j < ny; j++) {
            uint8_t *row;
            y = dir > 0 ? j : ny - 1 - j;
            row = cur + (size_t)y * (size_t)nx;
            if (k > 0) /* the 3x3 minimum of the slice before */
                vmin3(hp + (size_t)(y > 0 ? y - 1 : y) * (size_t)nx, hp + (size_t)y * (size_t)nx,
                      hp + (size_t)(y < ny - 1 ? y + 1 : y) * (size_t)nx, cand, nx);
            else
                memset(cand, 255, (size_t)nx);
            if (j > 0) { /* and the row before */
                const uint8_t *b = hc + (size_t)(y - dir) * (size_t)nx;
                vmin2(cand, b, nx);
            }
            sweep_row(row, cand, nx, dir);
            hmin3(row, hc + (size_t)y * (size_t)nx, nx);
        }
    }
}

int mprt__chessboard_distance(const int n[3], uint8_t *d)
{
    const size_t slice = (size_t)n[0] * (size_t)n[1];
    uint8_t *h = malloc(2 * slice), *cand = malloc((size_t)n[0]);
    if (!h || !cand) {
        free(h);
        free(cand);
        return MPRT_ERR_OUT_OF_MEMORY;
    }
    chamfer_pass(n, d, h, h + slice, cand, +1);
    chamfer_pass(n, d, h, h + slice, cand, -1);
    free(h);
    free(cand);
    return MPRT_OK;
}

/* Macro cells: m[a] voxels on axis a, the nearest whole number to the
 * largest voxel extent over this axis's extent, so that macro cells are
 * about cubic; macro_lo maps each voxel index to its macro cell's first. */
static int macro_cells(mprt_grid *g)
{
    real big = g->cell.x > g->cell.y ? g->cell.x : g->cell.y;
    int a, i, *lo;
    if (g->cell.z > big) big = g->cell.z;
    lo = malloc((size_t)(g->n[0] + g->n[1] + g->n[2]) * sizeof *lo);
    if (!lo) return MPRT_ERR_OUT_OF_MEMORY;
    for (a = 0; a < 3; a++) {
        real r = big / vget(g->cell, a) + R(0.5);
        g->macro[a] = r >= (real)g->n[a] ? g->n[a] : r < 1 ? 1 : (int)r;
        g->macro_lo[a] = lo;
        for (i = 0; i < g->n[a]; i++) lo[i] = i - i % g->macro[a];
        lo += g->n[a];
    }
    return MPRT_OK;
}

/* The jumps where every macro cell is one voxel: the distances are the
 * voxels' own, found in place in the empty flags, 255 for empty and 0 for a
 * voxel with primitives, then turned into empty values: d + 1 from 2 up (at
 * most 255), else as they were. */
static int mark_jumps_single(mprt_grid *g)
{
    uint8_t *e = g->empty;
    size_t v = 0, k, n = (size_t)g->voxels;
    for (; v + CHUNK <= n; v += CHUNK) {
        uint8_t *p = e + v;
        for (k = 0; k < CHUNK; k++) p[k] = p[k] ? 255 : 0;
    }
    for (; v < n; v++) e[v] = e[v] ? 255 : 0;
    if (mprt__chessboard_distance(g->n, e) != MPRT_OK) return MPRT_ERR_OUT_OF_MEMORY;
    for (v = 0; v + CHUNK <= n; v += CHUNK) {
        uint8_t *p = e + v;
        for (k = 0; k < CHUNK; k++) p[k] = (uint8_t)(p[k] < 2 ? p[k] : p[k] > 254 ? 255 : p[k] + 1);
    }
    for (; v < n; v++) e[v] = (uint8_t)(e[v] < 2 ? e[v] : e[v] > 254 ? 255 : e[v] + 1);
    return MPRT_OK;
}

/* The macro cells' distances (grid.h), given to the empty voxels each
 * contains.  A block that is a single voxel is not worth a jump: those
 * voxels stay at 1. */
int mprt__grid_mark_jumps(mprt_grid *g, mprt__distance_fn distance)
{
    int M[3], a, i, x, y, z, single;
    size_t *of[3] = {NULL, NULL, NULL}; /* per axis and voxel index: macro cell offset in md */
    uint8_t *md = NULL, *e = g->empty;
    int st = MPRT_ERR_OUT_OF_MEMORY;
    if (macro_cells(g) != MPRT_OK) return st;
    single = g->macro[0] == 1 && g->macro[1] == 1 && g->macro[2] == 1;
    if (single && !distance) return mark_jumps_single(g);
    if (!distance) distance = mprt__chessboard_distance;
    for (a = 0; a < 3; a++) M[a] = (g->n[a] + g->macro[a] - 1) / g->macro[a];
    md = malloc((size_t)M[0] * (size_t)M[1] * (size_t)M[2]);
    for (a = 0; a < 3; a++) of[a] = malloc((size_t)g->n[a] * sizeof *of[a]);
    if (!md || !of[0] || !of[1] || !of[2]) goto done;
    for (a = 0; a < 3; a++)
        for (i = 0; i < g->n[a]; i++)
            of[a][i] = (size_t)(i / g->macro[a]) * (a == 0 ? 1 : a == 1 ? (size_t)M[0] : (size_t)M[0] * (size_t)M[1]);
    memset(md, 255, (size_t)M[0] * (size_t)M[1] * (size_t)M[2]);
    /* a macro cell holds primitives when one of its voxels does */
    for (z = 0; z < g->n[2]; z++)
        for (y = 0; y < g->n[1]; y++)
            for (x = 0; x < g->n[0]; x++, e++)
                if (*e == 0) md[of[2][z] + of[1][y] + of[0][x]] = 0;
    if (distance(M, md) != MPRT_OK) goto done;
    /* distance d >= 1: the macro cells within d - 1 are empty; empty = d + 1 */
    e = g->empty;
    for (z = 0; z < g->n[2]; z++)
        for (y = 0; y < g->n[1]; y++)
            for (x = 0; x < g->n[0]; x++, e++) {
                unsigned d = md[of[2][z] + of[1][y] + of[0][x]];
                if (*e && d >= (single ? 2u : 1u)) *e = (uint8_t)(d > 254 ? 255 : d + 1);
            }
    st = MPRT_OK;
done:
    free(md);
    for (a = 0; a < 3; a++) free(of[a]);
    return st;
}

/* Empty values from which the walk jumps when asked to (MPRT_SKIP), and how
 * far from the ray's origin (in voxels) it must be: smaller blocks, and
 * jumps near the origin, cost more than the voxels they pass. */
#define DEFAULT_JUMP_MIN 16
#define DEFAULT_JUMP_FAR 8

/* Whether environment variable name is set to anything but "" or "0". */
static int env_on(const char *name)
{
    const char *v = getenv(name);
    return v && *v && strcmp(v, "0") != 0;
}

/* The jump threshold the environment asks for (grid.h).  By default the walk goes
 * voxel by voxel: jumps change no count, but at every grid studies/03_bench
 * measured they cost renders more time than the voxels they pass (a jump
 * sets up its runs afresh for every ray, and secondary rays' walks are
 * short).  MPRT_SKIP set (to anything but "" or "0") jumps from blocks of
 * empty value DEFAULT_JUMP_MIN and up, away from the ray's origin;
 * MPRT_JUMP_MIN=k (2..255) jumps from blocks of empty value k and up
 * wherever the walk is (the tests use 2, to jump wherever the grid allows);
 * MPRT_NO_SKIP set turns jumps off whatever the others say.  Read once per
 * grid, when it is made.  Returns MPRT_OK or fails the grid naming the
 * variable. */
int mprt__grid_jump_threshold(mprt_grid *g)
{
    const char *k = getenv("MPRT_JUMP_MIN");
    g->jump_min = 256;
    g->jump_far = 0;
    if (env_on("MPRT_NO_SKIP")) return MPRT_OK;
    if (k && *k) {
        char *end;
        long v = strtol(k, &end, 10);
        if (*end || v < 2 || v > 255)
            return mprt__grid_build_fail(g, MPRT_ERR_INVALID_ARG,
                                         "grid: environment MPRT_JUMP_MIN=%.40s is not a whole number in 2..255", k);
        g->jump_min = (unsigned)v;
    } else if (env_on("MPRT_SKIP")) {
        g->jump_min = DEFAULT_JUMP_MIN;
        g->jump_far = DEFAULT_JUMP_FAR;
    }
    return MPRT_OK;
}
