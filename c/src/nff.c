/* nff.c: reader and writer of NFF, the Neutral File Format of Eric Haines'
 * Standard Procedural Databases (the format is described in NFF.TXT of the
 * SPD package).
 *
 * Reading.  The text is split into lines ('\n', "\r\n" or a lone '\r'); a
 * '#' starts a comment that runs to the end of the line, so comments may
 * stand alone or trail an entity.  Blank lines are skipped.  Tokens are
 * separated by spaces, tabs, '\f' or '\v'.  The first token of a line names
 * the entity; its numbers follow on the same line, except where the grammar
 * above each parse function below says otherwise.  Numbers are read with
 * strtod and must be finite; a token with anything after the number is an
 * error.  The text need not be NUL-terminated, and it may contain any bytes.
 *
 * Errors.  Malformed input makes the parse return MPRT_ERR_PARSE with a
 * message "NAME:LINE: what was expected, found what was there".  An entity
 * that the scene API rejects (a NaN, a radius that is not positive, a cone
 * whose ends coincide, a non-planar polygon...) is reported in the same way,
 * with the API's message after the "NAME:LINE: " prefix.  On any error the
 * scene is put back as it was before the call, so a failed parse adds
 * nothing.
 *
 * Dropped entities.  The only entity that is dropped instead of failing is a
 * polygon (or patch) of zero area: NFF allows such polygons, and they cannot
 * be seen.  It is counted with mprt__scene_warn ("NAME:LINE: polygon with
 * zero area dropped") and parsing goes on; the scene's error message is
 * left as it was.  Before a polygon is added, consecutive vertices that are
 * exactly equal (position, and normal for a patch), the last and first
 * included, are merged into one; a polygon left with fewer than 3 vertices
 * has zero area.
 *
 * Writing.  The writer emits text that reads back to the same scene: every
 * number is printed with the fewest significant digits that convert back to
 * the same value (at most 17 for a double, 9 for a float in MPRT_SINGLE
 * builds).  Polygon patch normals are written as stored, i.e. unit length;
 * the scene normalises them again when they are read back. */
#include "mprt_internal.h"

#include <errno.h>
#include <limits.h>
#include <locale.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- Lines and tokens --------------------------------------------------- */

#define NFF_MAXTOK 12  /* tokens kept per line; further ones are only counted */
#define NFF_NUMBUF 128 /* longest token accepted as a number */

typedef struct {
    const char *s;
    size_t n;
} nff_token;

typedef struct {
    mprt_scene *scene;
    const char *name;
    const char *p, *end;     /* unread text */
    long line;               /* number of the line read last */
    nff_token tok[NFF_MAXTOK];
    long ntok;               /* tokens on that line (may exceed NFF_MAXTOK) */
    char point;              /* the C library's decimal point in this locale */
    double *verts, *norms;   /* polygon scratch, 3 doubles per vertex each */
    size_t capverts;         /* vertices the scratch arrays hold */
} nff_reader;

static int nff_space(char c) { return c == ' ' || c == '\t' || c == '\f' || c == '\v'; }

/* Read the next line into r->tok; 0 at the end of the text. */
static int nff_next_line(nff_reader *r)
{
    const char *p = r->p, *end = r->end;
    if (p >= end) return 0;
    r->line++;
    r->ntok = 0;
    while (p < end && *p != '\n' && *p != '\r') {
        const char *start;
        if (*p == '#') {
            while (p < end && *p != '\n' && *p != '\r') p++;
            break;
        }
        if (nff_space(*p)) {
            p++;
            continue;
        }
        start = p;
        while (p < end && !nff_space(*p) && *p != '\n' && *p != '\r' && *p != '#') p++;
        if (r->ntok < NFF_MAXTOK) {
            r->tok[r->ntok].s = start;
            r->tok[r->ntok].n = (size_t)(p - start);
        }
        r->ntok++;
    }
    if (p < end) {
        if (*p == '\r' && p + 1 < end && p[1] == '\n') p++;
        p++;
    }
    r->p = p;
    return 1;
}

