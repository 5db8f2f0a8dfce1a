/* grid.c: the uniform voxel grid over the scene's bounding box.
 *
 * Voxel data (the OS stage's database) is a compressed-sparse-row pair: for
 * voxel v, its primitive list is ids[start[v] .. start[v+1]); a voxel's flag
 * ("holds primitives") is start[v+1] > start[v].  A primitive is listed in
 * every voxel its surface may touch, by the primitives' conservative box
 * tests against the voxel box grown by a small relative margin, so that
 * rounding in the 3DDDA's voxel boundaries can never hide a primitive; or,
 * with MPRT_LIST_BOX, in every voxel its bounding box (so grown) touches,
 * and with MPRT_LIST_BOX_OUTWARD one voxel more on each axis's high side;
 * or, with MPRT_LIST_OCCUPIED, only in the voxels whose interior its surface
 * meets: the same tests against the voxel box shrunk by the margin, except
 * on an axis along which the primitive is flat (a polygon lying in a voxel
 * face is listed on both sides of it) or the voxels are too thin to shrink.
 * That listing leaves out voxels a primitive meets only on their boundary
 * (a corner, an edge, or a face it does not lie in); it is a study, not
 * watertight with the walk's acceptance rule (studies/08_grid_shape/listing.py).
 *
 * Empty space: the grid is also split into macro cells of whole voxels,
 * about cubic in space (one voxel each on a grid of cubic voxels), and each
 * empty voxel holds the chessboard distance from its macro cell to the
 * nearest macro cell with primitives (grid.h, empty), which lets the walk
 * jump across the block of empty macro cells around it (dda.h) with the
 * same counts, when the environment asks for jumps (jump_threshold).
 *
 * IC's copy of the primitives (ic.h) is made with the grid and counts
 * against its memory bound; mprt_grid_stats.bytes reports the voxel table
 * and lists alone, the grid as the paper's machine holds it. */
#include "grid.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_MAX_BYTES ((size_t)4 << 30)

int mprt__grid_fail(mprt_grid *g, int status, const char *fmt, ...)
{
    va_list ap;
    pthread_mutex_lock(&g->errlock);
    va_start(ap, fmt);
    mprt__vformat(g->errmsg, sizeof g->errmsg, fmt, ap);
    va_end(ap);
    pthread_mutex_unlock(&g->errlock);
    return status;
}

/* A failure while building: the grid is unusable. */
#define grid_fail(g, ...) ((g)->failed = 1, mprt__grid_fail((g), __VA_ARGS__))

const char *mprt_grid_errmsg(const mprt_grid *g) { return g ? g->errmsg : "no grid"; }

void mprt_grid_destroy(mprt_grid *g)
{
    if (!g) return;
    if (g->counted) mprt__scene_count_grid(g->scene, -1);
    free(g->start);
    free(g->empty);
    free(g->plain);
    free(g->macro_lo[0]);
    free(g->ids);
    free(g->ic.ref);
    free(g->ic.ball);
    free(g->ic.tri);
    mprt__ic_pack_free(&g->pack);
    pthread_mutex_destroy(&g->errlock);
    free(g);
}

/* Surface of primitive i may touch the box [lo, hi]: 1 yes, 0 no, -1 for a
 * primitive of unknown kind. */
static int prim_box(const mprt_scene *s, long long i, vec3 lo, vec3 hi)
{
    const mprt__prim *p = &s->prims[i];
    switch (p->kind) {
    case MPRT_SPHERE: return mprt__sphere_box(&s->spheres[p->index], lo, hi);
    case MPRT_POLYGON: return mprt__polygon_box(&s->polygons[p->index], s->verts, lo, hi);
    case MPRT_CYLINDER:
    case MPRT_CONE: return mprt__cone_box(&s->cones[p->index], lo, hi);
    default: return -1;
    }
}

static int clampi(long long v, int n) { return v < 0 ? 0 : v >= n ? n - 1 : (int)v; }

/* Voxel index along one axis of coordinate x (clamped into the grid). */
static int axis_cell(const mprt_grid *g, int a, real x)
{
    real f = (x - vget(g->lo, a)) * vget(g->inv_cell, a);
    if (!(f > 0)) return 0;
    if (f >= (real)g->n[a]) return g->n[a] - 1;
    return clampi((long long)f, g->n[a]);
}

vec3 mprt__grid_voxel_lo(const mprt_grid *g, int i, int j, int k)
{
    return v3(g->lo.x + (real)i * g->cell.x, g->lo.y + (real)j * g->cell.y, g->lo.z + (real)k * g->cell.z);
}

