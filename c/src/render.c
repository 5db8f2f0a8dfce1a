/* render.c: the entry points of rendering and tracing.  A render resolves
 * its description, sets up the camera, splits the samples into tiles and
 * lets worker threads take the tiles one by one; each sample's ray tree is
 * traced by pipeline.c.  Counters are integers summed per worker, and every
 * sample is written by the one thread that traced it, so the image and the
 * counters are the same bits for any number of threads. */
#include "render.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

void mprt_render_desc_init(mprt_render_desc *d)
{
    if (!d) return;
    memset(d, 0, sizeof *d);
    d->rules = MPRT_RULES_PAPER;
    d->threshold = 1.0 / 512;
    d->max_depth = 0;
    d->threads = 1;
    d->tile = 16;
    d->ambient = 0.1;
}

/* The workload conventions of each rule set (mprt_rules order), field by field. */
enum { NCONV = 5 };
static const char *const conv_name[NCONV] = {"offset", "accept", "behind", "candidates", "shadow_term"};
static const int conv_max[NCONV] = {MPRT_OFFSET_NONE, MPRT_ACCEPT_LISTED, MPRT_BEHIND_CAST, MPRT_CANDIDATES_ALL,
                                    MPRT_SHADOW_SURFACE};
static const int conv_of_rules[3][NCONV] = {
    {MPRT_OFFSET_SCALED, MPRT_ACCEPT_IN_VOXEL, MPRT_BEHIND_CUTOFF, MPRT_CANDIDATES_MATERIAL, MPRT_SHADOW_LIGHT},
    {MPRT_OFFSET_SCALED, MPRT_ACCEPT_IN_VOXEL, MPRT_BEHIND_SKIP, MPRT_CANDIDATES_MATERIAL, MPRT_SHADOW_LIGHT},
    {MPRT_OFFSET_SCALED, MPRT_ACCEPT_IN_VOXEL, MPRT_BEHIND_SKIP, MPRT_CANDIDATES_SPECULAR, MPRT_SHADOW_LIGHT},
};

/* Fill the conventions left 0 from the rule set; check the others. */
static int resolve_conventions(mprt_grid *g, mprt_render_desc *rd)
{
    int *field[NCONV], k;
    field[0] = &rd->offset;
    field[1] = &rd->accept;
    field[2] = &rd->behind;
    field[3] = &rd->candidates;
    field[4] = &rd->shadow_term;
    for (k = 0; k < NCONV; k++) {
        if (*field[k] < 0 || *field[k] > conv_max[k])
            return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: %s %d is not in 0..%d (0: the rule set's choice)",
                                   conv_name[k], *field[k], conv_max[k]);
        if (*field[k] == 0) *field[k] = conv_of_rules[rd->rules][k];
    }
    return MPRT_OK;
}

int mprt_grid_resolve_desc(mprt_grid *g, const mprt_render_desc *desc, mprt_render_desc *out)
{
    int st;
    mprt_render_desc rd;
    if (!g || !desc || !out) return MPRT_ERR_INVALID_ARG;
    if (g->failed) return MPRT_ERR_STATE;
    rd = *desc;
    if (rd.width == 0) rd.width = g->scene->width;
    if (rd.height == 0) rd.height = g->scene->height;
    if (rd.width < 1 || rd.height < 1 || rd.width > 65536 || rd.height > 65536)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: resolution %dx%d is not in 1..65536", rd.width,
                               rd.height);
    if (rd.rules != MPRT_RULES_PAPER && rd.rules != MPRT_RULES_SPD && rd.rules != MPRT_RULES_PAPER1992)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: unknown rule set %d (0 paper, 1 spd, 2 paper1992)",
                               rd.rules);
    if ((st = resolve_conventions(g, &rd)) != MPRT_OK) return st;
    if (!(rd.threshold >= 0 && rd.threshold < 1))
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: threshold %g is not in [0, 1)", rd.threshold);
    if (!(rd.ambient >= 0 && rd.ambient <= 1))
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: ambient %g is not in [0, 1]", rd.ambient);
    if (rd.max_depth < 0 || rd.max_depth > 255)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: max_depth %d is not in 0..255", rd.max_depth);
    if (rd.max_depth == 0) rd.max_depth = rd.rules == MPRT_RULES_SPD ? 5 : 64;
    if (rd.tile <= 0) rd.tile = 16;
    if (rd.threads < 0 || rd.threads > 64)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: threads %d is not in 0..64", rd.threads);
    if (rd.threads == 0) rd.threads = 1;
    if (rd.max_rays < 0)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "render: max_rays %d is negative (0 selects the default, %d)",
                               rd.max_rays, MPRT_DEFAULT_MAX_RAYS);
    if (rd.max_rays == 0) rd.max_rays = MPRT_DEFAULT_MAX_RAYS;
    *out = rd;
    return MPRT_OK;
}