/* Read lines up to the next one with a token; 0 at the end of the text. */
static int nff_next_entity_line(nff_reader *r)
{
    while (nff_next_line(r))
        if (r->ntok > 0) return 1;
    return 0;
}

/* The token is the string literal word. */
#define nff_is(t, word) ((t).n == sizeof(word) - 1 && memcmp((t).s, word, sizeof(word) - 1) == 0)

/* The token is the string word. */
static int nff_is_word(nff_token t, const char *word)
{
    size_t n = strlen(word);
    return t.n == n && memcmp(t.s, word, n) == 0;
}

/* Quote a token for a message: at most 32 bytes, unprintable ones as \xNN. */
static const char *nff_show(nff_token t, char *out, size_t cap)
{
    static const char hex[] = "0123456789abcdef";
    size_t i, k = 0;
    for (i = 0; i < t.n && i < 32 && k + 5 < cap; i++) {
        unsigned char c = (unsigned char)t.s[i];
        if (c >= 0x20 && c < 0x7f) {
            out[k++] = (char)c;
        } else {
            out[k++] = '\\';
            out[k++] = 'x';
            out[k++] = hex[c >> 4];
            out[k++] = hex[c & 15];
        }
    }
    if (i < t.n && k + 4 < cap) {
        memcpy(out + k, "...", 3);
        k += 3;
    }
    out[k] = '\0';
    return out;
}

/* ---- Numbers ------------------------------------------------------------ */

/* Copy a token into buf as a NUL-terminated string in the notation strtod
 * expects here ('.' becomes the locale's decimal point); 0 if it does not fit
 * or already holds that other decimal point. */
static int nff_cstring(const nff_reader *r, nff_token t, char *buf, size_t cap)
{
    size_t i;
    if (t.n == 0 || t.n >= cap) return 0;
    memcpy(buf, t.s, t.n);
    buf[t.n] = '\0';
    if (r->point != '.') {
        for (i = 0; i < t.n; i++) {
            if (buf[i] == r->point) return 0;
            if (buf[i] == '.') buf[i] = r->point;
        }
    }
    return 1;
}

#define NFF_NUMBER 0
#define NFF_GARBAGE 1
#define NFF_NONFINITE 2

/* Convert a token to a double: NFF_NUMBER, NFF_GARBAGE or NFF_NONFINITE. */
static int nff_number(const nff_reader *r, nff_token t, double *out)
{
    char buf[NFF_NUMBUF], *stop;
    double x;
    if (!nff_cstring(r, t, buf, sizeof buf)) return NFF_GARBAGE;
    x = strtod(buf, &stop);
    if (stop != buf + t.n) return NFF_GARBAGE;
    if (!isfinite(x)) return NFF_NONFINITE;
    *out = x;
    return NFF_NUMBER;
}

/* Convert a token to an int; 0 if it is not a decimal integer within int. */
static int nff_int(const nff_reader *r, nff_token t, int *out)
{
    char buf[NFF_NUMBUF], *stop;
    long x;
    if (!nff_cstring(r, t, buf, sizeof buf)) return 0;
    errno = 0;
    x = strtol(buf, &stop, 10);
    if (stop != buf + t.n || errno == ERANGE || x < INT_MIN || x > INT_MAX) return 0;
    *out = (int)x;
    return 1;
}

/* ---- Errors ------------------------------------------------------------- */