/* ---- Distance to the nearest voxel with primitives -------------------------
 * The chessboard (L-infinity) distance in voxels, capped at 255: two chamfer
 * passes over the 26 neighbours with unit weights, the first in raster
 * order from the neighbours already visited, the second in reverse.  This
 * is exact for the chessboard metric: between any two voxels there is a
 * shortest king's path whose steps go first forward then backward in
 * raster order (tests/c/test_skip.c compares it with brute force). */

static unsigned min_u(unsigned a, unsigned b) { return a < b ? a : b; }

/* o[x] = the minimum of r over x - 1 .. x + 1 (within 0 .. n - 1). */
static void min3_row(const uint8_t *r, uint8_t *o, int n)
{
    int x;
    if (n == 1) {
        o[0] = r[0];
        return;
    }
    o[0] = (uint8_t)min_u(r[0], r[1]);
    for (x = 1; x < n - 1; x++) o[x] = (uint8_t)min_u(min_u(r[x - 1], r[x]), r[x + 1]);
    o[n - 1] = (uint8_t)min_u(r[n - 2], r[n - 1]);
}

/* One pass: dir +1 forward, -1 backward.  Scratch: p3, n[0] * n[1] bytes
 * (the 3x3 minimum of the slice before), and cand, 2 n[0] bytes. */
static void chamfer_pass(const int n[3], uint8_t *d, uint8_t *p3, uint8_t *cand, int dir)
{
    const int nx = n[0], ny = n[1], nz = n[2];
    const size_t slice = (size_t)nx * (size_t)ny;
    uint8_t *rowmin = cand + nx;
    int i, j, k, x, y, z;
    for (k = 0; k < nz; k++) {
        uint8_t *cur;
        int have_prev;
        z = dir > 0 ? k : nz - 1 - k;
        cur = d + (size_t)z * slice;
        have_prev = dir > 0 ? z > 0 : z < nz - 1;
        if (have_prev) {
            /* p3: the 3x3 minimum, across x then y, of the slice before */
            const uint8_t *prev = d + (size_t)(z - dir) * slice;
            for (y = 0; y < ny; y++) min3_row(prev + (size_t)y * (size_t)nx, p3 + (size_t)y * (size_t)nx, nx);
            /* across y row by row, keeping the row above as it was (in cand) */
            for (y = 0; y < ny; y++) {
                uint8_t *o = p3 + (size_t)y * (size_t)nx;
                const uint8_t *below = y < ny - 1 ? o + nx : o;
                for (x = 0; x < nx; x++) {
                    unsigned here = o[x], m = min_u(here, below[x]);
                    if (y > 0) m = min_u(m, cand[x]);
                    cand[x] = (uint8_t)here;
                    o[x] = (uint8_t)m;
                }
            }
        }
        for (j = 0; j < ny; j++) {
            uint8_t *row;
            unsigned left = 255;
            y = dir > 0 ? j : ny - 1 - j;
            row = cur + (size_t)y * (size_t)nx;
            /* the neighbours in the slice before and the row before */
            if (have_prev) memcpy(cand, p3 + (size_t)y * (size_t)nx, (size_t)nx);
            else memset(cand, 255, (size_t)nx);
            if (dir > 0 ? y > 0 : y < ny - 1) {
                min3_row(row - (ptrdiff_t)dir * nx, rowmin, nx);
                for (x = 0; x < nx; x++) cand[x] = (uint8_t)min_u(cand[x], rowmin[x]);
            }
            /* then along the row, from the voxel just done */
            for (i = 0; i < nx; i++) {
                unsigned m, v;
                x = dir > 0 ? i : nx - 1 - i;
                m = min_u(cand[x], left);
                v = min_u(row[x], m + 1);
                row[x] = (uint8_t)v;
                left = v;
            }
        }
    }
}

/* The two passes above: kept as the reference for mprt__chessboard_distance. */
static int chessboard_reference(const int n[3], uint8_t *d)
{
    uint8_t *p3 = malloc((size_t)n[0] * (size_t)n[1]), *cand = malloc(2 * (size_t)n[0]);
    if (!p3 || !cand) {
        free(p3);
        free(cand);
        return MPRT_ERR_OUT_OF_MEMORY;
    }
    chamfer_pass(n, d, p3, cand, +1);
    chamfer_pass(n, d, p3, cand, -1);
    free(p3);
    free(cand);
    return MPRT_OK;
}

