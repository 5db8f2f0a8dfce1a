/* camera.h: the eye, its samples, the tiles of a render and the pixels
 * made from the samples (internal). */
#ifndef MPRT_CAMERA_H
#define MPRT_CAMERA_H

#include "mprt_internal.h"

/* The pinhole camera of a render and its sample grid.  Paper rules sample
 * the pixel centres (width x height samples); SPD rules sample the pixel
 * corners ((width+1) x (height+1) samples) and a pixel is the mean of its
 * four corners. */
typedef struct {
    vec3 from;            /* the eye */
    vec3 right, up, forward; /* unit camera frame */
    double pitch;         /* sample spacing on the image plane at distance 1 */
    double hither;        /* eye rays start at this distance along the view direction */
    int width, height;    /* pixels */
    int corners;          /* 1: samples at the pixel corners (SPD rules) */
    int samples_w, samples_h; /* samples per row and per column */
} mprt__camera;

/* Set up the camera of scene's view for an image of width x height pixels
 * under rules (mprt_rules). */
void mprt__camera_setup(const mprt_scene *scene, int width, int height, int rules, mprt__camera *cam);

/* Eye ray of sample (x, y): unit direction and the start distance tmin
 * (the hither plane). */
vec3 mprt__camera_ray(const mprt__camera *cam, int x, int y, real *tmin);

/* Tiles per row and per column for a tile edge of tile_edge samples (>= 1). */
void mprt__tile_counts(const mprt__camera *cam, int tile_edge, int *tiles_x, int *tiles_y);

/* Sample rectangle of tile number tile (0 <= tile < tiles_x * tiles_y):
 * rect = x0, y0 (inclusive), x1, y1 (exclusive). */
void mprt__tile_rect(const mprt__camera *cam, int tile_edge, int tile, int rect[4]);

/* Pixels from samples (samples_w * samples_h * 3 doubles): the samples as
 * they are, or with corners the mean of each pixel's four corners.  rgb
 * receives width * height * 3 floats. */
void mprt__samples_to_pixels(int corners, int samples_w, int samples_h, const double *samples, float *rgb);

#endif
