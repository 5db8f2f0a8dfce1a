/* camera.c: the eye rays of a render's samples, the tiles that split the
 * samples between threads (and traces), and the pixels made from the
 * samples.  The renderer and the public queries below use these functions
 * alone, so what a caller is told is what the renderer does. */
#include "camera.h"
#include "grid.h"

#include <string.h>

void mprt__camera_setup(const mprt_scene *s, int width, int height, int rules, mprt__camera *cam)
{
    int span = height > 1 ? height - 1 : 1;
    cam->from = s->from;
    cam->forward = vnorm(vsub(s->at, s->from));
    cam->right = vnorm(vcross(cam->forward, s->up));
    cam->up = vcross(cam->right, cam->forward);
    /* NFF's angle spans the centres of the first and last row */
    cam->pitch = 2 * tan(s->angle * 0.5 * 3.14159265358979323846 / 180) / span;
    cam->hither = s->hither;
    cam->width = width;
    cam->height = height;
    cam->corners = rules == MPRT_RULES_SPD;
    cam->samples_w = width + cam->corners;
    cam->samples_h = height + cam->corners;
}

vec3 mprt__camera_ray(const mprt__camera *cam, int x, int y, real *tmin)
{
    /* Sample (x, y) on the image plane: pixel centres, or corners half a
     * pixel up and left of them */
    double px = cam->corners ? (double)x - 0.5 : (double)x;
    double py = cam->corners ? (double)y - 0.5 : (double)y;
    double sx = (px - (cam->width - 1) * 0.5) * cam->pitch;
    double sy = ((cam->height - 1) * 0.5 - py) * cam->pitch;
    vec3 d = vadd(cam->forward, vadd(vscale(cam->right, (real)sx), vscale(cam->up, (real)sy)));
    d = vnorm(d);
    /* The hither plane is perpendicular to the view direction */
    *tmin = (real)(cam->hither / (double)vdot(d, cam->forward));
    return d;
}

void mprt__tile_counts(const mprt__camera *cam, int tile_edge, int *tiles_x, int *tiles_y)
{
    *tiles_x = (cam->samples_w - 1) / tile_edge + 1;
    *tiles_y = (cam->samples_h - 1) / tile_edge + 1;
}

void mprt__tile_rect(const mprt__camera *cam, int tile_edge, int tile, int rect[4])
{
    int tiles_x, tiles_y;
    mprt__tile_counts(cam, tile_edge, &tiles_x, &tiles_y);
    rect[0] = tile % tiles_x * tile_edge;
    rect[1] = tile / tiles_x * tile_edge;
    /* (written so that a huge tile edge cannot overflow) */
    rect[2] = tile_edge < cam->samples_w - rect[0] ? rect[0] + tile_edge : cam->samples_w;
    rect[3] = tile_edge < cam->samples_h - rect[1] ? rect[1] + tile_edge : cam->samples_h;
}

void mprt__samples_to_pixels(int corners, int samples_w, int samples_h, const double *samples, float *rgb)
{
    int width = samples_w - corners, height = samples_h - corners, x, y, k;
    for (y = 0; y < height; y++)
        for (x = 0; x < width; x++) {
            size_t a = (size_t)y * (size_t)samples_w + (size_t)x, b = a + (size_t)samples_w;
            float *out = rgb + 3 * ((size_t)y * (size_t)width + (size_t)x);
            for (k = 0; k < 3; k++) {
                double v;
                if (corners)
                    v = 0.25 * (samples[3 * a + (size_t)k] + samples[3 * (a + 1) + (size_t)k] +
                                samples[3 * b + (size_t)k] + samples[3 * (b + 1) + (size_t)k]);
                else
                    v = samples[3 * a + (size_t)k];
                out[k] = (float)v;
            }
        }
}

/* ---- Public queries ------------------------------------------------------ */

