/* nff_check.h: what the NFF tests share: parsing text and files into
 * scenes, writing them back, and comparing scenes field by field. */
#ifndef MPRT_TEST_NFF_CHECK_H
#define MPRT_TEST_NFF_CHECK_H

#include "mprt_internal.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check.h"

#define REF "../data/spd-reference/"

/* Parse text (NUL-terminated) into a new scene; OUT: status. */
static inline mprt_scene *parse_text(const char *text, const char *name, int *status)
{
    mprt_scene *s = NULL;
    int st;
    mprt_scene_create(&s);
    st = mprt_scene_parse_nff(s, text, strlen(text), name);
    if (status) *status = st;
    return s;
}

/* Parse text that must be valid. */
static inline mprt_scene *parse_ok(const char *text)
{
    int st;
    mprt_scene *s = parse_text(text, "t.nff", &st);
    CHECK_MSG(st == MPRT_OK, "status %d: %s", st, mprt_scene_errmsg(s));
    return s;
}

/* Write a scene to a malloc'd NUL-terminated string. */
static inline char *write_text(const mprt_scene *s)
{
    size_t need = 0, need2 = 0;
    char *buf;
    int st = mprt_scene_write_nff(s, NULL, 0, &need);
    CHECK(st == MPRT_ERR_CAPACITY);
    CHECK(need > 0);
    buf = malloc(need);
    if (!buf) return NULL;
    st = mprt_scene_write_nff(s, buf, need, &need2);
    CHECK(st == MPRT_OK);
    CHECK(need2 == need);
    CHECK(strlen(buf) + 1 == need);
    return buf;
}

static inline int same_real(real a, real b) { return memcmp(&a, &b, sizeof a) == 0; }
static inline int same_double(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }
static inline int same_vec(vec3 a, vec3 b) { return same_real(a.x, b.x) && same_real(a.y, b.y) && same_real(a.z, b.z); }
static inline int near_vec(vec3 a, vec3 b, double tol)
{
    return fabs((double)(a.x - b.x)) <= tol && fabs((double)(a.y - b.y)) <= tol &&
           fabs((double)(a.z - b.z)) <= tol;
}

/* The scene tables of a and b hold the same bits.  Patch normals are compared
 * to ntol only: the scene normalises them when they are added, and
 * normalising a unit vector again can move its last bit. */
static inline void check_same_scene(const char *what, const mprt_scene *a, const mprt_scene *b, double ntol)
{
    long long i;
    int j, bad = 0;
    CHECK_MSG(a->nprims == b->nprims, "%s: prims %lld vs %lld", what, a->nprims, b->nprims);
    CHECK_MSG(a->nspheres == b->nspheres && a->npolygons == b->npolygons && a->ncones == b->ncones &&
                  a->nverts == b->nverts && a->ncylinders == b->ncylinders && a->npatches == b->npatches,
              "%s: counts differ", what);
    CHECK_MSG(a->nmaterials == b->nmaterials && a->material == b->material, "%s: materials %lld vs %lld", what,
              a->nmaterials, b->nmaterials);
    CHECK_MSG(a->nlights == b->nlights, "%s: lights", what);
    if (a->nprims != b->nprims || a->nspheres != b->nspheres || a->npolygons != b->npolygons ||
        a->ncones != b->ncones || a->nverts != b->nverts || a->nmaterials != b->nmaterials ||
        a->nlights != b->nlights)
        return;
    CHECK_MSG(same_vec(a->from, b->from) && same_vec(a->at, b->at) && same_vec(a->up, b->up) &&
                  same_double(a->angle, b->angle) && same_double(a->hither, b->hither) &&
                  a->width == b->width && a->height == b->height,
              "%s: view", what);
    for (j = 0; j < 3; j++) CHECK_MSG(same_double(a->background[j], b->background[j]), "%s: background", what);
    for (i = 0; i < a->nprims; i++)
        if (a->prims[i].kind != b->prims[i].kind || a->prims[i].index != b->prims[i].index ||
            a->prims[i].material != b->prims[i].material)
            bad++;
    for (i = 0; i < a->nspheres; i++)
        if (!same_vec(a->spheres[i].c, b->spheres[i].c) || !same_real(a->spheres[i].r, b->spheres[i].r)) bad++;
    for (i = 0; i < a->npolygons; i++) {
        const mprt__polygon *p = &a->polygons[i], *q = &b->polygons[i];
        if (p->first != q->first || p->n != q->n || p->has_normals != q->has_normals ||
            !same_vec(p->normal, q->normal) || !same_real(p->d, q->d))
            bad++;
    }
    for (i = 0; i < a->nverts; i++)
        if (!same_vec(a->verts[i], b->verts[i])) bad++;
    for (i = 0; i < a->npolygons; i++) {
        const mprt__polygon *p = &a->polygons[i];
        if (!p->has_normals || !a->vnormals || !b->vnormals) continue;
        for (j = 0; j < p->n; j++)
            if (!near_vec(a->vnormals[p->first + j], b->vnormals[p->first + j], ntol)) bad++;
    }
    CHECK_MSG(!a->vnormals == !b->vnormals, "%s: vnormals allocated in one scene only", what);
    for (i = 0; i < a->ncones; i++) {
        const mprt__cone *p = &a->cones[i], *q = &b->cones[i];
        if (!same_vec(p->base, q->base) || !same_vec(p->apex, q->apex) || !same_real(p->rb, q->rb) ||
            !same_real(p->ra, q->ra) || !same_vec(p->w, q->w) || !same_vec(p->u, q->u) ||
            !same_vec(p->v, q->v) || !same_real(p->len, q->len) || !same_real(p->slope, q->slope))
            bad++;
    }
    for (i = 0; i < a->nmaterials; i++) {
        const mprt__material *p = &a->materials[i], *q = &b->materials[i];
        if (!same_double(p->rgb[0], q->rgb[0]) || !same_double(p->rgb[1], q->rgb[1]) ||
            !same_double(p->rgb[2], q->rgb[2]) || !same_double(p->kd, q->kd) || !same_double(p->ks, q->ks) ||
            !same_double(p->shine, q->shine) || !same_double(p->t, q->t) || !same_double(p->ior, q->ior))
            bad++;
    }
    for (i = 0; i < a->nlights; i++) {
        const mprt__light *p = &a->lights[i], *q = &b->lights[i];
        if (!same_vec(p->pos, q->pos) || p->has_rgb != q->has_rgb || !same_double(p->rgb[0], q->rgb[0]) ||
            !same_double(p->rgb[1], q->rgb[1]) || !same_double(p->rgb[2], q->rgb[2]))
            bad++;
    }
    CHECK_MSG(bad == 0, "%s: %d table entries differ", what, bad);
}