/* Resolve the description and set up what every ray shares. */
static int setup_render(mprt_grid *g, const mprt_render_desc *desc, mprt__render_setup *setup)
{
    int st = mprt_grid_resolve_desc(g, desc, &setup->desc);
    if (st != MPRT_OK) return st;
    setup->grid = g;
    setup->scene = g->scene;
    mprt__camera_setup(g->scene, setup->desc.width, setup->desc.height, setup->desc.rules, &setup->camera);
    setup->light_rgb_default = mprt__light_default_rgb(g->scene);
    return MPRT_OK;
}

size_t mprt__tree_stack_size(const mprt__render_setup *setup)
{
    return (size_t)(setup->desc.max_depth + 2) * (size_t)(setup->scene->nlights + 2) + 8;
}

/* Samples of a render: where each tile's colours go. */
typedef struct {
    double *rgb;            /* 3 doubles per sample */
    int stride;             /* samples per row of rgb */
    int x0, y0;             /* the sample rgb starts with */
} sample_buffer;

/* Trace the samples of one tile into out; stops at a sample over the ray
 * budget (sink->over_budget). */
static void render_tile(const mprt__render_setup *setup, int tile, const sample_buffer *out, mprt__tree_ray *stack,
                        mprt__sink *sink)
{
    const mprt__camera *cam = &setup->camera;
    int rect[4], x, y;
    mprt__tile_rect(cam, setup->desc.tile, tile, rect);
    for (y = rect[1]; y < rect[3]; y++)
        for (x = rect[0]; x < rect[2]; x++) {
            double *rgb = out->rgb + 3 * ((size_t)(y - out->y0) * (size_t)out->stride + (size_t)(x - out->x0));
            double sum[3]; /* the sample's sum: the shared buffer is written once a sample */
            mprt__tree_ray eye;
            memset(&eye, 0, sizeof eye);
            eye.origin = cam->from;
            eye.dir = mprt__camera_ray(cam, x, y, &eye.tmin);
            eye.tmax = (real)INFINITY;
            eye.contribution = 1;
            eye.kind = MPRT_RAY_PRIMARY;
            eye.depth = 1;
            mprt__trace_sample(setup, eye, y * cam->samples_w + x, sum, stack, sink);
            rgb[0] = sum[0];
            rgb[1] = sum[1];
            rgb[2] = sum[2];
            if (sink->over_budget >= 0) return;
        }
}

/* The error of a sample over the ray budget. */
static int budget_fail(mprt_grid *g, const mprt__render_setup *setup, const char *call, int64_t sample)
{
    const mprt_render_desc *d = &setup->desc;
    int w = setup->camera.samples_w;
    return mprt__grid_fail(g, MPRT_ERR_LIMIT,
                           "%s: sample (%d, %d) needs more than %d rays (max_rays, the ray budget of a sample): its "
                           "ray tree does not end (threshold %g, max_depth %d); raise the threshold or max_rays, or "
                           "lower max_depth",
                           call, (int)(sample % w), (int)(sample / w), d->max_rays,
                           d->rules != MPRT_RULES_SPD ? d->threshold : 0.0, d->max_depth);
}

/* ---- Trace tiles ------------------------------------------------------------- */

/* The error of a traced tile, or MPRT_OK: an unknown primitive, a sample over
 * the budget, values too wide for the records. */
static int tile_error(mprt_grid *g, const mprt__render_setup *setup, const mprt__sink *sink,
                      const mprt__recorder *recorder, int tile)
{
    if (sink->bad_prim >= 0)
        return mprt__grid_fail(g, MPRT_ERR_STATE, "trace: " MPRT__UNKNOWN_KIND, (long long)sink->bad_prim,
                               g->scene->prims[sink->bad_prim].kind);
    if (sink->over_budget >= 0) return budget_fail(g, setup, "trace", sink->over_budget);
    if (recorder->too_wide)
        return mprt__grid_fail(g, MPRT_ERR_STATE,
                               "trace: tile %d has an SC visit making more than 255 rays or a light index over 32767 "
                               "(the trace records cannot hold them)",
                               tile);
    return MPRT_OK;
}

