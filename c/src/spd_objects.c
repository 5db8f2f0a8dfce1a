/* spd_objects.c: the SPD scenes built from repeated objects: gears (a cube
 * of meshing gears over a reflective floor) and rings (a pyramid of
 * dodecahedral ring objects). */
#include "spd.h"

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

int mprt__spd_gears(mprt_scene *s, int size)
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

int mprt__spd_rings(mprt_scene *s, int size)
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