/* The same passes in fewer sweeps over memory, in loops of fixed length
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

static void chamfer_pass_fast(const int n[3], uint8_t *d, uint8_t *h0, uint8_t *h1, uint8_t *cand, int dir)
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
    chamfer_pass_fast(n, d, h, h + slice, cand, +1);
    chamfer_pass_fast(n, d, h, h + slice, cand, -1);
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

/* Mark the voxels the walk may jump from (empty values 2 and up): the
 * chessboard distance of each macro cell to the nearest one holding
 * primitives, given to the empty voxels it contains.  A block that is a
 * single voxel is not worth a jump: those voxels stay at 1. */
static int mark_jumps_single(mprt_grid *g);

static int mark_jumps(mprt_grid *g, int reference)
{
    int M[3], a, i, x, y, z, single;
    size_t *of[3] = {NULL, NULL, NULL}; /* per axis and voxel index: macro cell offset in md */
    uint8_t *md = NULL, *e = g->empty;
    int st = MPRT_ERR_OUT_OF_MEMORY;
    if (macro_cells(g) != MPRT_OK) return st;
    single = g->macro[0] == 1 && g->macro[1] == 1 && g->macro[2] == 1;
    if (single && !reference) return mark_jumps_single(g);
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
    if ((reference ? chessboard_reference(M, md) : mprt__chessboard_distance(M, md)) != MPRT_OK) goto done;
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

/* mark_jumps where every macro cell is one voxel (the reference is
 * mark_jumps(g, 1)): the distances are the voxels' own, found in place in
 * the empty flags, 255 for empty and 0 for a voxel with primitives, then
 * turned into empty values: d + 1 from 2 up (at most 255), else as they were. */
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

/* (voxel, primitive) pairs, filled while testing, then sorted by voxel. */
typedef struct {
    uint32_t *vox;
    int32_t *prim;
    size_t n, cap;
} pairs;

static int pairs_push(pairs *p, uint32_t v, int32_t id, size_t limit)
{
    if (p->n == p->cap) {
        size_t nc = p->cap ? p->cap * 2 : 1024;
        uint32_t *a;
        int32_t *b;
        if (nc > limit) nc = limit;
        if (nc <= p->n) return -1;
        a = realloc(p->vox, nc * sizeof *a);
        if (!a) return -1;
        p->vox = a;
        b = realloc(p->prim, nc * sizeof *b);
        if (!b) return -1;
        p->prim = b;
        p->cap = nc;
    }
    p->vox[p->n] = v;
    p->prim[p->n] = id;
    p->n++;
    return 0;
}

/* The voxel range primitive i's bounds touch, grown by the margin (on
 * MPRT_LIST_BOX_OUTWARD one voxel more on each axis's high side); and per
 * axis whether its voxel boxes shrink by the margin (MPRT_LIST_OCCUPIED, on
 * an axis along which the primitive is thicker than twice the margin and
 * the voxels thicker than four times it) or grow by it (otherwise). */
static int prim_range(mprt_grid *g, long long i, int a0[3], int a1[3], int shrink[3])
{
    const mprt_scene *s = g->scene;
    vec3 blo, bhi;
    int a;
    if (mprt__prim_bounds(s, i, &blo, &bhi) != MPRT_OK)
        return grid_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, i, s->prims[i].kind);
    for (a = 0; a < 3; a++) {
        a0[a] = axis_cell(g, a, vget(blo, a) - g->pad);
        a1[a] = axis_cell(g, a, vget(bhi, a) + g->pad);
        if (g->listing == MPRT_LIST_BOX_OUTWARD && a1[a] < g->n[a] - 1) a1[a]++;
        shrink[a] = g->listing == MPRT_LIST_OCCUPIED && vget(bhi, a) - vget(blo, a) > 2 * g->pad &&
                    vget(g->cell, a) > 4 * g->pad;
    }
    return MPRT_OK;
}

/* Whether the listing tests each primitive's surface against the voxels
 * (else every voxel of its bounds' range lists it). */
static int listing_tests(const mprt_grid *g)
{
    return g->listing == MPRT_LIST_EXACT || g->listing == MPRT_LIST_OCCUPIED;
}