int mprt_grid_trace_tile(mprt_grid *g, const mprt_render_desc *desc, int tile, double *samples, size_t cap_samples,
                         mprt_trace_ray *rays, size_t cap_rays, size_t *nrays, mprt_trace_visit *visits,
                         size_t cap_visits, size_t *nvisits, mprt_counters *counters)
{
    mprt__render_setup setup;
    mprt__recorder recorder;
    mprt__sink sink;
    sample_buffer out;
    mprt__tree_ray *stack;
    int rect[4], tiles_x, tiles_y;
    size_t nsamples;
    int st = setup_render(g, desc, &setup);
    if (st != MPRT_OK) return st;
    if (!samples || !nrays || !nvisits || (cap_rays && !rays) || (cap_visits && !visits)) return MPRT_ERR_INVALID_ARG;
    mprt__tile_counts(&setup.camera, setup.desc.tile, &tiles_x, &tiles_y);
    if (tile < 0 || tile >= tiles_x * tiles_y)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "trace: tile %d is not in 0..%d", tile, tiles_x * tiles_y - 1);
    mprt__tile_rect(&setup.camera, setup.desc.tile, tile, rect);
    nsamples = (size_t)(rect[2] - rect[0]) * (size_t)(rect[3] - rect[1]);
    if (cap_samples < nsamples * 3)
        return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "trace: sample buffer holds %zu doubles, %zu needed", cap_samples,
                               nsamples * 3);
    stack = malloc(mprt__tree_stack_size(&setup) * sizeof *stack);
    if (!stack) return mprt__grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "trace: out of memory for the ray stack");
    memset(&recorder, 0, sizeof recorder);
    recorder.rays = rays;
    recorder.cap_rays = cap_rays;
    recorder.visits = visits;
    recorder.cap_visits = cap_visits;
    mprt__sink_init(&sink, &recorder);
    out.rgb = samples;
    out.stride = rect[2] - rect[0];
    out.x0 = rect[0];
    out.y0 = rect[1];
    render_tile(&setup, tile, &out, stack, &sink);
    free(stack);
    *nrays = recorder.nrays;
    *nvisits = recorder.nvisits;
    if (counters) *counters = sink.counters;
    if (sink.bad_prim >= 0 || sink.over_budget >= 0) return tile_error(g, &setup, &sink, &recorder, tile);
    if (recorder.nrays > cap_rays || recorder.nvisits > cap_visits)
        return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "trace: tile %d needs %zu rays and %zu visits", tile,
                               recorder.nrays, recorder.nvisits);
    return tile_error(g, &setup, &sink, &recorder, tile);
}

