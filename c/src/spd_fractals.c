/* spd_fractals.c: the SPD scenes grown by recursion: balls (the
 * sphereflake), mount (a fractal mountain with four glass spheres), tetra
 * (a Sierpinski tetrahedron) and tree (an Aono & Kunii branching tree). */
#include "spd.h"

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

int mprt__spd_balls(mprt_scene *s, int size)
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

int mprt__spd_mount(mprt_scene *s, int size)
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

int mprt__spd_tetra(mprt_scene *s, int size)
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

int mprt__spd_tree(mprt_scene *s, int size)
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