static int push(mprt_grid *g, pairs *P, int x, int y, int z, long long i, size_t pair_limit, size_t max_bytes)
{
    if (!pairs_push(P, (uint32_t)(((long long)z * g->n[1] + y) * g->n[0] + x), (int32_t)i, pair_limit))
        return MPRT_OK;
    return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                     "grid %dx%dx%d: the primitive lists exceed the %zu bytes allowed "
                     "(or memory ran out) at primitive %lld",
                     g->n[0], g->n[1], g->n[2], max_bytes, i);
}

/* The (voxel, primitive) pairs, voxel by voxel as the paper's build would:
 * kept as the reference the faster list_fast is tested against
 * (mprt__grid_create_reference, tests/c/test_grid_build.c). */
static int list_reference(mprt_grid *g, pairs *P, size_t pair_limit, size_t max_bytes)
{
    const mprt_scene *s = g->scene;
    const real margin = g->pad;
    long long i;
    int st;
    for (i = 0; i < s->nprims; i++) {
        int a0[3], a1[3], shrink[3], x, y, z;
        real m[3];
        if ((st = prim_range(g, i, a0, a1, shrink)) != MPRT_OK) return st;
        for (x = 0; x < 3; x++) m[x] = shrink[x] ? -margin : margin;
        for (z = a0[2]; z <= a1[2]; z++)
            for (y = a0[1]; y <= a1[1]; y++)
                for (x = a0[0]; x <= a1[0]; x++) {
                    vec3 lo = mprt__grid_voxel_lo(g, x, y, z);
                    vec3 hi = mprt__grid_voxel_lo(g, x + 1, y + 1, z + 1);
                    lo = v3(lo.x - m[0], lo.y - m[1], lo.z - m[2]);
                    hi = v3(hi.x + m[0], hi.y + m[1], hi.z + m[2]);
                    int touch = !listing_tests(g) ? 1 : prim_box(s, i, lo, hi);
                    if (touch < 0)
                        return grid_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, i, s->prims[i].kind);
                    if (touch && (st = push(g, P, x, y, z, i, pair_limit, max_bytes)) != MPRT_OK) return st;
                }
    }
    return MPRT_OK;
}

/* The same pairs as list_reference, bit for bit, for less work: the voxel
 * boxes (grown by the margin) come from per-axis tables computed with the
 * same arithmetic, and polygons are tested column by column (x outermost)
 * through mprt__polybox, which clips each polygon to a column's x slab
 * once.  The order of a primitive's own pairs does not matter: the counting
 * sort keeps primitives in id order within each voxel. */