int mprt_grid_trace_tiles(mprt_grid *g, const mprt_render_desc *desc, const int *tiles, size_t ntiles,
                          double *samples, size_t cap_samples, int64_t first_ray, mprt_trace_ray *rays,
                          size_t cap_rays, size_t *nrays, mprt_trace_visit *visits, size_t cap_visits,
                          size_t *nvisits, size_t *ntraced, mprt_counters *counters)
{
    mprt__render_setup setup;
    mprt__sink sink;
    sample_buffer out;
    mprt__tree_ray *stack;
    int tiles_x, tiles_y;
    size_t i, nr = 0, nv = 0, most_rays = 0, most_visits = 0;
    int st = setup_render(g, desc, &setup);
    if (st != MPRT_OK) return st;
    if ((ntiles && (!tiles || !samples)) || !nrays || !nvisits || !ntraced || (cap_rays && !rays) ||
        (cap_visits && !visits) || first_ray < 0)
        return MPRT_ERR_INVALID_ARG;
    *nrays = *nvisits = *ntraced = 0;
    if (counters) memset(counters, 0, sizeof *counters);
    mprt__tile_counts(&setup.camera, setup.desc.tile, &tiles_x, &tiles_y);
    for (i = 0; i < ntiles; i++)
        if (tiles[i] < 0 || tiles[i] >= tiles_x * tiles_y)
            return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "trace: tiles[%zu] = %d is not in 0..%d", i, tiles[i],
                                   tiles_x * tiles_y - 1);
    if (cap_samples < (size_t)setup.camera.samples_w * (size_t)setup.camera.samples_h * 3)
        return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "trace: sample buffer holds %zu doubles, %zu needed", cap_samples,
                               (size_t)setup.camera.samples_w * (size_t)setup.camera.samples_h * 3);
    stack = malloc(mprt__tree_stack_size(&setup) * sizeof *stack);
    if (!stack) return mprt__grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "trace: out of memory for the ray stack");
    out.rgb = samples;
    out.stride = setup.camera.samples_w;
    out.x0 = out.y0 = 0;
    mprt__sink_init(&sink, NULL);
    for (i = 0; i < ntiles; i++) {
        mprt__recorder recorder;
        /* Stop before a tile that would likely not fit (as large as the largest
         * so far): a tile that does not fit is traced again by the next call */
        if (i > 0 && (cap_rays - nr < most_rays || cap_visits - nv < most_visits)) break;
        memset(&recorder, 0, sizeof recorder);
        recorder.rays = rays ? rays + nr : NULL;
        recorder.cap_rays = cap_rays - nr;
        recorder.visits = visits ? visits + nv : NULL;
        recorder.cap_visits = cap_visits - nv;
        recorder.base = first_ray + (int64_t)nr;
        {
            mprt_counters before = sink.counters;
            sink.recorder = &recorder;
            render_tile(&setup, tiles[i], &out, stack, &sink);
            if (sink.bad_prim >= 0 || sink.over_budget >= 0 || recorder.too_wide) {
                free(stack);
                return tile_error(g, &setup, &sink, &recorder, tiles[i]);
            }
            if (recorder.nrays > recorder.cap_rays || recorder.nvisits > recorder.cap_visits) {
                sink.counters = before; /* not recorded: not counted */
                if (i == 0) {
                    *nrays = recorder.nrays;
                    *nvisits = recorder.nvisits;
                    free(stack);
                    return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "trace: tile %d needs %zu rays and %zu visits",
                                           tiles[0], recorder.nrays, recorder.nvisits);
                }
                break;
            }
        }
        nr += recorder.nrays;
        nv += recorder.nvisits;
        if (recorder.nrays > most_rays) most_rays = recorder.nrays;
        if (recorder.nvisits > most_visits) most_visits = recorder.nvisits;
    }
    free(stack);
    *nrays = nr;
    *nvisits = nv;
    *ntraced = i;
    if (counters) *counters = sink.counters;
    return MPRT_OK;
}

/* ---- Render an image -------------------------------------------------------- */

/* The tiles of a render, taken one by one by the workers. */
typedef struct {
    const mprt__render_setup *setup;
    sample_buffer samples;
    int ntiles, next_tile;
    int out_of_memory;
    int stop;               /* a sample went over the ray budget: take no more tiles */
    pthread_mutex_t lock;
} tile_queue;

/* One worker thread: its counters and errors (its sink), copied here when it ends. */
typedef struct {
    tile_queue *queue;
    mprt__sink sink;
    int budget_tile;        /* the tile of sink.over_budget */
    pthread_t thread;
} worker;

/* Memory of its own cache lines: whole 64-byte lines, none shared with
 * another allocation (a worker writes its ray stack at every ray). */
static void *lines_alloc(size_t bytes)
{
    void *p;
    return posix_memalign(&p, 64, (bytes + 63) / 64 * 64) == 0 ? p : NULL;
}

/* A worker counts into a sink in its own stack frame, not into the worker
 * array: the counters change at every stage visit, and neighbouring
 * workers' entries share cache lines. */
