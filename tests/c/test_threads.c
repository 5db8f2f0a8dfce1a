/* test_threads.c: renders and traces from several threads (run under
 * ThreadSanitizer by `make tsan`). */
#include "check.h"
#include "mprt.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

enum { W = 40, H = 40, TILE = 8, CAPR = 1 << 13, CAPV = 1 << 15 };

static mprt_grid *grid;

typedef struct {
    int first;           /* tiles first, first+2, ... */
    size_t nvisits[64];  /* visits per tile */
    int status;
} job;

static void *trace_tiles(void *arg)
{
    job *j = arg;
    mprt_render_desc d;
    mprt_trace_ray *r = malloc(CAPR * sizeof *r);
    mprt_trace_visit *v = malloc(CAPV * sizeof *v);
    double s[TILE * TILE * 3];
    size_t nr, nv;
    int t;
    mprt_render_desc_init(&d);
    d.width = W;
    d.height = H;
    d.tile = TILE;
    for (t = j->first; t < 25; t += 2) {
        /* a too-small buffer first (the capacity path), then a big one */
        int st = mprt_grid_trace_tile(grid, &d, t, s, sizeof s / sizeof *s, r, 1, &nr, v, 1, &nv, NULL);
        if (st != MPRT_ERR_CAPACITY && st != MPRT_OK) j->status = st;
        st = mprt_grid_trace_tile(grid, &d, t, s, sizeof s / sizeof *s, r, CAPR, &nr, v, CAPV, &nv, NULL);
        if (st != MPRT_OK) j->status = st;
        j->nvisits[t] = nv;
    }
    free(r);
    free(v);
    return NULL;
}

static void test_renders_are_the_same_bits_with_any_thread_count(void)
{
    mprt_render_desc d;
    float *a = malloc(W * H * 3 * sizeof *a), *b = malloc(W * H * 3 * sizeof *b);
    mprt_counters ca, cb;
    mprt_render_desc_init(&d);
    d.width = W;
    d.height = H;
    d.tile = TILE;
    d.threads = 1;
    CHECK(mprt_grid_render(grid, &d, a, W * H * 3, &ca) == MPRT_OK);
    d.threads = 4;
    CHECK(mprt_grid_render(grid, &d, b, W * H * 3, &cb) == MPRT_OK);
    CHECK(memcmp(a, b, W * H * 3 * sizeof *a) == 0);
    CHECK(memcmp(&ca, &cb, sizeof ca) == 0);
    free(a);
    free(b);
}

static void test_tiles_traced_concurrently_equal_tiles_traced_alone(void)
{
    job j0, j1, alone;
    pthread_t t0, t1;
    int t;
    memset(&j0, 0, sizeof j0);
    memset(&j1, 0, sizeof j1);
    memset(&alone, 0, sizeof alone);
    j1.first = 1;
    pthread_create(&t0, NULL, trace_tiles, &j0);
    pthread_create(&t1, NULL, trace_tiles, &j1);
    pthread_join(t0, NULL);
    pthread_join(t1, NULL);
    CHECK(j0.status == MPRT_OK && j1.status == MPRT_OK);
    trace_tiles(&alone);
    alone.first = 1;
    trace_tiles(&alone);
    for (t = 0; t < 25; t++) CHECK_MSG((t % 2 ? j1 : j0).nvisits[t] == alone.nvisits[t], "tile %d", t);
}

int main(void)
{
    mprt_scene *s;
    mprt_scene_create(&s);
    mprt_scene_spd(s, "mount", 2);
    mprt_grid_create(s, 12, 12, 12, 0, &grid);
    RUN(test_renders_are_the_same_bits_with_any_thread_count);
    RUN(test_tiles_traced_concurrently_equal_tiles_traced_alone);
    mprt_grid_destroy(grid);
    mprt_scene_destroy(s);
    return CHECK_DONE();
}