/* Record "NAME:LINE: message" as the scene's error; returns status. */
static int nff_fail_status(nff_reader *r, int status, long line, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
static int nff_fail_status(nff_reader *r, int status, long line, const char *fmt, ...)
{
    char msg[MPRT__ERRMSG];
    va_list ap;
    va_start(ap, fmt);
    mprt__vformat(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return mprt__scene_fail(r->scene, status, "%s:%ld: %s", r->name, line, msg);
}

#define nff_fail(r, line, ...) nff_fail_status((r), MPRT_ERR_PARSE, (line), __VA_ARGS__)

/* A scene API call refused an entity: prefix its message with the place.
 * Invalid values become MPRT_ERR_PARSE; other statuses pass through. */
static int nff_api_fail(nff_reader *r, int status, long line)
{
    char msg[MPRT__ERRMSG];
    memcpy(msg, r->scene->errmsg, sizeof msg);
    msg[sizeof msg - 1] = '\0';
    if (status == MPRT_ERR_INVALID_ARG) status = MPRT_ERR_PARSE;
    return nff_fail_status(r, status, line, "%s", msg);
}

/* Parse tokens first.. of the current line as exactly want numbers into v.
 * what completes the messages: "expected 4 numbers <what>, found 3".  On a
 * continuation line (first == 0) a leading word is shown instead of a count,
 * since it is most likely the next entity. */
static int nff_numbers(nff_reader *r, int first, int want, double *v, const char *what)
{
    char shown[160];
    long have = r->ntok - first;
    int i, kind;
    if (have != want) {
        double dummy;
        if (first == 0 && nff_number(r, r->tok[0], &dummy) == NFF_GARBAGE)
            return nff_fail(r, r->line, "expected %d number%s %s, found '%s'", want,
                            want == 1 ? "" : "s", what, nff_show(r->tok[0], shown, sizeof shown));
        return nff_fail(r, r->line, "expected %d number%s %s, found %ld", want, want == 1 ? "" : "s",
                        what, have);
    }
    for (i = 0; i < want; i++) {
        nff_token t = r->tok[first + i];
        kind = nff_number(r, t, &v[i]);
        if (kind == NFF_GARBAGE)
            return nff_fail(r, r->line, "expected a number %s, found '%s'", what,
                            nff_show(t, shown, sizeof shown));
        if (kind == NFF_NONFINITE)
            return nff_fail(r, r->line, "expected a finite number %s, found '%s'", what,
                            nff_show(t, shown, sizeof shown));
    }
    return MPRT_OK;
}

/* Parse tokens first.. of the current line as exactly want numbers into v,
 * without a message; 1 when they are.  A fast path for vertex lines. */
static int nff_try_numbers(const nff_reader *r, int first, int want, double *v)
{
    int i;
    if (r->ntok - first != want) return 0;
    for (i = 0; i < want; i++)
        if (nff_number(r, r->tok[first + i], &v[i]) != NFF_NUMBER) return 0;
    return 1;
}

/* ---- Entities ----------------------------------------------------------- */

/* View, seven lines in this order, each keyword followed by its numbers:
 *     v
 *     from Fx Fy Fz          eye position
 *     at Ax Ay Az            point at the centre of the image
 *     up Ux Uy Uz            up direction (need not be perpendicular)
 *     angle degrees          between the centres of the first and last
 *                            pixel column (and row)
 *     hither distance        near clipping distance from the eye
 *     resolution xres yres   image size in pixels (integers)
 * Comment and blank lines may come between.  All six lines are required. */
static int nff_view(nff_reader *r)
{
    static const char *const key[6] = {"from", "at", "up", "angle", "hither", "resolution"};
    static const char *const what[6] = {
        "after 'from' (x y z)", "after 'at' (x y z)", "after 'up' (x y z)",
        "after 'angle' (degrees)", "after 'hither' (distance)",
        "after 'resolution' (width height)"};
    static const int count[6] = {3, 3, 3, 1, 1, 2};
    char shown[160];
    double v[5][3];
    int res[2] = {0, 0};
    long start = r->line;
    int i, j, st;
    if (r->ntok != 1)
        return nff_fail(r, r->line, "expected nothing after 'v' (the view continues on the next lines), found '%s'",
                        nff_show(r->tok[1], shown, sizeof shown));
    for (i = 0; i < 6; i++) {
        if (!nff_next_entity_line(r))
            return nff_fail(r, r->line, "expected the '%s' line of the view started at line %ld, found end of file",
                            key[i], start);
        if (!nff_is_word(r->tok[0], key[i]))
            return nff_fail(r, r->line, "expected '%s' in the view started at line %ld, found '%s'", key[i],
                            start, nff_show(r->tok[0], shown, sizeof shown));
        if (i < 5) {
            if ((st = nff_numbers(r, 1, count[i], v[i], what[i])) != MPRT_OK) return st;
            continue;
        }
        if (r->ntok - 1 != 2)
            return nff_fail(r, r->line, "expected 2 integers %s, found %ld", what[i], r->ntok - 1);
        for (j = 0; j < 2; j++) {
            if (!nff_int(r, r->tok[1 + j], &res[j]))
                return nff_fail(r, r->line, "expected an integer %s, found '%s'", what[i],
                                nff_show(r->tok[1 + j], shown, sizeof shown));
        }
    }
    st = mprt_scene_set_view(r->scene, v[0], v[1], v[2], v[3][0], v[4][0], res[0], res[1]);
    return st == MPRT_OK ? st : nff_api_fail(r, st, start);
}

/* Background colour, RGB in 0..1 (black when absent):
 *     b R G B */
static int nff_background(nff_reader *r)
{
    double c[3];
    int st = nff_numbers(r, 1, 3, c, "after 'b' (r g b)");
    if (st != MPRT_OK) return st;
    st = mprt_scene_set_background(r->scene, c);
    return st == MPRT_OK ? st : nff_api_fail(r, st, r->line);
}

/* Point light at X Y Z, with an optional RGB colour (without one, the
 * renderer picks the intensity):
 *     l X Y Z [R G B] */
static int nff_light(nff_reader *r)
{
    static const char *what = "after 'l' (x y z [r g b])";
    double v[6];
    int st;
    if (r->ntok - 1 != 3 && r->ntok - 1 != 6)
        return nff_fail(r, r->line, "expected 3 or 6 numbers %s, found %ld", what, r->ntok - 1);
    if ((st = nff_numbers(r, 1, (int)(r->ntok - 1), v, what)) != MPRT_OK) return st;
    st = mprt_scene_add_light(r->scene, v, r->ntok == 7 ? v + 3 : NULL);
    return st == MPRT_OK ? st : nff_api_fail(r, st, r->line);
}

/* Fill: the material of every primitive that follows, until the next "f":
 *     f R G B Kd Ks Shine T ior
 * colour, diffuse and specular weights, Phong exponent, transmittance and
 * index of refraction. */
static int nff_fill(nff_reader *r)
{
    double m[8];
    int st = nff_numbers(r, 1, 8, m, "after 'f' (r g b Kd Ks Shine T ior)");
    if (st != MPRT_OK) return st;
    st = mprt_scene_set_material(r->scene, m, m[3], m[4], m[5], m[6], m[7]);
    return st == MPRT_OK ? st : nff_api_fail(r, st, r->line);
}

/* Open cone frustum, or a cylinder when the radii are equal, between a base
 * disc and an apex disc; the ends must not coincide.  NFF.TXT puts the two
 * discs on their own lines:
 *     c
 *     base.x base.y base.z base_radius
 *     apex.x apex.y apex.z apex_radius
 * and the SPD generators write all on one line, which is read as well:
 *     c base.x base.y base.z base_radius apex.x apex.y apex.z apex_radius */
static int nff_cone(nff_reader *r)
{
    static const char *end_name[2] = {"base", "apex"};
    char what[120];
    double v[8];
    long start = r->line;
    int st, i;
    if (r->ntok - 1 == 8) {
        st = nff_numbers(r, 1, 8, v, "after 'c' (base x y z r, apex x y z r)");
        if (st != MPRT_OK) return st;
    } else if (r->ntok == 1) {
        for (i = 0; i < 2; i++) {
            if (!nff_next_entity_line(r))
                return nff_fail(r, r->line, "expected the %s line (x y z radius) of the cone started at line %ld, found end of file",
                                end_name[i], start);
            snprintf(what, sizeof what, "for the %s of the cone started at line %ld (x y z radius)",
                     end_name[i], start);
            if ((st = nff_numbers(r, 0, 4, v + 4 * i, what)) != MPRT_OK) return st;
        }
    } else {
        return nff_fail(r, r->line,
                        "expected 8 numbers after 'c' (base x y z r, apex x y z r), or none and "
                        "base and apex on the next two lines, found %ld",
                        r->ntok - 1);
    }
    st = mprt_scene_add_cone(r->scene, v, v[3], v + 4, v[7]);
    return st == MPRT_OK ? st : nff_api_fail(r, st, start);
}

/* Sphere; the radius must be positive (NFF's inside-only negative radius is
 * not supported):
 *     s center.x center.y center.z radius */
static int nff_sphere(nff_reader *r)
{
    double v[4];
    int st = nff_numbers(r, 1, 4, v, "after 's' (x y z radius)");
    if (st != MPRT_OK) return st;
    st = mprt_scene_add_sphere(r->scene, v, v[3]);
    return st == MPRT_OK ? st : nff_api_fail(r, st, r->line);
}

/* Make room for n vertices in the polygon scratch arrays. */
static int nff_reserve(nff_reader *r, size_t n)
{
    size_t cap = r->capverts ? r->capverts : 64;
    double *a, *b;
    if (n <= r->capverts) return MPRT_OK;
    while (cap < n) cap *= 2;
    if (cap > SIZE_MAX / (3 * sizeof(double)))
        return nff_fail_status(r, MPRT_ERR_OUT_OF_MEMORY, r->line, "out of memory reading a polygon");
    a = realloc(r->verts, cap * 3 * sizeof(double));
    if (a) r->verts = a;
    b = realloc(r->norms, cap * 3 * sizeof(double));
    if (b) r->norms = b;
    if (!a || !b) return nff_fail_status(r, MPRT_ERR_OUT_OF_MEMORY, r->line, "out of memory reading a polygon");
    r->capverts = cap;
    return MPRT_OK;
}

/* Vertex i equals vertex j (and so do their normals for a patch). */
static int nff_same_vertex(const nff_reader *r, int patch, int i, int j)
{
    if (memcmp(r->verts + 3 * i, r->verts + 3 * j, 3 * sizeof(double)) != 0) return 0;
    return !patch || memcmp(r->norms + 3 * i, r->norms + 3 * j, 3 * sizeof(double)) == 0;
}

/* Merge runs of equal consecutive vertices (cyclically); returns the count left. */
static int nff_merge_duplicates(nff_reader *r, int patch, int n)
{
    int i, m = 0;
    for (i = 0; i < n; i++) {
        if (m > 0 && nff_same_vertex(r, patch, i, m - 1)) continue;
        if (m != i) {
            memcpy(r->verts + 3 * m, r->verts + 3 * i, 3 * sizeof(double));
            memcpy(r->norms + 3 * m, r->norms + 3 * i, 3 * sizeof(double));
        }
        m++;
    }
    while (m > 1 && nff_same_vertex(r, patch, m - 1, 0)) m--;
    return m;
}

/* Polygon: a vertex count, then one line per vertex.  The vertices lie in one
 * plane and run counterclockwise seen from the front:
 *     p total_vertices
 *     x y z
 *     [... total_vertices lines in all]
 * Polygonal patch: the same with a vertex normal after each vertex:
 *     pp total_vertices
 *     x y z nx ny nz
 *     [... total_vertices lines in all]
 * The count is an integer of at least 3. */
static int nff_polygon(nff_reader *r, int patch)
{
    const char *kw = patch ? "pp" : "p";
    const char *noun = patch ? "polygon patch" : "polygon";
    const int per = patch ? 6 : 3;
    char shown[160], what[160];
    double v[6];
    long start = r->line;
    int n = 0, i, m, st, reason = 0;
    if (r->ntok != 2)
        return nff_fail(r, r->line, "expected 1 number after '%s' (vertex count), found %ld", kw, r->ntok - 1);
    if (!nff_int(r, r->tok[1], &n) || n < 1)
        return nff_fail(r, r->line, "expected a positive integer vertex count after '%s', found '%s'", kw,
                        nff_show(r->tok[1], shown, sizeof shown));
    if (n < 3)
        return nff_fail(r, r->line, "expected a vertex count of at least 3 after '%s', found %d", kw, n);
    for (i = 0; i < n; i++) {
        if (!nff_next_entity_line(r))
            return nff_fail(r, r->line, "expected %d more vert%s of the %s started at line %ld, found end of file",
                            n - i, n - i == 1 ? "ex" : "ices", noun, start);
        if (!nff_try_numbers(r, 0, per, v)) {
            snprintf(what, sizeof what, "for vertex %d of %d of the %s started at line %ld (%s)", i + 1, n,
                     noun, start, patch ? "x y z nx ny nz" : "x y z");
            return nff_numbers(r, 0, per, v, what);
        }
        if ((st = nff_reserve(r, (size_t)i + 1)) != MPRT_OK) return st;
        memcpy(r->verts + 3 * i, v, 3 * sizeof(double));
        if (patch) memcpy(r->norms + 3 * i, v + 3, 3 * sizeof(double));
    }
    m = nff_merge_duplicates(r, patch, n);
    if (m >= 3) {
        st = mprt__scene_add_polygon(r->scene, m, r->verts, patch ? r->norms : NULL, &reason);
        if (st == MPRT_OK) return st;
        if (reason != MPRT__DEGENERATE) return nff_api_fail(r, st, start);
    }
    mprt__scene_warn(r->scene, "%s:%ld: %s with zero area dropped", r->name, start, noun);
    return MPRT_OK;
}

/* ---- Parse -------------------------------------------------------------- */

/* What a failed parse must restore. */
typedef struct {
    long long nprims, nspheres, npolygons, ncones, nverts, nmaterials, nlights;
    long long ncylinders, npatches, dropped;
    int material, width, height;
    vec3 from, at, up;
    double angle, hither, background[3];
    char warning[MPRT__ERRMSG];
    char errmsg[MPRT__ERRMSG];
} nff_snapshot;

static void nff_save(const mprt_scene *s, nff_snapshot *k)
{
    k->nprims = s->nprims;
    k->nspheres = s->nspheres;
    k->npolygons = s->npolygons;
    k->ncones = s->ncones;
    k->nverts = s->nverts;
    k->nmaterials = s->nmaterials;
    k->nlights = s->nlights;
    k->ncylinders = s->ncylinders;
    k->npatches = s->npatches;
    k->dropped = s->dropped;
    k->material = s->material;
    k->width = s->width;
    k->height = s->height;
    k->from = s->from;
    k->at = s->at;
    k->up = s->up;
    k->angle = s->angle;
    k->hither = s->hither;
    memcpy(k->background, s->background, sizeof k->background);
    memcpy(k->warning, s->warning, sizeof k->warning);
    memcpy(k->errmsg, s->errmsg, sizeof k->errmsg);
}

static void nff_restore(mprt_scene *s, const nff_snapshot *k)
{
    s->nprims = k->nprims;
    s->nspheres = k->nspheres;
    s->npolygons = k->npolygons;
    s->ncones = k->ncones;
    s->nverts = k->nverts;
    s->nmaterials = k->nmaterials;
    s->nlights = k->nlights;
    s->ncylinders = k->ncylinders;
    s->npatches = k->npatches;
    s->dropped = k->dropped;
    s->material = k->material;
    s->width = k->width;
    s->height = k->height;
    s->from = k->from;
    s->at = k->at;
    s->up = k->up;
    s->angle = k->angle;
    s->hither = k->hither;
    memcpy(s->background, k->background, sizeof s->background);
    memcpy(s->warning, k->warning, sizeof s->warning);
}

static char nff_decimal_point(void)
{
    const struct lconv *lc = localeconv();
    return lc && lc->decimal_point && lc->decimal_point[0] ? lc->decimal_point[0] : '.';
}

int mprt__nff_parse(mprt_scene *scene, const char *text, size_t len, const char *name)
{
    nff_reader r;
    nff_snapshot *saved;
    char shown[160];
    int st = MPRT_OK;
    if (!scene) return MPRT_ERR_INVALID_ARG;
    if (!text) len = 0;
    memset(&r, 0, sizeof r);
    r.scene = scene;
    r.name = name ? name : "<nff>";
    r.p = text;
    r.end = text + len;
    r.point = nff_decimal_point();
    saved = malloc(sizeof *saved);
    if (!saved) return mprt__scene_fail(scene, MPRT_ERR_OUT_OF_MEMORY, "%s: out of memory", r.name);
    nff_save(scene, saved);
    while (st == MPRT_OK && nff_next_entity_line(&r)) {
        nff_token k = r.tok[0];
        if (nff_is(k, "s")) st = nff_sphere(&r);
        else if (nff_is(k, "p")) st = nff_polygon(&r, 0);
        else if (nff_is(k, "c")) st = nff_cone(&r);
        else if (nff_is(k, "f")) st = nff_fill(&r);
        else if (nff_is(k, "pp")) st = nff_polygon(&r, 1);
        else if (nff_is(k, "l")) st = nff_light(&r);
        else if (nff_is(k, "b")) st = nff_background(&r);
        else if (nff_is(k, "v")) st = nff_view(&r);
        else st = nff_fail(&r, r.line, "unknown entity '%s'", nff_show(k, shown, sizeof shown));
    }
    if (st != MPRT_OK) nff_restore(scene, saved);
    else memcpy(scene->errmsg, saved->errmsg, sizeof scene->errmsg); /* a dropped polygon's message */
    free(saved);
    free(r.verts);
    free(r.norms);
    return st;
}

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

static void nff_put_int(nff_writer *w, long long x)
{
    char text[32];
    snprintf(text, sizeof text, " %lld", x);
    nff_puts(w, text);
}

static void nff_put_material(nff_writer *w, const mprt__material *m)
{
    nff_puts(w, "f");
    nff_put_double(w, m->rgb[0]);
    nff_put_double(w, m->rgb[1]);
    nff_put_double(w, m->rgb[2]);
    nff_put_double(w, m->kd);
    nff_put_double(w, m->ks);
    nff_put_double(w, m->shine);
    nff_put_double(w, m->t);
    nff_put_double(w, m->ior);
    nff_puts(w, "\n");
}

static void nff_put_prim(nff_writer *w, const mprt_scene *s, const mprt__prim *p)
{
    int i;
    if (p->kind == MPRT_SPHERE) {
        const mprt__sphere *sp = &s->spheres[p->index];
        nff_puts(w, "s");
        nff_put_vec(w, sp->c);
        nff_put_real(w, sp->r);
    } else if (p->kind == MPRT_POLYGON) {
        const mprt__polygon *pg = &s->polygons[p->index];
        nff_puts(w, pg->has_normals ? "pp" : "p");
        nff_put_int(w, pg->n);
        for (i = 0; i < pg->n; i++) {
            nff_puts(w, "\n");
            nff_put_vec(w, s->verts[pg->first + i]);
            if (pg->has_normals) nff_put_vec(w, s->vnormals[pg->first + i]);
        }
    } else {
        const mprt__cone *c = &s->cones[p->index];
        nff_puts(w, "c");
        nff_put_vec(w, c->base);
        nff_put_real(w, c->rb);
        nff_put_vec(w, c->apex);
        nff_put_real(w, c->ra);
    }
    nff_puts(w, "\n");
}

/* Layout: a comment, the view block, the background, the lights, then the
 * primitives in id order.  Materials are written in their table order, each
 * just before the first primitive that uses it (unused ones too, so the
 * material table reads back the same). */
int mprt__nff_write(const mprt_scene *s, char *buf, size_t cap, size_t *needed)
{
    nff_writer w;
    long long i, k, next = 0;
    int cur = -1;
    if (!s || !needed || (!buf && cap)) return MPRT_ERR_INVALID_ARG;
    w.buf = buf;
    w.cap = cap;
    w.len = 0;
    w.point = nff_decimal_point();
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
    nff_put_double(&w, s->background[0]);
    nff_put_double(&w, s->background[1]);
    nff_put_double(&w, s->background[2]);
    nff_puts(&w, "\n");
    for (i = 0; i < s->nlights; i++) {
        const mprt__light *l = &s->lights[i];
        nff_puts(&w, "l");
        nff_put_vec(&w, l->pos);
        if (l->has_rgb) {
            nff_put_double(&w, l->rgb[0]);
            nff_put_double(&w, l->rgb[1]);
            nff_put_double(&w, l->rgb[2]);
        }
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
        nff_put_prim(&w, s, p);
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