/* The resolved description and camera of a render. */
static int render_camera(mprt_grid *g, const mprt_render_desc *desc, mprt_render_desc *rd, mprt__camera *cam)
{
    int st = mprt_grid_resolve_desc(g, desc, rd);
    if (st != MPRT_OK) return st;
    mprt__camera_setup(g->scene, rd->width, rd->height, rd->rules, cam);
    return MPRT_OK;
}

int mprt_grid_tiling(mprt_grid *g, const mprt_render_desc *desc, int *samples_w, int *samples_h, int *tiles_x,
                     int *tiles_y)
{
    mprt_render_desc rd;
    mprt__camera cam;
    int tx, ty, st = render_camera(g, desc, &rd, &cam);
    if (st != MPRT_OK) return st;
    mprt__tile_counts(&cam, rd.tile, &tx, &ty);
    if (samples_w) *samples_w = cam.samples_w;
    if (samples_h) *samples_h = cam.samples_h;
    if (tiles_x) *tiles_x = tx;
    if (tiles_y) *tiles_y = ty;
    return MPRT_OK;
}

int mprt_grid_tile_rect(mprt_grid *g, const mprt_render_desc *desc, int tile, int rect[4])
{
    mprt_render_desc rd;
    mprt__camera cam;
    int tx, ty, st;
    if (!rect) return MPRT_ERR_INVALID_ARG;
    if ((st = render_camera(g, desc, &rd, &cam)) != MPRT_OK) return st;
    mprt__tile_counts(&cam, rd.tile, &tx, &ty);
    if (tile < 0 || tile >= tx * ty)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "tile_rect: tile %d is not in 0..%d", tile, tx * ty - 1);
    mprt__tile_rect(&cam, rd.tile, tile, rect);
    return MPRT_OK;
}

int mprt_grid_camera_rays(mprt_grid *g, const mprt_render_desc *desc, size_t first, size_t n, double *origins,
                          double *directions)
{
    mprt_render_desc rd;
    mprt__camera cam;
    size_t nsamples, i;
    int st;
    if ((st = render_camera(g, desc, &rd, &cam)) != MPRT_OK) return st;
    if (n && (!origins || !directions)) return MPRT_ERR_INVALID_ARG;
    nsamples = (size_t)cam.samples_w * (size_t)cam.samples_h;
    if (first > nsamples || n > nsamples - first)
        return mprt__grid_fail(g, MPRT_ERR_INVALID_ARG, "camera_rays: samples %zu..%zu are not all in 0..%zu", first,
                               first + n - 1, nsamples - 1);
    for (i = 0; i < n; i++) {
        size_t k = first + i;
        real tmin;
        vec3 d = mprt__camera_ray(&cam, (int)(k % (size_t)cam.samples_w), (int)(k / (size_t)cam.samples_w), &tmin);
        origins[3 * i] = (double)cam.from.x;
        origins[3 * i + 1] = (double)cam.from.y;
        origins[3 * i + 2] = (double)cam.from.z;
        directions[3 * i] = (double)d.x;
        directions[3 * i + 1] = (double)d.y;
        directions[3 * i + 2] = (double)d.z;
    }
    return MPRT_OK;
}

int mprt_samples_to_image(int rules, int samples_w, int samples_h, const double *samples, float *rgb, size_t cap)
{
    int corners = rules == MPRT_RULES_SPD;
    if (rules != MPRT_RULES_PAPER && rules != MPRT_RULES_SPD && rules != MPRT_RULES_PAPER1992)
        return MPRT_ERR_INVALID_ARG;
    if (!samples || !rgb) return MPRT_ERR_INVALID_ARG;
    if (samples_w - corners < 1 || samples_h - corners < 1 || samples_w > 65537 || samples_h > 65537)
        return MPRT_ERR_INVALID_ARG;
    if (cap < (size_t)(samples_w - corners) * (size_t)(samples_h - corners) * 3) return MPRT_ERR_CAPACITY;
    mprt__samples_to_pixels(corners, samples_w, samples_h, samples, rgb);
    return MPRT_OK;
}
