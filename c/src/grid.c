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
 * Empty space, the macro cells and the jumps from them: grid_jumps.c.
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

int mprt__grid_prim_box(const mprt_scene *s, long long i, vec3 lo, vec3 hi)
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

static int pairs_push(mprt__pairs *p, uint32_t v, int32_t id, size_t limit)
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

int mprt__grid_prim_range(mprt_grid *g, long long i, int a0[3], int a1[3], int shrink[3])
{
    const mprt_scene *s = g->scene;
    vec3 blo, bhi;
    int a;
    if (mprt__prim_bounds(s, i, &blo, &bhi) != MPRT_OK)
        return mprt__grid_build_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, i, s->prims[i].kind);
    for (a = 0; a < 3; a++) {
        a0[a] = axis_cell(g, a, vget(blo, a) - g->pad);
        a1[a] = axis_cell(g, a, vget(bhi, a) + g->pad);
        if (g->listing == MPRT_LIST_BOX_OUTWARD && a1[a] < g->n[a] - 1) a1[a]++;
        shrink[a] = g->listing == MPRT_LIST_OCCUPIED && vget(bhi, a) - vget(blo, a) > 2 * g->pad &&
                    vget(g->cell, a) > 4 * g->pad;
    }
    return MPRT_OK;
}

int mprt__grid_push(mprt_grid *g, mprt__pairs *P, int x, int y, int z, long long i, size_t pair_limit, size_t max_bytes)
{
    if (!pairs_push(P, (uint32_t)(((long long)z * g->n[1] + y) * g->n[0] + x), (int32_t)i, pair_limit))
        return MPRT_OK;
    return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                                 "grid %dx%dx%d: the primitive lists exceed the %zu bytes allowed "
                                 "(or memory ran out) at primitive %lld",
                                 g->n[0], g->n[1], g->n[2], max_bytes, i);
}

/* The (voxel, primitive) pairs: for each primitive, the voxels of its
 * range (mprt__grid_prim_range) its surface may touch; the same pairs, bit
 * for bit, as testing each voxel's box in turn (tests/c/grid_reference.c),
 * for less work: the voxel boxes (grown or shrunk by the margin) come from
 * per-axis tables computed with the same arithmetic, and polygons are
 * tested column by column (x outermost) through mprt__polybox, which clips
 * each polygon to a column's x slab once.  The order of a primitive's own pairs does not matter: the counting
 * sort keeps primitives in id order within each voxel. */