static int list_fast(mprt_grid *g, pairs *P, size_t pair_limit, size_t max_bytes)
{
    const mprt_scene *s = g->scene;
    const real margin = g->pad;
    real *tab, *vlo[3], *vhi[3], *vmag[3], *tlo[2][3], *thi[2][3], *tmag[2][3];
    mprt__polybox pb;
    long long i;
    int a, k, j, st = MPRT_OK;
    const size_t per = (size_t)(g->n[0] + g->n[1] + g->n[2]);
    /* per axis the voxel bounds grown by the margin (tables 0) and, for
     * MPRT_LIST_OCCUPIED, shrunk by it (tables 1), with their magnitudes */
    tab = malloc(6 * per * sizeof *tab);
    if (!tab) return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the voxel bounds");
    memset(&pb, 0, sizeof pb);
    for (j = 0; j < 2; j++)
        for (a = 0; a < 3; a++) {
            const real lo = vget(g->lo, a), cell = vget(g->cell, a), m = j ? -margin : margin;
            tlo[j][a] = a == 0 ? tab + 3 * per * (size_t)j : tmag[j][a - 1] + g->n[a - 1];
            thi[j][a] = tlo[j][a] + g->n[a];
            tmag[j][a] = thi[j][a] + g->n[a];
            for (k = 0; k < g->n[a]; k++) {
                real l = lo + (real)k * cell, h = lo + (real)(k + 1) * cell, al, ah;
                tlo[j][a][k] = l - m;
                thi[j][a][k] = h + m;
                al = ABS(tlo[j][a][k]);
                ah = ABS(thi[j][a][k]);
                tmag[j][a][k] = al > ah ? al : ah;
            }
        }
    for (i = 0; i < s->nprims && st == MPRT_OK; i++) {
        const mprt__prim *p = &s->prims[i];
        mprt__cone_extent cx;
        real smag = 0;
        int a0[3], a1[3], shrink[3], x, y, z;
        if ((st = prim_range(g, i, a0, a1, shrink)) != MPRT_OK) break;
        for (a = 0; a < 3; a++) {
            vlo[a] = tlo[shrink[a]][a];
            vhi[a] = thi[shrink[a]][a];
            vmag[a] = tmag[shrink[a]][a];
        }
        if (p->kind == MPRT_POLYGON && listing_tests(g)) {
            mprt__polybox_set(&pb, &s->polygons[p->index], s->verts);
            for (x = a0[0]; x <= a1[0] && st == MPRT_OK; x++)
                for (y = a0[1]; y <= a1[1] && st == MPRT_OK; y++) {
                    real mxy = vmag[0][x] > vmag[1][y] ? vmag[0][x] : vmag[1][y];
                    for (z = a0[2]; z <= a1[2]; z++) {
                        int touch = mprt__polybox_test(&pb, v3(vlo[0][x], vlo[1][y], vlo[2][z]),
                                                       v3(vhi[0][x], vhi[1][y], vhi[2][z]),
                                                       mxy > vmag[2][z] ? mxy : vmag[2][z]);
                        if (touch < 0) {
                            st = grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory clipping polygon %lld", i);
                            break;
                        }
                        if (touch && (st = push(g, P, x, y, z, i, pair_limit, max_bytes)) != MPRT_OK) break;
                    }
                }
            continue;
        }
        if (listing_tests(g) && p->kind == MPRT_SPHERE) smag = vmaxabs(s->spheres[p->index].c);
        if (listing_tests(g) && (p->kind == MPRT_CYLINDER || p->kind == MPRT_CONE))
            mprt__cone_box_prepare(&s->cones[p->index], &cx);
        for (z = a0[2]; z <= a1[2] && st == MPRT_OK; z++)
            for (y = a0[1]; y <= a1[1] && st == MPRT_OK; y++)
                for (x = a0[0]; x <= a1[0]; x++) {
                    const vec3 lo = v3(vlo[0][x], vlo[1][y], vlo[2][z]), hi = v3(vhi[0][x], vhi[1][y], vhi[2][z]);
                    real m = vmag[0][x] > vmag[1][y] ? vmag[0][x] : vmag[1][y];
                    int touch;
                    if (vmag[2][z] > m) m = vmag[2][z];
                    if (!listing_tests(g)) touch = 1;
                    else if (p->kind == MPRT_SPHERE) touch = mprt__sphere_box_with(&s->spheres[p->index], lo, hi, m, smag);
                    else if (p->kind == MPRT_CYLINDER || p->kind == MPRT_CONE)
                        touch = mprt__cone_box_with(&s->cones[p->index], &cx, lo, hi, m);
                    else touch = prim_box(s, i, lo, hi);
                    if (touch < 0) {
                        st = grid_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, i, s->prims[i].kind);
                        break;
                    }
                    if (touch && (st = push(g, P, x, y, z, i, pair_limit, max_bytes)) != MPRT_OK) break;
                }
    }
    mprt__polybox_free(&pb);
    free(tab);
    return st;
}

/* Bytes of IC's copy of the primitives (ic.h). */
static size_t ic_bytes(const mprt_scene *s, long long *ntri)
{
    long long i;
    *ntri = 0;
    for (i = 0; i < s->npolygons; i++) *ntri += s->polygons[i].n == 3;
    return (size_t)s->nprims * (sizeof(uint32_t) + sizeof(mprt__ball)) + (size_t)*ntri * sizeof(mprt__tri);
}

/* IC's copy of the primitives: per id its kind and index, its ball, and
 * the triangles' records, from the scene's values as they are. */