/* A scene using every entity (both cone layouts, both light forms, p, pp). */
static const char *every_entity =
    "# hand-made scene with every entity\n"
    "v\n"
    "from 1.5 -2.25 3\n"
    "at 0 0.5 0\n"
    "up 0 0 1\n"
    "angle 40\n"
    "hither 0.125\n"
    "resolution 320 240\n"
    "b 0.1 0.2 0.3\n"
    "l 4 3 2\n"
    "l -1 -2 5 0.5 0.25 1\n"
    "f 1 0.5 0.25 0.7 0.3 20 0 1\n"
    "s 0.5 -0.5 1 0.75    # trailing comment\n"
    "p 3\n"
    "0 0 0\n"
    "1 0 0\n"
    "0 1 0\n"
    "f 0.2 0.4 0.6 0.5 0.2 3.0827 0.8 1.5\n"
    "pp 4\n"
    "0 0 1 0 0 2\n"
    "1 0 1 0 0.6 0.8\n"
    "1 1 1 1 1 1\n"
    "0 1 1 0 0 1\n"
    "c 0 0 0 0.5 0 0 2 0.25\n"
    "c\n"
    "1 1 1 0.3\n"
    "1 1 3 0.3\n"
    "s 1e-3 2.5E2 -7 0.1\n";

/* The SPD reference files and what they hold. */
typedef struct {
    const char *file;
    long long spheres, polygons, cylinders, cones, lights, materials;
    double from[3], hither;
} ref_counts;

enum { NREFS = 6 };
static const ref_counts refs[NREFS] = {
    {"balls.nff", 7381, 1, 0, 0, 3, 2, {2.1, 1.3, 1.7}, 0.01},
    {"gears.nff", 0, 9345, 0, 0, 5, 65, {-1.1, -2.1, 2.6}, 1},
    {"mount.nff", 4, 8192, 0, 0, 1, 2, {-1.6, 1.6, 1.7}, 0.01},
    {"rings.nff", 4200, 1, 4200, 0, 3, 841, {-1, -2.61313, 0.5}, 1},
    {"tetra.nff", 0, 4096, 0, 0, 1, 1, {1.02285, -3.17715, -2.17451}, 1},
    {"tree.nff", 4095, 1, 0, 4095, 7, 2, {4.5, 0.4, 2}, 1},
};

#endif