static int list_fast(mprt_grid *g, mprt__pairs *P, size_t pair_limit, size_t max_bytes)
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
    if (!tab) return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the voxel bounds");
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
        if ((st = mprt__grid_prim_range(g, i, a0, a1, shrink)) != MPRT_OK) break;
        for (a = 0; a < 3; a++) {
            vlo[a] = tlo[shrink[a]][a];
            vhi[a] = thi[shrink[a]][a];
            vmag[a] = tmag[shrink[a]][a];
        }
        if (p->kind == MPRT_POLYGON && mprt__grid_listing_tests(g)) {
            mprt__polybox_set(&pb, &s->polygons[p->index], s->verts);
            for (x = a0[0]; x <= a1[0] && st == MPRT_OK; x++)
                for (y = a0[1]; y <= a1[1] && st == MPRT_OK; y++) {
                    real mxy = vmag[0][x] > vmag[1][y] ? vmag[0][x] : vmag[1][y];
                    for (z = a0[2]; z <= a1[2]; z++) {
                        int touch = mprt__polybox_test(&pb, v3(vlo[0][x], vlo[1][y], vlo[2][z]),
                                                       v3(vhi[0][x], vhi[1][y], vhi[2][z]),
                                                       mxy > vmag[2][z] ? mxy : vmag[2][z]);
                        if (touch < 0) {
                            st = mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                                                       "out of memory clipping polygon %lld", i);
                            break;
                        }
                        if (touch && (st = mprt__grid_push(g, P, x, y, z, i, pair_limit, max_bytes)) != MPRT_OK) break;
                    }
                }
            continue;
        }
        if (mprt__grid_listing_tests(g) && p->kind == MPRT_SPHERE) smag = vmaxabs(s->spheres[p->index].c);
        if (mprt__grid_listing_tests(g) && (p->kind == MPRT_CYLINDER || p->kind == MPRT_CONE))
            mprt__cone_box_prepare(&s->cones[p->index], &cx);
        for (z = a0[2]; z <= a1[2] && st == MPRT_OK; z++)
            for (y = a0[1]; y <= a1[1] && st == MPRT_OK; y++)
                for (x = a0[0]; x <= a1[0]; x++) {
                    const vec3 lo = v3(vlo[0][x], vlo[1][y], vlo[2][z]), hi = v3(vhi[0][x], vhi[1][y], vhi[2][z]);
                    real m = vmag[0][x] > vmag[1][y] ? vmag[0][x] : vmag[1][y];
                    int touch;
                    if (vmag[2][z] > m) m = vmag[2][z];
                    if (!mprt__grid_listing_tests(g)) touch = 1;
                    else if (p->kind == MPRT_SPHERE) touch = mprt__sphere_box_with(&s->spheres[p->index], lo, hi, m, smag);
                    else if (p->kind == MPRT_CYLINDER || p->kind == MPRT_CONE)
                        touch = mprt__cone_box_with(&s->cones[p->index], &cx, lo, hi, m);
                    else touch = mprt__grid_prim_box(s, i, lo, hi);
                    if (touch < 0) {
                        st = mprt__grid_build_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, i, s->prims[i].kind);
                        break;
                    }
                    if (touch && (st = mprt__grid_push(g, P, x, y, z, i, pair_limit, max_bytes)) != MPRT_OK) break;
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
        return mprt__grid_build_fail(g, MPRT_ERR_INVALID_ARG,
                                     "grid: %lld primitives, more than IC can index (%lu)", s->nprims,
                                     (unsigned long)MPRT__IC_MAX_INDEX - 1);
    ic->ref = malloc((size_t)s->nprims * sizeof *ic->ref);
    ic->ball = calloc((size_t)s->nprims, sizeof *ic->ball);
    ic->tri = malloc((size_t)(ntri ? ntri : 1) * sizeof *ic->tri);
    if (!ic->ref || !ic->ball || !ic->tri)
        return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                                     "out of memory for the intersection data of %lld primitives", s->nprims);
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

/* The lists in voxel order, by a counting sort (primitives stay in id order
 * within a voxel), and the empty flags, in few passes over the voxels:
 * voxel v's count goes to start[v + 2] (start has voxels + 2 entries), so
 * that after the prefix sum start[v + 1] is where v's list begins and, once
 * the entries are placed, where it ends, with no cursor array; the empty
 * flags come with the prefix sum. */
static int sort_fast(mprt_grid *g, const mprt__pairs *P)
{
    const long long nvox = g->voxels;
    uint32_t *start = g->start, sum = 0;
    uint8_t *e;
    long long i;
    g->ids = malloc((P->n ? P->n : 1) * sizeof *g->ids);
    if (!g->ids) return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                                              "out of memory sorting %zu list entries", P->n);
    g->empty = e = malloc((size_t)nvox);
    if (!e) return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for %lld voxel flags", nvox);
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
    return MPRT_OK;
}

