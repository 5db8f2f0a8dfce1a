/* spd.c: the Standard Procedural Databases scene generators (balls, gears,
 * mount, rings, tetra, tree).
 *
 * The SPD are Eric Haines' benchmark scenes for ray tracers (public domain,
 * now CC0: github.com/erich666/StandardProceduralDatabases).  This file
 * rebuilds, from the published procedural rules, the scenes those programs
 * write as NFF with true curved primitives (their default output).  The
 * entities are added in the order the programs print them, so primitive ids
 * follow the order of an SPD .nff file, and the arithmetic follows the same
 * operation order (row-vector 4x4 matrices, same constants) so the numbers
 * agree with the originals to rounding, for every size factor. */
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

static void mat_identity(spd_mat m)
{
    int i, j;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++) m[i][j] = i == j ? 1.0 : 0.0;
}

/* Rotation by angle (radians) about a coordinate axis. */
static void mat_rotate(spd_mat m, int axis, double angle)
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
static void mat_axis_rotate(spd_mat m, const double a[3], double angle)
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
static void mat_mul(spd_mat r, spd_mat a, spd_mat b)
{
    int i, j;
    for (i = 0; i < 4; i++)
        for (j = 0; j < 4; j++)
            r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] + a[i][3] * b[3][j];
}

/* Point times matrix, with the translation row. */
static void xform_point(double r[3], const double p[3], spd_mat m)
{
    double t[3];
    t[0] = p[0] * m[0][0] + p[1] * m[1][0] + p[2] * m[2][0] + m[3][0];
    t[1] = p[0] * m[0][1] + p[1] * m[1][1] + p[2] * m[2][1] + m[3][1];
    t[2] = p[0] * m[0][2] + p[1] * m[1][2] + p[2] * m[2][2] + m[3][2];
    r[0] = t[0]; r[1] = t[1]; r[2] = t[2];
}

/* Direction times matrix, without the translation row. */
static void xform_vector(double r[3], const double p[3], spd_mat m)
{
    double t[3];
    t[0] = p[0] * m[0][0] + p[1] * m[1][0] + p[2] * m[2][0];
    t[1] = p[0] * m[0][1] + p[1] * m[1][1] + p[2] * m[2][1];
    t[2] = p[0] * m[0][2] + p[1] * m[1][2] + p[2] * m[2][2];
    r[0] = t[0]; r[1] = t[1]; r[2] = t[2];
}

/* Homogeneous 4-vector times matrix. */
static void xform_coord(double r[4], const double p[4], spd_mat m)
{
    double t[4];
    int j;
    for (j = 0; j < 4; j++) t[j] = p[0] * m[0][j] + p[1] * m[1][j] + p[2] * m[2][j] + p[3] * m[3][j];
    for (j = 0; j < 4; j++) r[j] = t[j];
}

/* Scale v to unit length (left alone if zero); returns the old length. */
static double normalize(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (len > 0.0) {
        v[0] /= len;
        v[1] /= len;
        v[2] /= len;
    }
    return len;
}

static void set3(double v[3], double x, double y, double z)
{
    v[0] = x; v[1] = y; v[2] = z;
}

/* ---- Output in the SPD library's NFF conventions ------------------------ */

/* Background and view shared by all six scenes: 45 degrees, 512x512. */
static int out_header(mprt_scene *s, const double from[3], const double at[3], const double up[3],
                      double hither)
{
    static const double sky[3] = {0.078, 0.361, 0.753};
    SPD_TRY(mprt_scene_set_background(s, sky));
    return mprt_scene_set_view(s, from, at, up, 45.0, hither, 512, 512);
}

/* A light at (x, y, z); SPD's NFF lights carry no colour. */
static int out_light(mprt_scene *s, double x, double y, double z)
{
    double p[3];
    set3(p, x, y, z);
    return mprt_scene_add_light(s, p, NULL);
}

/* Surface from SPD parameters: the highlight half-angle ang (degrees) becomes
 * the Phong exponent that drops to one half at that angle (100000 for no
 * highlight, 1 for 90 degrees or more). */