static int build_ic(mprt_grid *g, long long ntri)
{
    const mprt_scene *s = g->scene;
    mprt__ic *ic = &g->ic;
    long long i;
    if ((unsigned long long)s->nprims >= MPRT__IC_MAX_INDEX)
        return grid_fail(g, MPRT_ERR_INVALID_ARG, "grid: %lld primitives, more than IC can index (%lu)", s->nprims,
                         (unsigned long)MPRT__IC_MAX_INDEX - 1);
    ic->ref = malloc((size_t)s->nprims * sizeof *ic->ref);
    ic->ball = calloc((size_t)s->nprims, sizeof *ic->ball);
    ic->tri = malloc((size_t)(ntri ? ntri : 1) * sizeof *ic->tri);
    if (!ic->ref || !ic->ball || !ic->tri)
        return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the intersection data of %lld primitives",
                         s->nprims);
    for (i = 0; i < s->nprims; i++) {
        const mprt__prim *p = &s->prims[i];
        uint32_t kind, index = (uint32_t)p->index;
        switch (p->kind) {
        case MPRT_SPHERE:
            kind = MPRT__IC_SPHERE;
            ic->ball[i].c = s->spheres[p->index].c;
            ic->ball[i].r2 = s->spheres[p->index].r * s->spheres[p->index].r;
            break;
        case MPRT_POLYGON: {
            const mprt__polygon *q = &s->polygons[p->index];
            kind = MPRT__IC_POLYGON;
            if (q->n == 3) {
                mprt__tri *t = &ic->tri[ic->ntri];
                kind = MPRT__IC_TRIANGLE;
                index = (uint32_t)ic->ntri++;
                t->v[0] = s->verts[q->first];
                t->v[1] = s->verts[q->first + 1];
                t->v[2] = s->verts[q->first + 2];
                t->normal = q->normal;
                t->d = q->d;
            }
            break;
        }
        default: /* MPRT_CYLINDER, MPRT_CONE (build checked the kinds) */
            kind = p->kind == MPRT_CYLINDER ? MPRT__IC_CYLINDER : MPRT__IC_CONE;
            mprt__cone_ball(&s->cones[p->index], &ic->ball[i]);
            break;
        }
        ic->ref[i] = index << MPRT__IC_KIND_BITS | kind;
    }
    return MPRT_OK;
}

/* The lists in voxel order (a counting sort: primitives stay in id order
 * within a voxel), the empty flags and the jumps, the plain way: kept as the
 * reference for sort_fast. */
static int sort_reference(mprt_grid *g, const pairs *P)
{
    const long long nvox = g->voxels;
    uint32_t *count;
    long long i;
    for (i = 0; i < (long long)P->n; i++) g->start[P->vox[i] + 1]++;
    for (i = 0; i < nvox; i++) g->start[i + 1] += g->start[i];
    g->ids = malloc((P->n ? P->n : 1) * sizeof *g->ids);
    count = malloc((size_t)nvox * sizeof *count);
    if (!g->ids || !count) {
        free(count);
        return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory sorting %zu list entries", P->n);
    }
    memcpy(count, g->start, (size_t)nvox * sizeof *count);
    for (i = 0; i < (long long)P->n; i++) g->ids[count[P->vox[i]]++] = P->prim[i];
    free(count);
    g->refs = (long long)P->n;
    g->empty = malloc((size_t)nvox);
    if (!g->empty) return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %lld voxel flags", nvox);
    for (i = 0; i < nvox; i++) g->empty[i] = g->start[i + 1] > g->start[i] ? 0 : 1;
    if (g->jump_min <= 255 && mark_jumps(g, 1) != MPRT_OK)
        return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the macro cells of %lld voxels", nvox);
    return MPRT_OK;
}

/* sort_reference's result in fewer passes over the voxels: voxel v's count
 * goes to start[v + 2] (start has voxels + 2 entries), so that after the
 * prefix sum start[v + 1] is where v's list begins and, once the entries are
 * placed, where it ends, with no cursor array; the empty flags come with
 * the prefix sum; and on a grid of single-voxel macro cells the distance
 * transform runs in place on the flags (mark_jumps). */
static int sort_fast(mprt_grid *g, const pairs *P)
{
    const long long nvox = g->voxels;
    uint32_t *start = g->start, sum = 0;
    uint8_t *e;
    long long i;
    g->ids = malloc((P->n ? P->n : 1) * sizeof *g->ids);
    if (!g->ids) return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory sorting %zu list entries", P->n);
    g->empty = e = malloc((size_t)nvox);
    if (!e) return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %lld voxel flags", nvox);
    for (i = 0; i < (long long)P->n; i++) start[P->vox[i] + 2]++;
    for (i = 0; i < nvox; i++) {
        uint32_t c = start[i + 2];
        e[i] = c == 0;
        start[i + 1] = sum;
        sum += c;
    }
    start[nvox + 1] = 0;
    for (i = 0; i < (long long)P->n; i++) g->ids[start[P->vox[i] + 1]++] = P->prim[i];
    g->refs = (long long)P->n;
    if (g->jump_min <= 255 && mark_jumps(g, 0) != MPRT_OK)
        return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the macro cells of %lld voxels", nvox);
    return MPRT_OK;
}

