/* grid_reference.c: the stages of a grid's build (grid.h, mprt__grid_stages)
 * written the plain way, the reference the library's faster ones
 * (grid.c, grid_jumps.c) must match bit for bit: the pairs found voxel by
 * voxel, each voxel's box tested with the primitive's own box test, as the
 * paper's build would; the lists sorted with a cursor array; and the
 * chessboard distance by two chamfer passes, the first in raster order
 * from the neighbours already visited, the second in reverse, one voxel at
 * a time. */
#include "grid_reference.h"

#include <stdlib.h>
#include <string.h>

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

/* mprt__chessboard_distance by the two passes above. */
static int chessboard_plain(const int n[3], uint8_t *d)
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

/* The (voxel, primitive) pairs, voxel by voxel. */
static int list_plain(mprt_grid *g, mprt__pairs *P, size_t pair_limit, size_t max_bytes)
{
    const mprt_scene *s = g->scene;
    const real margin = g->pad;
    long long i;
    int st;
    for (i = 0; i < s->nprims; i++) {
        int a0[3], a1[3], shrink[3], x, y, z;
        real m[3];
        if ((st = mprt__grid_prim_range(g, i, a0, a1, shrink)) != MPRT_OK) return st;
        for (x = 0; x < 3; x++) m[x] = shrink[x] ? -margin : margin;
        for (z = a0[2]; z <= a1[2]; z++)
            for (y = a0[1]; y <= a1[1]; y++)
                for (x = a0[0]; x <= a1[0]; x++) {
                    vec3 lo = mprt__grid_voxel_lo(g, x, y, z);
                    vec3 hi = mprt__grid_voxel_lo(g, x + 1, y + 1, z + 1);
                    int touch;
                    lo = v3(lo.x - m[0], lo.y - m[1], lo.z - m[2]);
                    hi = v3(hi.x + m[0], hi.y + m[1], hi.z + m[2]);
                    touch = !mprt__grid_listing_tests(g) ? 1 : mprt__grid_prim_box(s, i, lo, hi);
                    if (touch < 0)
                        return mprt__grid_build_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, i,
                                                     s->prims[i].kind);
                    if (touch && (st = mprt__grid_push(g, P, x, y, z, i, pair_limit, max_bytes)) != MPRT_OK)
                        return st;
                }
    }
    return MPRT_OK;
}

/* The lists in voxel order by a counting sort with a cursor array
 * (primitives stay in id order within a voxel), then the empty flags. */
static int sort_plain(mprt_grid *g, const mprt__pairs *P)
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
        return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory sorting %zu list entries", P->n);
    }
    memcpy(count, g->start, (size_t)nvox * sizeof *count);
    for (i = 0; i < (long long)P->n; i++) g->ids[count[P->vox[i]]++] = P->prim[i];
    free(count);
    g->refs = (long long)P->n;
    g->empty = malloc((size_t)nvox);
    if (!g->empty) return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %lld voxel flags", nvox);
    for (i = 0; i < nvox; i++) g->empty[i] = g->start[i + 1] > g->start[i] ? 0 : 1;
    return MPRT_OK;
}

int mprt__grid_create_reference(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing,
                                mprt_grid **out)
{
    static const mprt__grid_stages plain = {list_plain, sort_plain, chessboard_plain};
    return mprt__grid_create_stages(s, nx, ny, nz, max_bytes, listing, &plain, out);
}