static int out_surface(mprt_scene *s, double r, double g, double b, double kd, double ks, double ang,
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
static int out_polygon(mprt_scene *s, int n, double (*pts)[3])
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

static int out_sphere(mprt_scene *s, const double c[3], double r)
{
    return mprt_scene_add_sphere(s, c, r);
}

static int out_cone(mprt_scene *s, const double base[3], double rb, const double apex[3], double ra)
{
    return mprt_scene_add_cone(s, base, rb, apex, ra);
}

/* ---- balls: the sphereflake --------------------------------------------- */

/* Each sphere (xyzw = centre and radius; dir xyz = unit-ish direction from its
 * parent, w = child/parent radius ratio) spawns 9 children 1/3 its size. */
static int balls_grow(mprt_scene *s, double objset[9][4], int depth, const double c[4],
                      const double dir[4])
{
    spd_mat mx;
    double scale;
    int k;

    SPD_TRY(out_sphere(s, c, c[3]));
    if (depth <= 0) return MPRT_OK;
    depth--;

    /* Rotation taking +Z to dir; near +-Z the 2021 code snaps with 0.9999 */
    if (dir[2] >= 0.9999) {
        mat_identity(mx);
    } else if (dir[2] <= -0.9999) {
        mat_rotate(mx, SPD_Y_AXIS, SPD_PI);
    } else {
        double zaxis[3] = {0.0, 0.0, 1.0}, axis[3];
        axis[0] = zaxis[1] * dir[2] - zaxis[2] * dir[1];
        axis[1] = zaxis[2] * dir[0] - zaxis[0] * dir[2];
        axis[2] = zaxis[0] * dir[1] - zaxis[1] * dir[0];
        normalize(axis);
        mat_axis_rotate(mx, axis, acos(zaxis[0] * dir[0] + zaxis[1] * dir[1] + zaxis[2] * dir[2]));
    }

    /* Children sit at parent radius + child radius from the parent centre */
    scale = c[3] * (1.0 + dir[3]);
    for (k = 0; k < 9; k++) {
        double child[4], cdir[4];
        xform_coord(child, objset[k], mx);
        child[0] = child[0] * scale + c[0];
        child[1] = child[1] * scale + c[1];
        child[2] = child[2] * scale + c[2];
        child[3] = c[3] * dir[3];
        cdir[0] = (child[0] - c[0]) / scale;
        cdir[1] = (child[1] - c[1]) / scale;
        cdir[2] = (child[2] - c[2]) / scale;
        cdir[3] = dir[3];
        SPD_TRY(balls_grow(s, objset, depth, child, cdir));
    }
    return MPRT_OK;
}

/* The 9 child directions around +Z: a trio tilted off the equator, repeated
 * at three turns of 120 degrees about Z. */
static void balls_objset(double objset[9][4])
{
    double trio[3][4], axis[3], d = 1.0 / sqrt(2.0);
    spd_mat mx;
    int set, v, j;

    trio[0][0] = d;   trio[0][1] = d;   trio[0][2] = 0.0; trio[0][3] = 0.0;
    trio[1][0] = d;   trio[1][1] = 0.0; trio[1][2] = -d;  trio[1][3] = 0.0;
    trio[2][0] = 0.0; trio[2][1] = d;   trio[2][2] = -d;  trio[2][3] = 0.0;
    set3(axis, 1.0, -1.0, 0.0);
    normalize(axis);
    mat_axis_rotate(mx, axis, asin(2.0 / sqrt(6.0)));
    for (v = 0; v < 3; v++) {
        double t[4];
        xform_coord(t, trio[v], mx);
        for (j = 0; j < 4; j++) trio[v][j] = t[j];
    }
    for (set = 0; set < 3; set++) {
        mat_rotate(mx, SPD_Z_AXIS, set * 2.0 * SPD_PI / 3.0);
        for (v = 0; v < 3; v++) xform_coord(objset[set * 3 + v], trio[v], mx);
    }
}

static int gen_balls(mprt_scene *s, int size)
{
    double from[3], at[3], up[3], floor_pts[4][3], objset[9][4];
    double center[4] = {0.0, 0.0, 0.0, 0.5}, dir[4] = {0.0, 0.0, 1.0, 1.0 / 3.0};
    const double radius = 1.0;

    set3(from, 2.1, 1.3, 1.7);
    set3(at, 0.0, 0.0, 0.0);
    set3(up, 0.0, 0.0, 1.0);
    SPD_TRY(out_header(s, from, at, up, 0.01));
    SPD_TRY(out_light(s, 4.0, 3.0, 2.0));
    SPD_TRY(out_light(s, 1.0, -4.0, 4.0));
    SPD_TRY(out_light(s, -3.0, 1.0, 5.0));

    /* Beige floor square under the flake */
    SPD_TRY(out_surface(s, 1.0, 0.75, 0.33, 0.8, 0.0, 0.0, 0.0, 1.0));
    set3(floor_pts[0], 12.0 * radius, 12.0 * radius, -radius / 2.0);
    set3(floor_pts[1], -12.0 * radius, 12.0 * radius, -radius / 2.0);
    set3(floor_pts[2], -12.0 * radius, -12.0 * radius, -radius / 2.0);
    set3(floor_pts[3], 12.0 * radius, -12.0 * radius, -radius / 2.0);
    SPD_TRY(out_polygon(s, 4, floor_pts));

    /* Mirrored spheres */
    SPD_TRY(out_surface(s, 1.0, 0.9, 0.7, 0.5, 0.5, 37.0, 0.0, 1.0));
    balls_objset(objset);
    return balls_grow(s, objset, size, center, dir);
}

/* ---- gears: a cube of meshing gears over a reflective floor -------------- */

#define GEAR_TEETH 36
#define GEAR_EDGE_DIFF (1.0 - 0.9)

/* Four face vertices of one tooth: two on the outer rim, two at the root. */
static void gear_tooth(double gear_angle, double tooth_angle, const double center[3],
                       const double outer[3], const double inner[3], double (*pts)[3])
{
    double angle[4];
    spd_mat mx;
    int k;
    angle[0] = gear_angle - 0.19 * tooth_angle;
    angle[1] = gear_angle + 0.19 * tooth_angle;
    angle[2] = gear_angle + 0.3 * tooth_angle;
    angle[3] = gear_angle + 0.7 * tooth_angle;
    for (k = 0; k < 4; k++) {
        mat_rotate(mx, SPD_Z_AXIS, angle[k]);
        xform_vector(pts[k], k < 2 ? outer : inner, mx);
        pts[k][0] += center[0];
        pts[k][1] += center[1];
        pts[k][2] += center[2];
    }
}

/* One gear: top face (144-gon), 144 side rectangles, bottom face. */
static int gear_make(mprt_scene *s, const double center[3], double offset_angle, double outer_r,
                     double inner_r, double thickness)
{
    double pts[4 * GEAR_TEETH][3], side[4][3], outer[3], inner[3];
    double tooth_angle = 2.0 * SPD_PI / (double)GEAR_TEETH;
    int t, k;

    set3(outer, outer_r, 0.0, 0.0);
    set3(inner, inner_r, 0.0, 0.0);
    for (t = 0; t < GEAR_TEETH; t++) {
        double ga = offset_angle + 2.0 * SPD_PI * (double)t / (double)GEAR_TEETH;
        gear_tooth(ga, tooth_angle, center, outer, inner, &pts[t * 4]);
    }
    SPD_TRY(out_polygon(s, 4 * GEAR_TEETH, pts));

    /* Side walls: each face edge extruded down by the thickness */
    for (k = 0; k < 4 * GEAR_TEETH; k++) {
        int next = (k + 1) % (4 * GEAR_TEETH);
        memcpy(side[0], pts[k], sizeof side[0]);
        memcpy(side[1], pts[k], sizeof side[1]);
        side[1][2] -= thickness;
        memcpy(side[2], pts[next], sizeof side[2]);
        side[2][2] -= thickness;
        memcpy(side[3], pts[next], sizeof side[3]);
        SPD_TRY(out_polygon(s, 4, side));
    }

    /* Bottom face, wound the other way.  The original rotates its vertices
     * afresh by negative angles; those are the side walls' lower vertices in
     * reverse order (bottom j = top 1-j), equal to within an ulp.  Reusing
     * the walls' values makes each gear a closed, crack-free mesh. */
    {
        double bottom[4 * GEAR_TEETH][3];
        for (k = 0; k < 4 * GEAR_TEETH; k++) {
            memcpy(bottom[k], pts[(1 - k + 4 * GEAR_TEETH) % (4 * GEAR_TEETH)], sizeof bottom[k]);
            bottom[k][2] -= thickness;
        }
        return out_polygon(s, 4 * GEAR_TEETH, bottom);
    }
}

/* Fractional part by truncation toward zero, as the SPD macro does. */
static double spd_fraction(double a) { return a - (double)(int)a; }

static int gen_gears(mprt_scene *s, int size)
{
    double from[3], at[3], up[3], ground[4][3], zero[3], offset[3], center[3];
    double outer_r, thickness, sf = (double)size;
    int ix, iy, iz;

    set3(from, -1.1, -2.1, 2.6);
    set3(at, 0.0, 0.0, 0.0);
    set3(up, 0.0, 0.0, 1.0);
    SPD_TRY(out_header(s, from, at, up, 1.0));
    SPD_TRY(out_light(s, 2.0, 4.0, 4.0));
    SPD_TRY(out_light(s, -2.0, 4.0, 3.0));
    SPD_TRY(out_light(s, 2.0, -2.5, 2.5));
    SPD_TRY(out_light(s, -1.0, -4.0, 2.0));
    SPD_TRY(out_light(s, -1.111, -2.121, 2.626));

    /* Off-white reflective ground square */
    SPD_TRY(out_surface(s, 1.0, 0.85, 0.7, 0.3, 0.6, 37.0, 0.0, 0.0));
    set3(ground[0], 2.0, 2.0, 0.0);
    set3(ground[1], -2.0, 2.0, 0.0);
    set3(ground[2], -2.0, -2.0, 0.0);
    set3(ground[3], 2.0, -2.0, 0.0);
    SPD_TRY(out_polygon(s, 4, ground));

    /* Gear lattice: size^3 gears filling [-1,1]^2 in layers going down from z=1 */
    outer_r = 1.0 / (sf - (double)(size - 1) * GEAR_EDGE_DIFF / 2.0);
    zero[0] = zero[1] = -1.0 + outer_r;
    zero[2] = 1.0;
    offset[0] = offset[1] = outer_r * (2.0 - GEAR_EDGE_DIFF);
    offset[2] = -1.0 / sf;
    thickness = 0.1 < 1.0 / (2.0 * sf) ? 0.1 : 1.0 / (2.0 * sf);

    for (iz = 0; iz < size; iz++) {
        center[2] = zero[2] + (double)iz * offset[2];
        for (iy = 0; iy < size; iy++) {
            center[1] = zero[1] + (double)iy * offset[1];
            for (ix = 0; ix < size; ix++) {
                double col[3], cmax, angle;
                center[0] = zero[0] + (double)ix * offset[0];

                /* Pseudo-random colour, scaled so its largest channel is 1 */
                col[0] = 0.01 + spd_fraction((double)(ix * 3 + iy * 2 + iz + 1) * 5.0 / 7.0);
                col[1] = 0.01 + spd_fraction((double)(iy * 3 + iz * 2 + ix + 1) * 3.0 / 7.0);
                col[2] = 0.01 + spd_fraction((double)(iz * 3 + ix * 2 + iy + 1) * 2.0 / 7.0);
                cmax = col[0] > col[1] ? col[0] : col[1];
                cmax = cmax > col[2] ? cmax : col[2];
                col[0] /= cmax;
                col[1] /= cmax;
                col[2] /= cmax;
                if ((ix * 4 + iy * 2 + iz) % 5 == 0)
                    SPD_TRY(out_surface(s, col[0], col[1], col[2], 0.2, 0.0, 0.0, 0.8, 1.1));
                else
                    SPD_TRY(out_surface(s, col[0], col[1], col[2], 1.0, 0.0, 0.0, 0.0, 0.0));

                /* Neighbours are turned half a tooth so the teeth mesh */
                angle = SPD_PI * (double)((ix + iy + iz) % 2) / (double)GEAR_TEETH;
                SPD_TRY(gear_make(s, center, angle, 0.995 * outer_r, (1.0 - GEAR_EDGE_DIFF) * outer_r,
                                  thickness));
            }
        }
    }
    return MPRT_OK;
}

/* ---- mount: fractal mountain with four glass spheres --------------------- */

#define MOUNT_NO 21

typedef struct {
    mprt_scene *scene;
    int size;
    double npts;      /* grid cells per side, as a double */
    double roughness;
} mount_ctx;

/* Shift left, where a negative count (size factors above 7 in the original
 * program) contributes nothing: on the reference x86-64 build the count is
 * taken mod 64, which moves every bit above the 16 that the hash keeps. */
static unsigned long long mount_shl(unsigned long long v, int n)
{
    return n < 0 || n > 63 ? 0ULL : v << n;
}

/* The original (1987) hash of a grid point into a 16-bit seed. */
static long mount_hash(int a, int b, int c)
{
    unsigned long long ua = (unsigned long long)a, ub = (unsigned long long)b;
    return (long)((mount_shl(ua, 23 - c) + mount_shl(ub, 15 - c) + mount_shl(ua, 7 - c)) & 0xffffULL);
}

/* SPD's portable Gaussian deviate (polar method over a small LCG) for a seed. */
static double mount_gauss(long seed)
{
    long ix1, ix2 = seed;
    double v1, v2, r;
    do {
        ix1 = (28411L + ix2 * 8121L) % 134456L;
        ix2 = (28411L + ix1 * 8121L) % 134456L;
        v1 = (double)ix1 * 2.0 * 1.0 / 134456.0 - 1.0;
        v2 = (double)ix2 * 2.0 * 1.0 / 134456.0 - 1.0;
        r = v1 * v1 + v2 * v2;
    } while (r >= 1.0);
    return v1 * sqrt(-2.0 * log(r) / r);
}

/* Displacement at the grid point (x, y). */
static double mount_rand(const mount_ctx *m, int x, int y)
{
    return mount_gauss(MOUNT_NO + mount_hash(x, y, m->size));
}

/* Carpenter subdivision of the square with lower-left grid corner (x, y) and
 * corner heights ll, lr, ur, ul; unit squares become two triangles. */
static int mount_grow(const mount_ctx *m, int width, int x, int y, double ll, double lr, double ur,
                      double ul)
{
    if (width == 1) {
        double lx = -1.0 + (double)x * 2.0 / m->npts, rx = -1.0 + (double)(x + 1) * 2.0 / m->npts;
        double ly = -1.0 + (double)y * 2.0 / m->npts, uy = -1.0 + (double)(y + 1) * 2.0 / m->npts;
        double corner[4][3], tri[3][3];
        int t, v;
        set3(corner[0], lx, ly, ll);
        set3(corner[1], rx, ly, lr);
        set3(corner[2], rx, uy, ur);
        set3(corner[3], lx, uy, ul);
        for (t = 0; t < 2; t++) {
            for (v = 0; v < 3; v++) memcpy(tri[v], corner[(v + t * 2) % 4], sizeof tri[v]);
            SPD_TRY(out_polygon(m->scene, 3, tri));
        }
        return MPRT_OK;
    } else {
        int h = width >> 1;
        double rise = (double)h * 2.0 / m->npts * m->roughness;
        double lower, right, upper, left, middle;

        /* Edge midpoints and centre, each displaced by its own seeded deviate */
        lower = (ll + lr) / 2.0 + rise * mount_rand(m, x + h, y);
        right = (lr + ur) / 2.0 + rise * mount_rand(m, x + width, y + h);
        upper = (ur + ul) / 2.0 + rise * mount_rand(m, x + h, y + width);
        left = (ul + ll) / 2.0 + rise * mount_rand(m, x, y + h);
        middle = (ll + lr + ur + ul) / 4.0 + 1.4142136 * rise * mount_rand(m, x + h, y + h);

        SPD_TRY(mount_grow(m, h, x, y, ll, lower, middle, left));
        SPD_TRY(mount_grow(m, h, x + h, y, lower, lr, right, middle));
        SPD_TRY(mount_grow(m, h, x + h, y + h, middle, right, ur, upper));
        return mount_grow(m, h, x, y + h, left, middle, upper, ul);
    }
}

/* Pyramid of four touching spheres: one on top, three below at 120 degrees. */
static int mount_spheres(mprt_scene *s, const double c[4])
{
    double axis[3], pt[3], top[3], new_pt[3], p[3];
    spd_mat mx;
    int i;

    set3(axis, 1.0, 1.0, 0.0);
    normalize(axis);
    set3(pt, 0.0, 0.0, c[3] * sqrt(3.0 / 2.0));
    set3(top, c[0] + pt[0], c[1] + pt[1], c[2] + pt[2]);
    SPD_TRY(out_sphere(s, top, c[3]));

    mat_axis_rotate(mx, axis, acos(-1.0 / 3.0));
    xform_vector(new_pt, pt, mx);
    for (i = 0; i < 3; i++) {
        mat_rotate(mx, SPD_Z_AXIS, (double)i * 2.0 * SPD_PI / 3.0);
        xform_vector(p, new_pt, mx);
        p[0] += c[0];
        p[1] += c[1];
        p[2] += c[2];
        SPD_TRY(out_sphere(s, p, c[3]));
    }
    return MPRT_OK;
}

static int gen_mount(mprt_scene *s, int size)
{
    double from[3], at[3], up[3], center[4] = {-0.8, 0.8, 1.0, 0.17}, ratio;
    mount_ctx m;
    int npts = 1 << size;

    set3(from, -1.6, 1.6, 1.7);
    set3(at, 0.0, 0.0, 0.0);
    set3(up, 0.0, 0.0, 1.0);
    SPD_TRY(out_header(s, from, at, up, 0.01));
    SPD_TRY(out_light(s, -100.0, -100.0, 100.0));

    /* Clear glass spheres */
    SPD_TRY(out_surface(s, 1.0, 1.0, 1.0, 0.1, 0.1, 6.7, 0.9, 1.5));
    SPD_TRY(mount_spheres(s, center));

    /* Grey mountain over [-1,1]^2, fractal dimension 2.2 */
    SPD_TRY(out_surface(s, 0.5, 0.45, 0.35, 1.0, 0.0, 0.0, 0.0, 0.0));
    ratio = 2.0 / exp(log(2.0) / (2.2 - 1.0));
    m.scene = s;
    m.size = size;
    m.npts = (double)npts;
    m.roughness = sqrt(ratio * ratio - 1.0);
    return mount_grow(&m, npts, 0, 0, 0.0, 0.0, 0.0, 0.0);
}

/* ---- rings: pyramid of dodecahedral ring objects ------------------------- */

/* The 30 edge midpoints of a dodecahedron (6 pentagons of 5) scaled so the
 * object with tube radius minor_r fits in the unit sphere. */
static void rings_dodec(double minor_r, double v[30][3])
{
    double scale = 1.0 / (1.0 + minor_r), tmp[3];
    spd_mat xm, zm;
    int k, p;

    /* First pentagon in the XY plane, starting on +X */
    for (k = 0; k < 5; k++) {
        v[k][0] = scale * cos((double)k * 2.0 * SPD_PI / 5.0);
        v[k][1] = scale * sin((double)k * 2.0 * SPD_PI / 5.0);
        v[k][2] = 0.0;
    }

    /* The other five: tip by the dihedral angle about X, then turn about Z */
    mat_rotate(xm, SPD_X_AXIS, 2.0 * acos(cos(SPD_PI / 3.0) / sin(SPD_PI / 5.0)));
    for (p = 1; p < 6; p++) {
        mat_rotate(zm, SPD_Z_AXIS, SPD_PI * (2.0 * (double)(p - 1) + 1.0) / 5.0);
        for (k = 0; k < 5; k++) {
            xform_point(tmp, v[k], xm);
            xform_point(v[5 * p + k], tmp, zm);
        }
    }
}

static int gen_rings(mprt_scene *s, int size)
{
    static const double ring_rgb[6][3] = {
        {1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0},
        {0.0, 1.0, 1.0}, {1.0, 0.0, 1.0}, {1.0, 1.0, 0.0}};
    const double radius = 0.07412, spread_out = 1.0;
    double from[3], at[3], up[3], wall[4][3], w[3], dodec[30][3], offset[3];
    double spread = 1.0 / sin(SPD_PI / 8.0), y_diff, xz_diff;
    int depth, oz, ox, e;

    /* Layer spacing: layers spread along +Y, objects 2 apart in X and Z */
    if (spread_out <= spread) {
        y_diff = spread / spread_out;
        xz_diff = 1.0;
    } else {
        y_diff = 1.0;
        xz_diff = spread_out / spread;
    }

    set3(from, -1.0, -spread, 0.5);
    set3(at, from[0], from[1] + 1.0, from[2]);
    set3(up, 0.0, 0.0, 1.0);
    SPD_TRY(out_header(s, from, at, up, 1.0));
    SPD_TRY(out_light(s, 3.0, -spread, 3.0));
    SPD_TRY(out_light(s, -4.0, -spread, 1.0));
    SPD_TRY(out_light(s, 2.0, -spread, -4.0));

    /* White backdrop just spanning the 45 degree view plus 1% */
    SPD_TRY(out_surface(s, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0));
    w[1] = y_diff * (double)(size + 1);
    w[0] = w[2] = 1.01 * (w[1] - from[1]) * tan(SPD_PI / 8.0);
    set3(wall[0], w[0] + from[0], w[1], w[2] + from[2]);
    set3(wall[1], -w[0] + from[0], w[1], w[2] + from[2]);
    set3(wall[2], -w[0] + from[0], w[1], -w[2] + from[2]);
    set3(wall[3], w[0] + from[0], w[1], -w[2] + from[2]);
    SPD_TRY(out_polygon(s, 4, wall));

    /* Layer d holds (d+1)^2 objects; each ring is 5 cylinders with sphere joints */
    rings_dodec(radius, dodec);
    for (depth = 0; depth < size; depth++) {
        offset[1] = y_diff * (double)(depth + 1);
        for (oz = 0; oz <= depth; oz++) {
            offset[2] = xz_diff * (double)(2 * oz - depth);
            for (ox = 0; ox <= depth; ox++) {
                offset[0] = xz_diff * (double)(2 * ox - depth);
                for (e = 0; e < 30; e++) {
                    double base[3], apex[3];
                    int prev;
                    set3(base, dodec[e][0] + offset[0], dodec[e][1] + offset[1], dodec[e][2] + offset[2]);
                    if (e % 5 == 0) {
                        prev = e + 4;
                        SPD_TRY(out_surface(s, ring_rgb[e / 5][0], ring_rgb[e / 5][1], ring_rgb[e / 5][2],
                                            0.5, 0.2, 37.0, 0.0, 0.0));
                    } else {
                        prev = e - 1;
                    }
                    set3(apex, dodec[prev][0] + offset[0], dodec[prev][1] + offset[1],
                         dodec[prev][2] + offset[2]);
                    SPD_TRY(out_cone(s, base, radius, apex, radius));
                    SPD_TRY(out_sphere(s, base, radius));
                }
            }
        }
    }
    return MPRT_OK;
}

/* ---- tetra: Sierpinski tetrahedron --------------------------------------- */

/* Tetrahedron inscribed in the cube of half-size c[3] around c: recurse into
 * the 4 half-size ones at alternate corners, or at depth 1 write 4 faces. */
static int tetra_grow(mprt_scene *s, int depth, const double c[4])
{
    int x, y, z;
    if (depth <= 1) {
        double corner[4][3], face[3][3];
        int n = 0, f, v, ord[3];
        for (x = -1; x <= 1; x += 2)
            for (y = -1; y <= 1; y += 2)
                for (z = -1; z <= 1; z += 2)
                    if (x * y * z == 1) {
                        set3(corner[n], c[0] + (double)x * c[3], c[1] + (double)y * c[3],
                             c[2] + (double)z * c[3]);
                        n++;
                    }
        /* Faces 012, 321, 230, 103: outward winding */
        for (f = 0; f < 4; f++) {
            for (v = 0; v < 3; v++) ord[v] = (f + v) % 4;
            if (f % 2 == 1) {
                int t = ord[0];
                ord[0] = ord[2];
                ord[2] = t;
            }
            for (v = 0; v < 3; v++) memcpy(face[v], corner[ord[v]], sizeof face[v]);
            SPD_TRY(out_polygon(s, 3, face));
        }
        return MPRT_OK;
    }
    for (x = -1; x <= 1; x += 2)
        for (y = -1; y <= 1; y += 2)
            for (z = -1; z <= 1; z += 2)
                if (x * y * z == 1) {
                    double sub[4];
                    sub[0] = c[0] + (double)x * c[3] / 2.0;
                    sub[1] = c[1] + (double)y * c[3] / 2.0;
                    sub[2] = c[2] + (double)z * c[3] / 2.0;
                    sub[3] = c[3] / 2.0;
                    SPD_TRY(tetra_grow(s, depth - 1, sub));
                }
    return MPRT_OK;
}

static int gen_tetra(mprt_scene *s, int size)
{
    double from[3], at[3], up[3], center[4] = {0.0, 0.0, 0.0, 1.0};

    set3(from, 1.022846, -3.177154, -2.174512);
    set3(at, -0.004103, -0.004103, 0.216539);
    set3(up, -0.816497, -0.816497, 0.816497);
    SPD_TRY(out_header(s, from, at, up, 1.0));
    SPD_TRY(out_light(s, 2.0, -18.0, -5.0));
    SPD_TRY(out_surface(s, 1.0, 0.2, 0.2, 1.0, 0.0, 0.0, 0.0, 0.0));
    return tetra_grow(s, size, center);
}

/* ---- tree: Aono & Kunii branching tree ------------------------------------ */

/* One branch: a cone along the local +Z unit segment capped by a sphere at
 * the tip, then the two child branches, each placed by its own matrix. */
static int tree_grow(mprt_scene *s, spd_mat branch[2], spd_mat cur, double scale, int depth)
{
    static const double origin[3] = {0.0, 0.0, 0.0}, tip[3] = {0.0, 0.0, 1.0};
    double base[3], apex[3], rb, ra;
    int i;

    xform_point(base, origin, cur);
    rb = scale * 0.15;
    xform_point(apex, tip, cur);
    ra = rb * 0.67;
    SPD_TRY(out_cone(s, base, rb, apex, ra));
    SPD_TRY(out_sphere(s, apex, ra));
    if (depth <= 0) return MPRT_OK;
    for (i = 0; i < 2; i++) {
        spd_mat next;
        mat_mul(next, branch[i], cur);
        SPD_TRY(tree_grow(s, branch, next, scale * 0.67, depth - 1));
    }
    return MPRT_OK;
}

static int gen_tree(mprt_scene *s, int size)
{
    double from[3], at[3], up[3], field[4][3];
    spd_mat branch[2], rx, rz, rot, st, ident;
    int i;

    set3(from, 4.5, 0.4, 2.0);
    set3(at, 0.0, 0.0, 1.5);
    set3(up, 0.0, 0.0, 1.0);
    SPD_TRY(out_header(s, from, at, up, 1.0));
    SPD_TRY(out_light(s, -5.0, 5.0, 50.0));
    SPD_TRY(out_light(s, 30.0, -30.0, 30.0));
    SPD_TRY(out_light(s, -40.0, -30.0, 20.0));
    SPD_TRY(out_light(s, 10.0, 30.0, 40.0));
    SPD_TRY(out_light(s, -30.0, 40.0, 10.0));
    SPD_TRY(out_light(s, 50.0, 25.0, 20.0));
    SPD_TRY(out_light(s, -10.0, -60.0, 30.0));

    /* Green field */
    SPD_TRY(out_surface(s, 0.2, 0.7, 0.2, 1.0, 0.0, 0.0, 0.0, 0.0));
    set3(field[0], 50.0, 50.0, 0.0);
    set3(field[1], -50.0, 50.0, 0.0);
    set3(field[2], -50.0, -50.0, 0.0);
    set3(field[3], 50.0, -50.0, 0.0);
    SPD_TRY(out_polygon(s, 4, field));

    /* Brown tree */
    SPD_TRY(out_surface(s, 0.55, 0.4, 0.2, 1.0, 0.0, 0.0, 0.0, 0.0));

    /* Child placement: tilt about X by the branch angle, turn about Z by the
     * divergence, shrink by the contraction, and move to the parent's tip */
    for (i = 0; i < 2; i++) {
        double br_angle = i == 0 ? 40.0 : 25.0;
        double divergence = i == 0 ? 90.0 : 140.0 + 90.0;
        double contraction = i == 0 ? 0.65 : 0.70;
        mat_rotate(rx, SPD_X_AXIS, br_angle * SPD_PI / 180.0);
        mat_rotate(rz, SPD_Z_AXIS, divergence * SPD_PI / 180.0);
        mat_mul(rot, rx, rz);
        mat_identity(st);
        st[0][0] = contraction;
        st[1][1] = contraction;
        st[2][2] = contraction;
        st[3][2] = 1.0;
        mat_mul(branch[i], rot, st);
    }
    mat_identity(ident);
    return tree_grow(s, branch, ident, 1.0, size);
}

/* ---- Entry point ----------------------------------------------------------- */

typedef struct {
    const char *name;
    int def_size;  /* SPD default size factor */
    int max_size;  /* largest size with fewer than 50 million primitives */
    int (*gen)(mprt_scene *, int);
} spd_entry;

/* Primitive counts at the maxima: balls (9^9-1)/8+1 = 48.4M, gears
 * 69^3*146+1 = 48.0M, mount 2*4^12+4 = 33.6M, rings 10*135*136*271+1 = 49.8M,
 * tetra 4^12 = 16.8M, tree 2^25-1 = 33.6M. */
static const spd_entry spd_table[] = {
    {"balls", 4, 8, gen_balls},
    {"gears", 4, 69, gen_gears},
    {"mount", 6, 12, gen_mount},
    {"rings", 7, 135, gen_rings},
    {"tetra", 6, 12, gen_tetra},
    {"tree", 11, 23, gen_tree},
};

int mprt__spd_generate(mprt_scene *scene, const char *name, int size)
{
    size_t i;
    if (!scene) return MPRT_ERR_INVALID_ARG;
    if (!name)
        return mprt__scene_fail(scene, MPRT_ERR_INVALID_ARG,
                                "spd: no scene name (expected balls, gears, mount, rings, tetra or tree)");
    for (i = 0; i < sizeof spd_table / sizeof spd_table[0]; i++) {
        const spd_entry *e = &spd_table[i];
        if (strcmp(name, e->name) != 0) continue;
        if (size <= 0) size = e->def_size;
        if (size > e->max_size)
            return mprt__scene_fail(scene, MPRT_ERR_INVALID_ARG,
                                    "spd: size %d is too large for %s (allowed 1..%d, or <= 0 for the default %d)",
                                    size, e->name, e->max_size, e->def_size);
        return e->gen(scene, size);
    }
    return mprt__scene_fail(scene, MPRT_ERR_INVALID_ARG,
                            "spd: unknown scene '%.100s' (expected balls, gears, mount, rings, tetra or tree)",
                            name);
}
