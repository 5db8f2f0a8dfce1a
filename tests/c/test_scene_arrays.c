/* test_scene_arrays.c: a scene's shapes, materials and lights read back as
 * arrays: the values given, and all the renderer uses (a scene rebuilt from
 * them renders the same bits). */
#include "check.h"
#include "mprt.h"

#include <stdlib.h>
#include <string.h>

/* Values exact in float too, so MPRT_SINGLE builds return them unchanged. */
static const double mat_a[8] = {1, 0.5, 0.25, 0.75, 0.125, 3, 0, 1};
static const double mat_b[8] = {0.5, 0.5, 1, 0.25, 0.5, 8, 0.5, 1.5};
static const double sphere0[4] = {1, 2, 3, 0.5}, sphere1[4] = {-1, 0.25, 4, 2};
static const double cone[8] = {0, 0, 0, 1, 0, 0, 2, 0.5}, cylinder[8] = {1, 1, 1, 0.75, 1, 3, 1, 0.75};
static const double tri[9] = {0, 0, 5, 1, 0, 5, 0, 1, 5};
static const double quad[12] = {0, 0, -1, 2, 0, -1, 2, 2, -1, 0, 2, -1};
static const double quad_normals[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
static const double light0[6] = {10, 10, 10, 0.5, 0.25, 1}, light1_pos[3] = {-10, 5, 0};

/* Ids: 0 sphere0, 1 cone, 2 tri, 3 cylinder, 4 sphere1, 5 quad. */
static mprt_scene *hand_scene(void)
{
    mprt_scene *s;
    mprt_scene_create(&s);
    CHECK(mprt_scene_set_material(s, mat_a, mat_a[3], mat_a[4], mat_a[5], mat_a[6], mat_a[7]) == MPRT_OK);
    CHECK(mprt_scene_add_sphere(s, sphere0, sphere0[3]) == MPRT_OK);
    CHECK(mprt_scene_add_cone(s, cone, cone[3], cone + 4, cone[7]) == MPRT_OK);
    CHECK(mprt_scene_add_polygon(s, 3, tri, NULL) == MPRT_OK);
    CHECK(mprt_scene_add_cone(s, cylinder, cylinder[3], cylinder + 4, cylinder[7]) == MPRT_OK);
    CHECK(mprt_scene_set_material(s, mat_b, mat_b[3], mat_b[4], mat_b[5], mat_b[6], mat_b[7]) == MPRT_OK);
    CHECK(mprt_scene_add_sphere(s, sphere1, sphere1[3]) == MPRT_OK);
    CHECK(mprt_scene_add_polygon(s, 4, quad, quad_normals) == MPRT_OK);
    CHECK(mprt_scene_add_light(s, light0, light0 + 3) == MPRT_OK);
    CHECK(mprt_scene_add_light(s, light1_pos, NULL) == MPRT_OK);
    return s;
}

static void test_shapes_come_back_by_kind_in_id_order(void)
{
    mprt_scene *s = hand_scene();
    int32_t ids[4], vstart[3];
    double data[16], verts[3 * 7];
    int i;
    CHECK(mprt_scene_get_spheres(s, ids, data, 2) == MPRT_OK);
    CHECK(ids[0] == 0 && ids[1] == 4);
    CHECK(memcmp(data, sphere0, sizeof sphere0) == 0 && memcmp(data + 4, sphere1, sizeof sphere1) == 0);
    CHECK(mprt_scene_get_cones(s, ids, data, 2) == MPRT_OK); /* a cone and a cylinder */
    CHECK(ids[0] == 1 && ids[1] == 3);
    CHECK(memcmp(data, cone, sizeof cone) == 0 && memcmp(data + 8, cylinder, sizeof cylinder) == 0);
    CHECK(mprt_scene_get_polygons(s, ids, vstart, 2, verts, 7) == MPRT_OK);
    CHECK(ids[0] == 2 && ids[1] == 5);
    CHECK(vstart[0] == 0 && vstart[1] == 3 && vstart[2] == 7);
    CHECK(memcmp(verts, tri, sizeof tri) == 0 && memcmp(verts + 9, quad, sizeof quad) == 0);
    for (i = 0; i < 4; i++) ids[i] = -7;
    CHECK(mprt_scene_get_spheres(s, ids, data, 1) == MPRT_ERR_CAPACITY);
    CHECK(mprt_scene_get_cones(s, ids, data, 1) == MPRT_ERR_CAPACITY);
    CHECK(mprt_scene_get_polygons(s, ids, vstart, 1, verts, 7) == MPRT_ERR_CAPACITY);
    CHECK(mprt_scene_get_polygons(s, ids, vstart, 2, verts, 6) == MPRT_ERR_CAPACITY);
    CHECK(ids[0] == -7); /* nothing written on failure */
    CHECK(mprt_scene_get_spheres(s, NULL, data, 2) == MPRT_ERR_INVALID_ARG);
    mprt_scene_destroy(s);
}

static void test_materials_and_lights_are_what_the_renderer_uses(void)
{
    mprt_scene *s = hand_scene();
    double m[16], l[12];
    CHECK(mprt_scene_get_materials(s, m, 2) == MPRT_OK);
    CHECK(memcmp(m, mat_a, sizeof mat_a) == 0 && memcmp(m + 8, mat_b, sizeof mat_b) == 0);
    CHECK(mprt_scene_get_lights(s, l, 2) == MPRT_OK);
    CHECK(memcmp(l, light0, sizeof light0) == 0 && memcmp(l + 6, light1_pos, sizeof light1_pos) == 0);
    /* NFF: a light without a colour shines 1/sqrt(number of lights) */
    CHECK(l[9] == 1 / sqrt(2.0) && l[10] == l[9] && l[11] == l[9]);
    CHECK(mprt_scene_get_materials(s, m, 1) == MPRT_ERR_CAPACITY);
    CHECK(mprt_scene_get_lights(s, l, 1) == MPRT_ERR_CAPACITY);
    mprt_scene_destroy(s);
}

static void test_an_empty_scene_gives_empty_arrays(void)
{
    mprt_scene *s;
    int32_t vstart[1] = {-1};
    mprt_scene_create(&s);
    CHECK(mprt_scene_get_spheres(s, NULL, NULL, 0) == MPRT_OK);
    CHECK(mprt_scene_get_cones(s, NULL, NULL, 0) == MPRT_OK);
    CHECK(mprt_scene_get_polygons(s, NULL, vstart, 0, NULL, 0) == MPRT_OK);
    CHECK(vstart[0] == 0);
    CHECK(mprt_scene_get_materials(s, NULL, 0) == MPRT_OK);
    CHECK(mprt_scene_get_lights(s, NULL, 0) == MPRT_OK);
    CHECK(mprt_scene_get_spheres(NULL, NULL, NULL, 0) == MPRT_ERR_INVALID_ARG);
    mprt_scene_destroy(s);
}

/* The white diffuse material a primitive gets before any "f". */
static void test_the_default_material_is_listed(void)
{
    static const double white[8] = {1, 1, 1, 1, 0, 0, 0, 1};
    mprt_scene *s;
    double m[8];
    mprt_scene_create(&s);
    CHECK(mprt_scene_add_sphere(s, sphere0, 1) == MPRT_OK);
    CHECK(mprt_scene_get_materials(s, m, 1) == MPRT_OK);
    CHECK(memcmp(m, white, sizeof white) == 0);
    mprt_scene_destroy(s);
}

/* A copy of s made only from the arrays (and info's view and background). */
static mprt_scene *rebuild(const mprt_scene *s)
{
    mprt_scene_info info;
    mprt_scene *c;
    int32_t *kind, *words, *mat, *sid, *cid, *pid, *vstart;
    double *sph, *con, *verts, *mats, *lights;
    long long np, ns, nc, npoly, i, is = 0, ic = 0, ip = 0;
    int cur = -1;
    mprt_scene_get_info(s, &info);
    np = info.prims;
    ns = info.count[MPRT_SPHERE];
    nc = info.count[MPRT_CYLINDER] + info.count[MPRT_CONE];
    npoly = info.count[MPRT_POLYGON];
    kind = malloc((size_t)np * sizeof *kind);
    words = malloc((size_t)np * sizeof *words);
    mat = malloc((size_t)np * sizeof *mat);
    sid = malloc((size_t)(ns + 1) * sizeof *sid);
    cid = malloc((size_t)(nc + 1) * sizeof *cid);
    pid = malloc((size_t)(npoly + 1) * sizeof *pid);
    vstart = malloc((size_t)(npoly + 1) * sizeof *vstart);
    sph = malloc((size_t)(4 * ns + 1) * sizeof *sph);
    con = malloc((size_t)(8 * nc + 1) * sizeof *con);
    verts = malloc((size_t)(3 * info.vertices + 1) * sizeof *verts);
    mats = malloc((size_t)(8 * info.materials) * sizeof *mats);
    lights = malloc((size_t)(6 * info.lights + 1) * sizeof *lights);
    CHECK(mprt_scene_get_prims(s, kind, words, mat, (size_t)np) == MPRT_OK);
    CHECK(mprt_scene_get_spheres(s, sid, sph, (size_t)ns) == MPRT_OK);
    CHECK(mprt_scene_get_cones(s, cid, con, (size_t)nc) == MPRT_OK);
    CHECK(mprt_scene_get_polygons(s, pid, vstart, (size_t)npoly, verts, (size_t)info.vertices) == MPRT_OK);
    CHECK(mprt_scene_get_materials(s, mats, (size_t)info.materials) == MPRT_OK);
    CHECK(mprt_scene_get_lights(s, lights, (size_t)info.lights) == MPRT_OK);
    mprt_scene_create(&c);
    CHECK(mprt_scene_set_view(c, info.from, info.at, info.up, info.angle, info.hither, info.width, info.height) ==
          MPRT_OK);
    CHECK(mprt_scene_set_background(c, info.background) == MPRT_OK);
    for (i = 0; i < info.lights; i++) CHECK(mprt_scene_add_light(c, lights + 6 * i, lights + 6 * i + 3) == MPRT_OK);
    for (i = 0; i < np; i++) {
        const double *m = mats + 8 * mat[i];
        if (mat[i] != cur) CHECK(mprt_scene_set_material(c, m, m[3], m[4], m[5], m[6], m[7]) == MPRT_OK);
        cur = mat[i];
        if (kind[i] == MPRT_SPHERE) {
            CHECK(sid[is] == i);
            CHECK(mprt_scene_add_sphere(c, sph + 4 * is, sph[4 * is + 3]) == MPRT_OK);
            is++;
        } else if (kind[i] == MPRT_POLYGON) {
            CHECK(pid[ip] == i);
            CHECK(mprt_scene_add_polygon(c, vstart[ip + 1] - vstart[ip], verts + 3 * vstart[ip], NULL) == MPRT_OK);
            ip++;
        } else {
            const double *k = con + 8 * ic;
            CHECK(cid[ic] == i);
            CHECK(mprt_scene_add_cone(c, k, k[3], k + 4, k[7]) == MPRT_OK);
            ic++;
        }
    }
    free(kind); free(words); free(mat); free(sid); free(cid); free(pid); free(vstart);
    free(sph); free(con); free(verts); free(mats); free(lights);
    return c;
}

static void test_a_scene_rebuilt_from_its_arrays_renders_the_same_bits(void)
{
    static const char *const names[6] = {"balls", "gears", "mount", "rings", "tetra", "tree"};
    enum { W = 20, H = 16 };
    int n, rules;
    for (n = 0; n < 6; n++) {
        mprt_scene *s, *c;
        mprt_grid *gs, *gc;
        mprt_scene_info info;
        mprt_scene_create(&s);
        CHECK(mprt_scene_spd(s, names[n], 1) == MPRT_OK);
        mprt_scene_get_info(s, &info);
        CHECK(info.patches == 0); /* vertex normals are not among the arrays */
        c = rebuild(s);
        CHECK(mprt_grid_create(s, 5, 5, 5, 0, &gs) == MPRT_OK);
        CHECK(mprt_grid_create(c, 5, 5, 5, 0, &gc) == MPRT_OK);
        for (rules = MPRT_RULES_PAPER; rules <= MPRT_RULES_SPD; rules++) {
            mprt_render_desc d;
            float a[W * H * 3], b[W * H * 3];
            mprt_counters ca, cb;
            mprt_render_desc_init(&d);
            d.rules = rules;
            d.width = W;
            d.height = H;
            CHECK(mprt_grid_render(gs, &d, a, W * H * 3, &ca) == MPRT_OK);
            CHECK(mprt_grid_render(gc, &d, b, W * H * 3, &cb) == MPRT_OK);
            CHECK_MSG(memcmp(a, b, sizeof a) == 0, "%s rules %d: images differ", names[n], rules);
            CHECK_MSG(memcmp(&ca, &cb, sizeof ca) == 0, "%s rules %d: counters differ", names[n], rules);
        }
        mprt_grid_destroy(gs);
        mprt_grid_destroy(gc);
        mprt_scene_destroy(s);
        mprt_scene_destroy(c);
    }
}

int main(void)
{
    RUN(test_shapes_come_back_by_kind_in_id_order);
    RUN(test_materials_and_lights_are_what_the_renderer_uses);
    RUN(test_an_empty_scene_gives_empty_arrays);
    RUN(test_the_default_material_is_listed);
    RUN(test_a_scene_rebuilt_from_its_arrays_renders_the_same_bits);
    return CHECK_DONE();
}
