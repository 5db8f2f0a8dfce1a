/* nff_write.c: the NFF writer.  It emits text that reads back to the same
 * scene: every number is printed with the fewest significant digits that
 * convert back to the same value (at most 17 for a double, 9 for a float in
 * MPRT_SINGLE builds).  Polygon patch normals are written as stored, i.e.
 * unit length; the scene normalises them again when they are read back. */
#include "mprt_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- Write -------------------------------------------------------------- */

typedef struct {
    char *buf;
    size_t cap, len;  /* len counts every byte produced, also past cap */
    char point;
    char last;        /* last byte produced */
} nff_writer;

static void nff_put(nff_writer *w, const char *s, size_t n)
{
    if (n == 0) return;
    if (w->len < w->cap) {
        size_t room = w->cap - w->len;
        memcpy(w->buf + w->len, s, n < room ? n : room);
    }
    w->len += n;
    w->last = s[n - 1];
}

static void nff_puts(nff_writer *w, const char *s) { nff_put(w, s, strlen(s)); }

/* Append a number formatted by the C library, its decimal point made '.',
 * after a space unless it starts a line. */
static void nff_put_number(nff_writer *w, char *text)
{
    char *c;
    if (w->point != '.')
        for (c = text; *c; c++)
            if (*c == w->point) *c = '.';
    if (w->last != '\n') nff_put(w, " ", 1);
    nff_puts(w, text);
}

/* Shortest "%.Ng" text of a double that strtod turns back into x. */
static void nff_put_double(nff_writer *w, double x)
{
    char text[40];
    int prec;
    for (prec = 15; prec < 17; prec++) {
        snprintf(text, sizeof text, "%.*g", prec, x);
        if (strtod(text, NULL) == x) break;
    }
    if (prec == 17) snprintf(text, sizeof text, "%.17g", x);
    nff_put_number(w, text);
}

/* Shortest text of a stored coordinate that reads back to the same value. */
static void nff_put_real(nff_writer *w, real x)
{
#ifdef MPRT_SINGLE
    char text[40];
    int prec;
    for (prec = 6; prec < 9; prec++) {
        snprintf(text, sizeof text, "%.*g", prec, (double)x);
        if ((float)strtod(text, NULL) == x) break;
    }
    if (prec == 9) snprintf(text, sizeof text, "%.9g", (double)x);
    nff_put_number(w, text);
#else
    nff_put_double(w, x);
#endif
}

static void nff_put_vec(nff_writer *w, vec3 v)
{
    nff_put_real(w, v.x);
    nff_put_real(w, v.y);
    nff_put_real(w, v.z);
}

/* A colour: three doubles. */
static void nff_put_rgb(nff_writer *w, const double rgb[3])
{
    nff_put_double(w, rgb[0]);
    nff_put_double(w, rgb[1]);
    nff_put_double(w, rgb[2]);
}

static void nff_put_int(nff_writer *w, long long x)
{
    char text[32];
    snprintf(text, sizeof text, " %lld", x);
    nff_puts(w, text);
}

static void nff_put_material(nff_writer *w, const mprt__material *m)
{
    nff_puts(w, "f");
    nff_put_rgb(w, m->rgb);
    nff_put_double(w, m->kd);
    nff_put_double(w, m->ks);
    nff_put_double(w, m->shine);
    nff_put_double(w, m->t);
    nff_put_double(w, m->ior);
    nff_puts(w, "\n");
}

/* One primitive; MPRT_ERR_STATE for an unknown kind. */
static int nff_put_prim(nff_writer *w, const mprt_scene *s, const mprt__prim *p)
{
    int i;
    switch (p->kind) {
    case MPRT_SPHERE: {
        const mprt__sphere *sp = &s->spheres[p->index];
        nff_puts(w, "s");
        nff_put_vec(w, sp->c);
        nff_put_real(w, sp->r);
        break;
    }
    case MPRT_POLYGON: {
        const mprt__polygon *pg = &s->polygons[p->index];
        nff_puts(w, pg->has_normals ? "pp" : "p");
        nff_put_int(w, pg->n);
        for (i = 0; i < pg->n; i++) {
            nff_puts(w, "\n");
            nff_put_vec(w, s->verts[pg->first + i]);
            if (pg->has_normals) nff_put_vec(w, s->vnormals[pg->first + i]);
        }
        break;
    }
    case MPRT_CYLINDER:
    case MPRT_CONE: {
        const mprt__cone *c = &s->cones[p->index];
        nff_puts(w, "c");
        nff_put_vec(w, c->base);
        nff_put_real(w, c->rb);
        nff_put_vec(w, c->apex);
        nff_put_real(w, c->ra);
        break;
    }
    default: return MPRT_ERR_STATE;
    }
    nff_puts(w, "\n");
    return MPRT_OK;
}

/* Layout: a comment, the view block, the background, the lights, then the
 * primitives in id order.  Materials are written in their table order, each
 * just before the first primitive that uses it (unused ones too, so the
 * material table reads back the same). */
int mprt_scene_write_nff(const mprt_scene *s, char *buf, size_t cap, size_t *needed)
{
    nff_writer w;
    long long i, k, next = 0;
    int cur = -1;
    if (!s || !needed || (!buf && cap)) return MPRT_ERR_INVALID_ARG;
    w.buf = buf;
    w.cap = cap;
    w.len = 0;
    w.point = mprt__decimal_point();
    w.last = '\n';

    nff_puts(&w, "# NFF written by mprt " MPRT_VERSION "\nv\nfrom");
    nff_put_vec(&w, s->from);
    nff_puts(&w, "\nat");
    nff_put_vec(&w, s->at);
    nff_puts(&w, "\nup");
    nff_put_vec(&w, s->up);
    nff_puts(&w, "\nangle");
    nff_put_double(&w, s->angle);
    nff_puts(&w, "\nhither");
    nff_put_double(&w, s->hither);
    nff_puts(&w, "\nresolution");
    nff_put_int(&w, s->width);
    nff_put_int(&w, s->height);
    nff_puts(&w, "\nb");
    nff_put_rgb(&w, s->background);
    nff_puts(&w, "\n");
    for (i = 0; i < s->nlights; i++) {
        const mprt__light *l = &s->lights[i];
        nff_puts(&w, "l");
        nff_put_vec(&w, l->pos);
        if (l->has_rgb) nff_put_rgb(&w, l->rgb);
        nff_puts(&w, "\n");
    }
    for (i = 0; i < s->nprims; i++) {
        const mprt__prim *p = &s->prims[i];
        if (p->material != cur && p->material >= 0 && p->material < s->nmaterials) {
            if (p->material >= next) {
                for (k = next; k <= p->material; k++) nff_put_material(&w, &s->materials[k]);
                next = p->material + 1;
            } else {
                nff_put_material(&w, &s->materials[p->material]);
            }
            cur = p->material;
        }
        if (nff_put_prim(&w, s, p) != MPRT_OK) return MPRT_ERR_STATE;
    }
    for (k = next; k < s->nmaterials; k++) nff_put_material(&w, &s->materials[k]);

    *needed = w.len + 1;
    if (cap < w.len + 1) {
        if (cap > 0) buf[cap - 1] = '\0';
        return MPRT_ERR_CAPACITY;
    }
    buf[w.len] = '\0';
    return MPRT_OK;
}