static int build(mprt_grid *g, size_t max_bytes, const mprt__grid_stages *stages)
{
    const mprt_scene *s = g->scene;
    long long nvox = g->voxels;
    mprt__pairs P = {NULL, NULL, 0, 0};
    size_t pair_limit, fixed;
    long long ntri;
    int st = MPRT_OK;

    fixed = (size_t)(nvox + 1) * sizeof *g->start + (size_t)nvox + (size_t)(nvox + 63) / 64 * 8 + ic_bytes(s, &ntri);
    if (fixed > max_bytes)
        return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                                     "grid %dx%dx%d needs %zu bytes for its voxel table and intersection data alone, "
                                     "more than the %zu allowed",
                                     g->n[0], g->n[1], g->n[2], fixed, max_bytes);
    /* Pairs cost 8 bytes while building and 4 in the final list. */
    pair_limit = (max_bytes - fixed) / 8;
    g->start = calloc((size_t)nvox + 2, sizeof *g->start); /* + 1 for sort_fast */
    if (!g->start) return mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY,
                                                "out of memory allocating %zu bytes of voxel table", fixed);

    /* Margin: a few thousand ulps of the scene's extent. */
    g->pad = (real)(vmaxabs(vsub(g->hi, g->lo)) + vmaxabs(g->lo) + vmaxabs(g->hi)) * REAL_EPS * R(4096);

    st = (stages && stages->list ? stages->list : list_fast)(g, &P, pair_limit, max_bytes);
    if (st != MPRT_OK) goto done;
    if (P.n > 0xffffffffu) {
        st = mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY, "grid: %zu list entries exceed 2^32", P.n);
        goto done;
    }

    st = (stages && stages->sort ? stages->sort : sort_fast)(g, &P);
    if (st != MPRT_OK) goto done;
    if (g->jump_min <= 255 && mprt__grid_mark_jumps(g, stages ? stages->distance : NULL) != MPRT_OK) {
        st = mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the macro cells of %lld voxels", nvox);
        goto done;
    }
    if (mprt__dda_plain(g) != MPRT_OK) {
        st = mprt__grid_build_fail(g, MPRT_ERR_OUT_OF_MEMORY, "out of memory for the walk's bits of %lld voxels", nvox);
        goto done;
    }
    st = build_ic(g, ntri);

done:
    free(P.vox);
    free(P.prim);
    return st;
}

int mprt_grid_create(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, mprt_grid **out)
{
    return mprt_grid_create_listing(s, nx, ny, nz, max_bytes, MPRT_LIST_EXACT, out);
}

int mprt__grid_create_stages(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing,
                             const mprt__grid_stages *stages, mprt_grid **out)
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
    if (!s) return mprt__grid_build_fail(g, MPRT_ERR_INVALID_ARG, "grid: no scene");
    if (listing != MPRT_LIST_EXACT && listing != MPRT_LIST_BOX && listing != MPRT_LIST_BOX_OUTWARD &&
        listing != MPRT_LIST_OCCUPIED)
        return mprt__grid_build_fail(g, MPRT_ERR_INVALID_ARG,
                                     "grid: unknown listing %d (0 exact, 1 box, 2 box_outward, 3 occupied)", listing);
    g->listing = listing;
    if (nx < 1 || ny < 1 || nz < 1 || nx > 1024 || ny > 1024 || nz > 1024)
        return mprt__grid_build_fail(g, MPRT_ERR_INVALID_ARG,
                                     "grid: subdivision %dx%dx%d is not in 1..1024 per axis", nx, ny, nz);
    if (s->nprims == 0 && s->dropped > 0)
        return mprt__grid_build_fail(g, MPRT_ERR_STATE,
                                     "grid: the scene has no primitives: %lld %s dropped while reading it (%s%s)",
                                     s->dropped, s->dropped == 1 ? "was" : "were", s->dropped == 1 ? "" : "the first: ",
                                     s->warning);
    if (s->nprims == 0) return mprt__grid_build_fail(g, MPRT_ERR_STATE, "grid: the scene has no primitives");
    g->n[0] = nx;
    g->n[1] = ny;
    g->n[2] = nz;
    g->voxels = (long long)nx * ny * nz;
    if (mprt__scene_bounds(s, &g->lo, &g->hi, &bad) != MPRT_OK)
        return mprt__grid_build_fail(g, MPRT_ERR_STATE, "grid: " MPRT__UNKNOWN_KIND, bad, s->prims[bad].kind);
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
    if ((st = mprt__grid_jump_threshold(g)) != MPRT_OK) return st;
    st = build(g, max_bytes ? max_bytes : DEFAULT_MAX_BYTES, stages);
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
    return mprt__grid_create_stages(s, nx, ny, nz, max_bytes, listing, NULL, out);
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
