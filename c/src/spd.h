/* spd.h: what the SPD scene generators share (internal): row-vector 4x4
 * matrices, and output in the SPD library's NFF conventions.  The helpers are
 * static inline so that each generator's arithmetic is the same code as in
 * the original programs' single file. */
#ifndef MPRT_SPD_H
#define MPRT_SPD_H

#include "mprt_internal.h"

#include <string.h>

#define SPD_PI 3.141592653589793

/* Propagate a non-OK status to the caller. */
#define SPD_TRY(call)                                                                 \
    do {                                                                              \
        int spd_st_ = (call);                                                         \
        if (spd_st_ != MPRT_OK) return spd_st_;                                       \
    } while (0)

/* ---- Row-vector 4x4 matrix helpers (p' = p * M, translation in row 3) ---- */

typedef double spd_mat[4][4];

enum { SPD_X_AXIS = 0, SPD_Y_AXIS = 1, SPD_Z_AXIS = 2 };

static inline void mat_identity(spd_mat m)
{
    int i, j;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) m[i][j] = i == j ? 1.0 : 0.0;
}

/* Rotation by angle (radians) about a coordinate axis. */
static inline void mat_rotate(spd_mat m, int axis, double angle)
{
    double c = cos(angle), s = sin(angle);
    int i, j;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) m[i][j] = 0.0;
    if (axis == SPD_X_AXIS) {
        m[0][0] = 1.0;
        m[1][1] = c; m[2][2] = c;
        m[1][2] = s; m[2][1] = -s;
    } else if (axis == SPD_Y_AXIS) {
        m[1][1] = 1.0;
        m[0][0] = c; m[2][2] = c;
        m[2][0] = s; m[0][2] = -s;
    } else {
        m[2][2] = 1.0;
        m[0][0] = c; m[1][1] = c;
        m[0][1] = s; m[1][0] = -s;
    }
    m[3][3] = 1.0;
}

/* Rotation by angle (radians) about a unit axis through the origin. */
static inline void mat_axis_rotate(spd_mat m, const double a[3], double angle)
{
    double c = cos(angle), s = sin(angle), t = 1.0 - c;
    m[0][0] = a[0] * a[0] + (1.0 - a[0] * a[0]) * c;
    m[0][1] = a[0] * a[1] * t + a[2] * s;
    m[0][2] = a[0] * a[2] * t - a[1] * s;
    m[0][3] = 0.0;
    m[1][0] = a[0] * a[1] * t - a[2] * s;
    m[1][1] = a[1] * a[1] + (1.0 - a[1] * a[1]) * c;
    m[1][2] = a[1] * a[2] * t + a[0] * s;
    m[1][3] = 0.0;
    m[2][0] = a[0] * a[2] * t + a[1] * s;
    m[2][1] = a[1] * a[2] * t - a[0] * s;
    m[2][2] = a[2] * a[2] + (1.0 - a[2] * a[2]) * c;
    m[2][3] = 0.0;
    m[3][0] = 0.0; m[3][1] = 0.0; m[3][2] = 0.0; m[3][3] = 1.0;
}

/* Product r = a * b (r must not alias a or b). */
static inline void mat_mul(spd_mat r, spd_mat a, spd_mat b)
{
    int i, j;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++)
            r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] + a[i][3] * b[3][j];
}

/* Point times matrix, with the translation row. */
static inline void xform_point(double r[3], const double p[3], spd_mat m)
{
    double t[3];
    t[0] = p[0] * m[0][0] + p[1] * m[1][0] + p[2] * m[2][0] + m[3][0];
    t[1] = p[0] * m[0][1] + p[1] * m[1][1] + p[2] * m[2][1] + m[3][1];
    t[2] = p[0] * m[0][2] + p[1] * m[1][2] + p[2] * m[2][2] + m[3][2];
    r[0] = t[0]; r[1] = t[1]; r[2] = t[2];
}

/* Direction times matrix, without the translation row. */
static inline void xform_vector(double r[3], const double p[3], spd_mat m)
{
    double t[3];
    t[0] = p[0] * m[0][0] + p[1] * m[1][0] + p[2] * m[2][0];
    t[1] = p[0] * m[0][1] + p[1] * m[1][1] + p[2] * m[2][1];
    t[2] = p[0] * m[0][2] + p[1] * m[1][2] + p[2] * m[2][2];
    r[0] = t[0]; r[1] = t[1]; r[2] = t[2];
}

