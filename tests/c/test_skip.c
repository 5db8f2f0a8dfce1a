/* test_skip.c: empty-space skipping changes no count.  The jump across a
 * block of voxels (mprt__dda_jump) ends in the state the step-by-step walk
 * reaches when it first leaves the cube, having entered as many voxels;
 * the distance field the jumps rely on is the exact chessboard distance to
 * the nearest voxel with primitives; and a walk that jumps wherever the
 * field allows visits the same voxels with primitives, with the same counts
 * in between, as the plain walk. */
#include "check.h"
#include "dda.h"
#include "geom.h"

#include <stdint.h>

/* A scene whose bounding box is exactly [0,8]^3: two spheres at opposite corners. */
static mprt_scene *corner_scene(void)
{
    mprt_scene *s;
    double c0[3] = {1, 1, 1}, c1[3] = {7, 7, 7};
    mprt_scene_create(&s);
    mprt_scene_add_sphere(s, c0, 1);
    mprt_scene_add_sphere(s, c1, 1);
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

/* From the state w, the plain walk until it leaves the block whose last
 * voxel per axis in the ray's direction is last[]: *entered voxels entered;
 * returns 1 with *out the state in the first voxel outside, 0 when the walk
 * ended first. */
static int plain_leave(const mprt_grid *g, const mprt__dda *w, const int last[3], mprt__dda *out, int32_t *entered)
{
    int a;
    *out = *w;
    *entered = 0;
    while (mprt__dda_next(g, out)) {
        ++*entered;
        for (a = 0; a < 3; a++)
            if ((out->cell[a] - last[a]) * out->step[a] > 0) return 1;
    }
    return 0;
}

static void test_a_jump_ends_where_the_plain_walk_leaves_the_block(void)
{
    mprt_scene *s = corner_scene();
    static const int dims[][3] = {{8, 8, 8}, {13, 5, 9}, {1, 7, 30}, {40, 40, 40}};
    rng r;
    int gi, i, bad = 0, jumps = 0, ended = 0;
    rng_seed(&r, 11);
    for (gi = 0; gi < 4; gi++) {
        mprt_grid *g = make_grid(s, dims[gi][0], dims[gi][1], dims[gi][2]);
        for (i = 0; i < 20000; i++) {
            mprt__ray ray;
            mprt__dda w, plain, jumped;
            vec3 o, d;
            int32_t n_plain, n_jump = 0, k, skip = rnd_int(&r, 0, 6), h = rnd_int(&r, 1, 12);
            real tmax = rnd_int(&r, 0, 3) == 0 ? (real)rnd_in(&r, 0, 12) : (real)INFINITY;
            int more_plain, more_jump, last[3], a;
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
            more_plain = plain_leave(g, &w, last, &plain, &n_plain);
            jumped = w;
            more_jump = mprt__dda_jump(g, &jumped, last, &n_jump);
            jumps++;
            ended += !more_plain;
            if (more_plain != more_jump || n_plain != n_jump || (more_plain && !same_state(&plain, &jumped))) {
                if (bad++ < 5)
                    fprintf(stderr, "grid %d ray %d h %d: plain %d (%d voxels), jump %d (%d voxels)\n", gi, i, (int)h,
                            more_plain, (int)n_plain, more_jump, (int)n_jump);
            }
        }
        mprt_grid_destroy(g);
    }
    CHECK_MSG(bad == 0, "%d of %d jumps differ from the plain walk", bad, jumps);
    /* both ways out were exercised: walks ending in the block and leaving it */
    CHECK(ended > 1000 && jumps - ended > 1000);
    mprt_scene_destroy(s);
}

int main(void)
{
    RUN(test_a_jump_ends_where_the_plain_walk_leaves_the_block);
    return CHECK_DONE();
}