static void *work(void *arg)
{
    worker *self = arg;
    tile_queue *queue = self->queue;
    mprt__sink sink = self->sink;
    mprt__tree_ray *stack = lines_alloc(mprt__tree_stack_size(queue->setup) * sizeof *stack);
    if (!stack) {
        pthread_mutex_lock(&queue->lock);
        queue->out_of_memory = 1;
        pthread_mutex_unlock(&queue->lock);
        return NULL;
    }
    for (;;) {
        int tile;
        pthread_mutex_lock(&queue->lock);
        tile = queue->out_of_memory || queue->stop ? queue->ntiles : queue->next_tile++;
        pthread_mutex_unlock(&queue->lock);
        if (tile >= queue->ntiles) break;
        render_tile(queue->setup, tile, &queue->samples, stack, &sink);
        if (sink.over_budget >= 0) {
            /* Tiles are handed out in order and the tiles being traced are
             * finished, so the lowest failing tile is found whatever the
             * thread count: the error names the same sample every time */
            self->budget_tile = tile;
            pthread_mutex_lock(&queue->lock);
            queue->stop = 1;
            pthread_mutex_unlock(&queue->lock);
            break;
        }
    }
    free(stack);
    self->sink = sink;
    return NULL;
}

int mprt_grid_render(mprt_grid *g, const mprt_render_desc *desc, float *rgb, size_t cap, mprt_counters *counters)
{
    mprt__render_setup setup;
    tile_queue queue;
    worker workers[64];
    int i, started, tiles_x, tiles_y;
    int64_t bad_prim = -1;
    size_t nsamples, npixels;
    int st = setup_render(g, desc, &setup);
    if (st != MPRT_OK) return st;
    if (!rgb) return MPRT_ERR_INVALID_ARG;
    npixels = (size_t)setup.desc.width * (size_t)setup.desc.height;
    if (cap < npixels * 3)
        return mprt__grid_fail(g, MPRT_ERR_CAPACITY, "render: image buffer holds %zu floats, %zu needed", cap,
                               npixels * 3);
    memset(&queue, 0, sizeof queue);
    queue.setup = &setup;
    mprt__tile_counts(&setup.camera, setup.desc.tile, &tiles_x, &tiles_y);
    queue.ntiles = tiles_x * tiles_y;
    nsamples = (size_t)setup.camera.samples_w * (size_t)setup.camera.samples_h;
    queue.samples.stride = setup.camera.samples_w;
    queue.samples.rgb = malloc(nsamples * 3 * sizeof *queue.samples.rgb);
    if (!queue.samples.rgb || pthread_mutex_init(&queue.lock, NULL) != 0) {
        free(queue.samples.rgb);
        return mprt__grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "render: out of memory for %zu samples", nsamples);
    }
    for (i = 0; i < setup.desc.threads; i++) {
        worker *w = &workers[i];
        w->queue = &queue;
        mprt__sink_init(&w->sink, NULL);
        w->budget_tile = -1;
    }
    /* Workers 1.. in threads of their own, worker 0 in this one */
    for (started = 1; started < setup.desc.threads; started++)
        if (pthread_create(&workers[started].thread, NULL, work, &workers[started]) != 0) break;
    work(&workers[0]);
    for (i = 1; i < started; i++) pthread_join(workers[i].thread, NULL);
    pthread_mutex_destroy(&queue.lock);
    if (queue.out_of_memory) {
        free(queue.samples.rgb);
        return mprt__grid_fail(g, MPRT_ERR_OUT_OF_MEMORY, "render: out of memory for a worker's ray stack");
    }
    for (i = 0; i < started; i++)
        if (workers[i].sink.bad_prim >= 0) bad_prim = workers[i].sink.bad_prim;
    if (bad_prim >= 0) {
        free(queue.samples.rgb);
        return mprt__grid_fail(g, MPRT_ERR_STATE, "render: " MPRT__UNKNOWN_KIND, (long long)bad_prim,
                               g->scene->prims[bad_prim].kind);
    }
    if (queue.stop) {
        const worker *first = NULL;
        for (i = 0; i < started; i++)
            if (workers[i].budget_tile >= 0 && (!first || workers[i].budget_tile < first->budget_tile))
                first = &workers[i];
        free(queue.samples.rgb);
        return budget_fail(g, &setup, "render", first->sink.over_budget);
    }
    /* Pixels: samples as they are, or the mean of each pixel's four corners */
    mprt__samples_to_pixels(setup.camera.corners, setup.camera.samples_w, setup.camera.samples_h, queue.samples.rgb,
                            rgb);
    if (counters) {
        memset(counters, 0, sizeof *counters);
        for (i = 0; i < started; i++) mprt__counters_add(counters, &workers[i].sink.counters);
    }
    free(queue.samples.rgb);
    return MPRT_OK;
}