static int build(mprt_grid *g, size_t max_bytes, int reference)
{
    const mprt_scene *s = g->scene;
    long long nvox = g->voxels;
    pairs P = {NULL, NULL, 0, 0};
    size_t pair_limit, fixed;
    long long ntri;
    int st = MPRT_OK;

    fixed = (size_t)(nvox + 1) * sizeof *g->start + (size_t)nvox + (size_t)(nvox + 63) / 64 * 8 + ic_bytes(s, &ntri);
    if (fixed > max_bytes)
        return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                         "grid %dx%dx%d needs %zu bytes for its voxel table and intersection data alone, more "
                         "than the %zu allowed",
                         g->n[0], g->n[1], g->n[2], fixed, max_bytes);
    /* Pairs cost 8 bytes while building and 4 in the final list. */
    pair_limit = (max_bytes - fixed) / 8;
    g->start = calloc((size_t)nvox + 2, sizeof *g->start); /* + 1 for sort_fast */
    if (!g->start) return grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory allocating %zu bytes of voxel table", fixed);

    /* Margin: a few thousand ulps of the scene's extent. */
    g->pad = (real)(vmaxabs(vsub(g->hi, g->lo)) + vmaxabs(g->lo) + vmaxabs(g->hi)) * REAL_EPS * R(4096);

    st = reference ? list_reference(g, &P, pair_limit, max_bytes) : list_fast(g, &P, pair_limit, max_bytes);
    if (st != MPRT_OK) goto done;
    if (P.n > 0xffffffffu) {
        st = grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "grid: %zu list entries exceed 2^32", P.n);
        goto done;
    }

    st = reference ? sort_reference(g, &P) : sort_fast(g, &P);
    if (st != MPRT_OK) goto done;
    if (mprt__dda_plain(g) != MPRT_OK) {
        st = grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the walk's bits of %lld voxels", nvox);
        goto done;
    }
    st = build_ic(g, ntri);

done:
    free(P.vox);
    free(P.prim);
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

/* The jump threshold the environment asks for.  By default the walk goes
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
static int jump_threshold(mprt_grid *g)
{
    const char *k = getenv("MPRT_JUMP_MIN");
    g->jump_min = 256;
    g->jump_far = 0;
    if (env_on("MPRT_NO_SKIP")) return MPRT_OK;
    if (k && *k) {
        char *end;
        long v = strtol(k, &end, 10);
        if (*end || v < 2 || v > 255)
            return grid_fail(g, MPRT_ERR_INVALID_ARG, "grid: environment MPRT_JUMP_MIN=%.40s is not a whole number in 2..255", k);
        g->jump_min = (unsigned)v;
    } else if (env_on("MPRT_SKIP")) {
        g->jump_min = DEFAULT_JUMP_MIN;
        g->jump_far = DEFAULT_JUMP_FAR;
    }
    return MPRT_OK;
}

int mprt_grid_create(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, mprt_grid **out)
{
    return mprt_grid_create_listing(s, nx, ny, nz, max_bytes, MPRT_LIST_EXACT, out);
}

static int create(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing, int reference,
                  mprt_grid **out)
{
    mprt_grid *g;
    long long bad;
    int a, st;
    real ext;
    if (!out) return MPRT_ERR_INVALID_ARG;
    *out = NULL;
    g = calloc(1, sizeof *g);
    if (!g) return MPRT_ERR_OUT_OF_MEMORY;
    if (pthread_mutex_init(&g->errlock, NULL) != 0) {
        free(g);
        return MPRT_ERR_OUT_OF_MEMORY;
    }
    *out = g;
    g->scene = s;
    if (!s) return grid_fail(g, MPRT_ERR_INVALID_ARG, "grid: no scene");
    if (listing != MPRT_LIST_EXACT && listing != MPRT_LIST_BOX && listing != MPRT_LIST_BOX_OUTWARD &&
        listing != MPRT_LIST_OCCUPIED)
        return grid_fail(g, MPRT_ERR_INVALID_ARG,
                         "grid: unknown listing %d (0 exact, 1 box, 2 box_outward, 3 occupied)", listing);
    g->listing = listing;
    if (nx < 1 || ny < 1 || nz < 1 || nx > 1024 || ny > 1024 || nz > 1024)
        return grid_fail(g, MPRT_ERR_INVALID_ARG, "grid: subdivision %dx%dx%d is not in 1..1024 per axis", nx, ny, nz);
    if (s->nprims == 0 && s->dropped > 0)
        return grid_fail(g, MPRT_ERR_STATE, "grid: the scene has no primitives: %lld %s dropped while reading it (%s%s)",
                         s->dropped, s->dropped == 1 ? "was" : "were", s->dropped == 1 ? "" : "the first: ", s->warning);
    if (s->nprims == 0) return grid_fail(g, MPRT_ERR_STATE, "grid: the scene has no primitives");
    g->n[0] = nx;
    g->n[1] = ny;
    g->n[2] = nz;
    g->voxels = (long long)nx * ny * nz;
    if (mprt__scene_bounds(s, &g->lo, &g->hi, &bad) != MPRT_OK)
        return grid_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, bad, s->prims[bad].kind);
    /* A flat scene still needs a box of some thickness on every axis. */
    ext = vmaxabs(vsub(g->hi, g->lo));
    if (ext == 0) ext = vmaxabs(g->lo) > 0 ? vmaxabs(g->lo) : 1;
    for (a = 0; a < 3; a++) {
        real lo = vget(g->lo, a), hi = vget(g->hi, a);
        if (hi - lo < ext * R(1e-6)) {
            lo -= ext * R(1e-6);
            hi += ext * R(1e-6);
        }
        if (a == 0) { g->lo.x = lo; g->hi.x = hi; }
        if (a == 1) { g->lo.y = lo; g->hi.y = hi; }
        if (a == 2) { g->lo.z = lo; g->hi.z = hi; }
    }
    g->cell = v3((g->hi.x - g->lo.x) / (real)nx, (g->hi.y - g->lo.y) / (real)ny, (g->hi.z - g->lo.z) / (real)nz);
    g->inv_cell = v3(1 / g->cell.x, 1 / g->cell.y, 1 / g->cell.z);
    if ((st = jump_threshold(g)) != MPRT_OK) return st;
    st = build(g, max_bytes ? max_bytes : DEFAULT_MAX_BYTES, reference);
    if (st == MPRT_OK) {
        mprt__ic_pack_choose(g);
        /* The scene now refuses changes until this grid is destroyed */
        mprt__scene_count_grid(s, +1);
        g->counted = 1;
    }
    return st;
}