/* Homogeneous 4-vector times matrix. */
static inline void xform_coord(double r[4], const double p[4], spd_mat m)
{
    double t[4];
    int j;
    for (j = 0; j < 4; j++) t[j] = p[0] * m[0][j] + p[1] * m[1][j] + p[2] * m[2][j] + p[3] * m[3][j];
    for (j = 0; j < 4; j++) r[j] = t[j];
}

/* Scale v to unit length (left alone if zero); returns the old length. */
static inline double normalize(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (len > 0.0) {
        v[0] /= len;
        v[1] /= len;
        v[2] /= len;
    }
    return len;
}

static inline void set3(double v[3], double x, double y, double z)
{
    v[0] = x; v[1] = y; v[2] = z;
}

/* ---- Output in the SPD library's NFF conventions ------------------------ */

/* Background and view shared by all six scenes: 45 degrees, 512x512. */
static inline int out_header(mprt_scene *s, const double from[3], const double at[3], const double up[3],
                      double hither)
{
    static const double sky[3] = {0.078, 0.361, 0.753};
    SPD_TRY(mprt_scene_set_background(s, sky));
    return mprt_scene_set_view(s, from, at, up, 45.0, hither, 512, 512);
}

/* A light at (x, y, z); SPD's NFF lights carry no colour. */
static inline int out_light(mprt_scene *s, double x, double y, double z)
{
    double p[3];
    set3(p, x, y, z);
    return mprt_scene_add_light(s, p, NULL);
}

/* Surface from SPD parameters: the highlight half-angle ang (degrees) becomes
 * the Phong exponent that drops to one half at that angle (100000 for no
 * highlight, 1 for 90 degrees or more). */
static inline int out_surface(mprt_scene *s, double r, double g, double b, double kd, double ks, double ang,
                       double kt, double ior)
{
    double rgb[3], rad = SPD_PI * ang / 180.0, shine;
    if (rad <= 0.0) shine = 100000.0;
    else if (rad >= SPD_PI / 2.0) shine = 1.0;
    else shine = log(0.5) / log(cos(rad));
    set3(rgb, r, g, b);
    return mprt_scene_set_material(s, rgb, kd, ks, shine, kt, ior);
}

/* Polygon as the SPD library writes it: a vertex closer than 1e-6 to its
 * successor (cyclically) is removed from pts in place, and a polygon left
 * with fewer than 3 vertices is not written at all. */
static inline int out_polygon(mprt_scene *s, int n, double (*pts)[3])
{
    int i = 0, j;
    while (i < n) {
        double d[3];
        const double *q = pts[(i + 1) % n];
        set3(d, pts[i][0] - q[0], pts[i][1] - q[1], pts[i][2] - q[2]);
        if (normalize(d) < 1.0e-6) {
            for (j = i; j < n - 1; j++) memcpy(pts[j], pts[j + 1], sizeof pts[j]);
            n--;
        } else {
            i++;
        }
    }
    if (n < 3) return MPRT_OK;
    return mprt_scene_add_polygon(s, n, &pts[0][0], NULL);
}

static inline int out_sphere(mprt_scene *s, const double c[3], double r)
{
    return mprt_scene_add_sphere(s, c, r);
}

static inline int out_cone(mprt_scene *s, const double base[3], double rb, const double apex[3], double ra)
{
    return mprt_scene_add_cone(s, base, rb, apex, ra);
}

/* The generators (spd_fractals.c, spd_objects.c): add scene NAME at SPD size
 * factor size (1 or more) to s, in the order the SPD program prints it. */
int mprt__spd_balls(mprt_scene *s, int size);
int mprt__spd_gears(mprt_scene *s, int size);
int mprt__spd_mount(mprt_scene *s, int size);
int mprt__spd_rings(mprt_scene *s, int size);
int mprt__spd_tetra(mprt_scene *s, int size);
int mprt__spd_tree(mprt_scene *s, int size);

#endif