int mprt_grid_create_listing(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing,
                             mprt_grid **out)
{
    return create(s, nx, ny, nz, max_bytes, listing, 0, out);
}

int mprt__grid_create_reference(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing,
                                mprt_grid **out)
{
    return create(s, nx, ny, nz, max_bytes, listing, 1, out);
}

int mprt_grid_get_stats(const mprt_grid *g, mprt_grid_stats *st)
{
    long long v;
    if (!g || !st) return MPRT_ERR_INVALID_ARG;
    if (g->failed) return MPRT_ERR_STATE;
    memset(st, 0, sizeof *st);
    st->n[0] = g->n[0];
    st->n[1] = g->n[1];
    st->n[2] = g->n[2];
    st->voxels = g->voxels;
    st->refs = g->refs;
    for (v = 0; v < g->voxels; v++) {
        long long len = (long long)(g->start[v + 1] - g->start[v]);
        if (len) st->nonempty++;
        if (len > st->max_len) st->max_len = len;
        if (g->empty[v] >= g->jump_min) st->jump_voxels++;
    }
    st->mean_len = st->nonempty ? (double)st->refs / (double)st->nonempty : 0;
    st->bytes = (long long)((g->voxels + 1) * (long long)sizeof *g->start + g->voxels + (g->voxels + 63) / 64 * 8 +
                            g->refs * (long long)sizeof *g->ids +
                            (g->macro_lo[0] ? (long long)(g->n[0] + g->n[1] + g->n[2]) * (long long)sizeof(int) : 0));
    st->lo[0] = g->lo.x; st->lo[1] = g->lo.y; st->lo[2] = g->lo.z;
    st->hi[0] = g->hi.x; st->hi[1] = g->hi.y; st->hi[2] = g->hi.z;
    st->listing = g->listing;
    return MPRT_OK;
}

int mprt_grid_get_lists(const mprt_grid *g, uint32_t *start, size_t cap_start, int32_t *ids, size_t cap_ids)
{
    if (!g || !start || (!ids && g->refs)) return MPRT_ERR_INVALID_ARG;
    if (g->failed) return MPRT_ERR_STATE;
    if (cap_start < (size_t)g->voxels + 1 || cap_ids < (size_t)g->refs) return MPRT_ERR_CAPACITY;
    memcpy(start, g->start, ((size_t)g->voxels + 1) * sizeof *start);
    if (g->refs) memcpy(ids, g->ids, (size_t)g->refs * sizeof *ids);
    return MPRT_OK;
}
