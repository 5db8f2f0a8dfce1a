/* nff.c: the reader of NFF, the Neutral File Format of Eric Haines'
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
 * equal as the scene stores them (position, and the unit normal for a
 * patch), the last and first included, are merged into one; a polygon left
 * with fewer than 3 vertices has zero area.  So the text the writer makes
 * reads back to the same polygon.
 *
 * Materials.  Kd, Ks and T must each lie in [0, 1]; Ks + T may exceed 1
 * (the glass of many NFF files, "f .9 .9 .9 .1 .9 50 .9 1.33"): such
 * materials are read as written, with one note per file
 * (mprt_scene_notes) naming the first and the count, since the ray budget of
 * a sample bounds the work of their wider ray trees.
 *
 * Unknown entities.  A line whose first token is no entity above fails with
 * "NAME:LINE: unknown entity 'fp'".  With MPRT_NFF_SKIP_UNKNOWN it is
 * skipped, with the lines after it that start with a number (the entity's
 * data), and one note per skipped entity gives its count and its first
 * lines; for a material line (a name starting with 'f', as "fp"), also the
 * material the surfaces after each skip take instead: the last 'f' before
 * it (or, before any, the scene's material, white diffuse by default).
 *
 * The writer is in nff_write.c. */
#include "nff.h"

#include <errno.h>
#include <limits.h>
#include <locale.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

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
                        mprt__nff_show(r->tok[1], shown, sizeof shown));
    for (i = 0; i < 6; i++) {
        if (!mprt__nff_next_entity_line(r))
            return nff_fail(r, r->line, "expected the '%s' line of the view started at line %ld, found end of file",
                            key[i], start);
        if (!mprt__nff_is_word(r->tok[0], key[i]))
            return nff_fail(r, r->line, "expected '%s' in the view started at line %ld, found '%s'", key[i],
                            start, mprt__nff_show(r->tok[0], shown, sizeof shown));
        if (i < 5) {
            if ((st = mprt__nff_numbers(r, 1, count[i], v[i], what[i])) != MPRT_OK) return st;
            continue;
        }
        if (r->ntok - 1 != 2)
            return nff_fail(r, r->line, "expected 2 integers %s, found %ld", what[i], r->ntok - 1);
        for (j = 0; j < 2; j++) {
            if (!mprt__nff_int(r, r->tok[1 + j], &res[j]))
                return nff_fail(r, r->line, "expected an integer %s, found '%s'", what[i],
                                mprt__nff_show(r->tok[1 + j], shown, sizeof shown));
        }
    }
    st = mprt_scene_set_view(r->scene, v[0], v[1], v[2], v[3][0], v[4][0], res[0], res[1]);
    return st == MPRT_OK ? st : mprt__nff_api_fail(r, st, start);
}

/* Background colour, RGB in 0..1 (black when absent):
 *     b R G B */
static int nff_background(nff_reader *r)
{
    double c[3];
    int st = mprt__nff_numbers(r, 1, 3, c, "after 'b' (r g b)");
    if (st != MPRT_OK) return st;
    st = mprt_scene_set_background(r->scene, c);
    return st == MPRT_OK ? st : mprt__nff_api_fail(r, st, r->line);
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
    if ((st = mprt__nff_numbers(r, 1, (int)(r->ntok - 1), v, what)) != MPRT_OK) return st;
    st = mprt_scene_add_light(r->scene, v, r->ntok == 7 ? v + 3 : NULL);
    return st == MPRT_OK ? st : mprt__nff_api_fail(r, st, r->line);
}

/* Fill: the material of every primitive that follows, until the next "f":
 *     f R G B Kd Ks Shine T ior
 * colour, diffuse and specular weights, Phong exponent, transmittance and
 * index of refraction. */
static int nff_fill(nff_reader *r)
{
    double m[8];
    int st = mprt__nff_numbers(r, 1, 8, m, "after 'f' (r g b Kd Ks Shine T ior)");
    if (st != MPRT_OK) return st;
    st = mprt_scene_set_material(r->scene, m, m[3], m[4], m[5], m[6], m[7]);
    if (st != MPRT_OK) return mprt__nff_api_fail(r, st, r->line);
    if (m[4] + m[6] > 1 + 1e-12 && r->over_one++ == 0) { /* (a margin for decimal text: 0.3 + 0.7) */
        r->over_line = r->line;
        r->over_ks = m[4];
        r->over_t = m[6];
    }
    return MPRT_OK;
}

/* What a skipping read keeps of each unknown entity besides its count: the
 * lines of its first few skips, and the 'f' line in effect at each (0: none
 * in this file yet), so the note can say which material the surfaces after
 * a skipped material line take. */
#define NFF_LINES_SHOWN 4
typedef struct {
    long line[NFF_UNKNOWN][NFF_LINES_SHOWN];
    long fill[NFF_UNKNOWN][NFF_LINES_SHOWN];
    long last_fill;          /* the line of the last 'f' read (0: none yet) */
} nff_skips;

/* An entity the reader does not know, under MPRT_NFF_SKIP_UNKNOWN: counted
 * by name, with its first lines; its number lines are skipped by the caller. */
static void nff_skip_unknown(nff_reader *r, nff_skips *sk)
{
    char shown[160];
    int i;
    mprt__nff_show(r->tok[0], shown, sizeof shown);
    r->in_unknown = 1;
    for (i = 0; i < r->nunknown; i++)
        if (strcmp(r->unknown[i].name, shown) == 0) break;
    if (i == r->nunknown) {
        if (r->nunknown == NFF_UNKNOWN || strlen(shown) >= sizeof r->unknown[0].name) {
            r->unknown_more++;
            return;
        }
        strcpy(r->unknown[i].name, shown);
        r->unknown[i].count = 0;
        r->unknown[i].first = r->line;
        r->nunknown++;
    }
    if (r->unknown[i].count < NFF_LINES_SHOWN) {
        sk->line[i][r->unknown[i].count] = r->line;
        sk->fill[i][r->unknown[i].count] = sk->last_fill;
    }
    r->unknown[i].count++;
}

/* The token starts like a number (a data line of a skipped entity). */
static int nff_numberlike(nff_token t)
{
    return t.n > 0 && (strchr("0123456789+-.", t.s[0]) != NULL);
}

/* Append to out (cap bytes, used so far) what fits, keeping it terminated. */
static void nff_append(char *out, size_t cap, size_t *used, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
static void nff_append(char *out, size_t cap, size_t *used, const char *fmt, ...)
{
    va_list ap;
    int n;
    if (*used >= cap) return;
    va_start(ap, fmt);
    n = vsnprintf(out + *used, cap - *used, fmt, ap);
    va_end(ap);
    if (n > 0) *used = (size_t)n >= cap - *used ? cap - 1 : *used + (size_t)n;
}

/* The note of one skipped entity: its count and first lines; for a material
 * line (a name starting with 'f', as NFF's own 'f'), the material the
 * surfaces after each skip take instead: the last 'f' before it, or the
 * scene's material before this file (white diffuse, Kd 1, by default). */
static void nff_skip_note(nff_reader *r, const nff_skips *sk, int i, int had_material)
{
    char text[400];
    size_t used = 0;
    long count = r->unknown[i].count;
    int shown = count < NFF_LINES_SHOWN ? (int)count : NFF_LINES_SHOWN, j, material;
    material = r->unknown[i].name[0] == 'f' && r->unknown[i].name[1] != '\0';
    nff_append(text, sizeof text, &used, "%s: %ld '%s' %sline%s skipped (line%s ", r->name, count,
               r->unknown[i].name, material ? "material " : "", count == 1 ? "" : "s", count == 1 ? "" : "s");
    for (j = 0; j < shown; j++) nff_append(text, sizeof text, &used, "%s%ld", j ? ", " : "", sk->line[i][j]);
    if (count > shown) nff_append(text, sizeof text, &used, " and %ld more", count - shown);
    nff_append(text, sizeof text, &used, "), with the number lines after %s", count == 1 ? "it" : "each");
    if (material) {
        /* the shown lines grouped by the 'f' in effect (the same 'f' runs together) */
        int several = count > 1;
        nff_append(text, sizeof text, &used, ": the surfaces after %s take the last 'f' material before %s: ",
                   several ? "them" : "it", several ? "them" : "it");
        for (j = 0; j < shown; j++) {
            long f = sk->fill[i][j];
            int first = j == 0 || sk->fill[i][j - 1] != f, last = j + 1 == shown || sk->fill[i][j + 1] != f;
            if (first) {
                if (j) nff_append(text, sizeof text, &used, "; ");
                if (f) nff_append(text, sizeof text, &used, "the 'f' of line %ld", f);
                else if (had_material) nff_append(text, sizeof text, &used, "the material set before this file");
                else nff_append(text, sizeof text, &used, "the default white diffuse material (no 'f' before)");
                if (several) nff_append(text, sizeof text, &used, " for line%s ", last ? "" : "s");
            }
            if (several) nff_append(text, sizeof text, &used, "%s%ld", first ? "" : ", ", sk->line[i][j]);
        }
    }
    mprt__scene_note(r->scene, "%s", text);
}

/* The notes of a read that succeeded: Ks + T over 1, each entity skipped. */
static void nff_notes(nff_reader *r, const nff_skips *sk, int had_material)
{
    int i;
    if (r->over_one)
        mprt__scene_note(r->scene,
                         "%s:%ld: material: Ks %g + T %g = %g is over 1 (%ld such material%s in the file): read as "
                         "written; a hit's reflection and refraction rays may then carry more light in all than "
                         "their parent, and the ray budget of a sample (max_rays) bounds the work",
                         r->name, r->over_line, r->over_ks, r->over_t, r->over_ks + r->over_t, r->over_one,
                         r->over_one == 1 ? "" : "s");
    for (i = 0; i < r->nunknown; i++) nff_skip_note(r, sk, i, had_material);
    if (r->unknown_more)
        mprt__scene_note(r->scene, "%s: %ld more lines of other unknown entities skipped, with their number lines",
                         r->name, r->unknown_more);
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
        st = mprt__nff_numbers(r, 1, 8, v, "after 'c' (base x y z r, apex x y z r)");
        if (st != MPRT_OK) return st;
    } else if (r->ntok == 1) {
        for (i = 0; i < 2; i++) {
            if (!mprt__nff_next_entity_line(r))
                return nff_fail(r, r->line, "expected the %s line (x y z radius) of the cone started at line %ld, found end of file",
                                end_name[i], start);
            snprintf(what, sizeof what, "for the %s of the cone started at line %ld (x y z radius)",
                     end_name[i], start);
            if ((st = mprt__nff_numbers(r, 0, 4, v + 4 * i, what)) != MPRT_OK) return st;
        }
    } else {
        return nff_fail(r, r->line,
                        "expected 8 numbers after 'c' (base x y z r, apex x y z r), or none and "
                        "base and apex on the next two lines, found %ld",
                        r->ntok - 1);
    }
    st = mprt_scene_add_cone(r->scene, v, v[3], v + 4, v[7]);
    return st == MPRT_OK ? st : mprt__nff_api_fail(r, st, start);
}

/* Sphere; the radius must be positive (NFF's inside-only negative radius is
 * not supported):
 *     s center.x center.y center.z radius */
static int nff_sphere(nff_reader *r)
{
    double v[4];
    int st = mprt__nff_numbers(r, 1, 4, v, "after 's' (x y z radius)");
    if (st != MPRT_OK) return st;
    st = mprt_scene_add_sphere(r->scene, v, v[3]);
    return st == MPRT_OK ? st : mprt__nff_api_fail(r, st, r->line);
}

/* Make room for n vertices in the polygon scratch arrays. */
static int nff_reserve(nff_reader *r, size_t n)
{
    size_t cap = r->capverts ? r->capverts : 64;
    double *a, *b;
    if (n <= r->capverts) return MPRT_OK;
    while (cap < n) cap *= 2;
    if (cap > SIZE_MAX / (3 * sizeof(double)))
        return mprt__nff_fail_status(r, MPRT_ERR_OUT_OF_MEMORY, r->line, "out of memory reading a polygon");
    a = realloc(r->verts, cap * 3 * sizeof(double));
    if (a) r->verts = a;
    b = realloc(r->norms, cap * 3 * sizeof(double));
    if (b) r->norms = b;
    if (!a || !b) return mprt__nff_fail_status(r, MPRT_ERR_OUT_OF_MEMORY, r->line, "out of memory reading a polygon");
    r->capverts = cap;
    return MPRT_OK;
}

/* Vertex i equals vertex j (and so do their normals for a patch) as the
 * scene would store them: positions in the build's precision, normals made
 * unit.  Two vertices written differently but stored alike would be written
 * back alike and merged when read again, so they are merged now. */
static int nff_same_vertex(const nff_reader *r, int patch, int i, int j)
{
    const double *a = r->verts + 3 * i, *b = r->verts + 3 * j;
    vec3 na, nb;
    if ((real)a[0] != (real)b[0] || (real)a[1] != (real)b[1] || (real)a[2] != (real)b[2]) return 0;
    if (!patch) return 1;
    na = mprt__unit_normal(r->norms + 3 * i);
    nb = mprt__unit_normal(r->norms + 3 * j);
    return na.x == nb.x && na.y == nb.y && na.z == nb.z;
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
    if (!mprt__nff_int(r, r->tok[1], &n) || n < 1)
        return nff_fail(r, r->line, "expected a positive integer vertex count after '%s', found '%s'", kw,
                        mprt__nff_show(r->tok[1], shown, sizeof shown));
    if (n < 3)
        return nff_fail(r, r->line, "expected a vertex count of at least 3 after '%s', found %d", kw, n);
    for (i = 0; i < n; i++) {
        if (!mprt__nff_next_entity_line(r))
            return nff_fail(r, r->line, "expected %d more vert%s of the %s started at line %ld, found end of file",
                            n - i, n - i == 1 ? "ex" : "ices", noun, start);
        if (!mprt__nff_try_numbers(r, 0, per, v)) {
            snprintf(what, sizeof what, "for vertex %d of %d of the %s started at line %ld (%s)", i + 1, n,
                     noun, start, patch ? "x y z nx ny nz" : "x y z");
            return mprt__nff_numbers(r, 0, per, v, what);
        }
        if ((st = nff_reserve(r, (size_t)i + 1)) != MPRT_OK) return st;
        memcpy(r->verts + 3 * i, v, 3 * sizeof(double));
        if (patch) memcpy(r->norms + 3 * i, v + 3, 3 * sizeof(double));
    }
    m = nff_merge_duplicates(r, patch, n);
    if (m >= 3) {
        st = mprt__scene_add_polygon(r->scene, m, r->verts, patch ? r->norms : NULL, &reason);
        if (st == MPRT_OK) return st;
        if (reason != MPRT__DEGENERATE) return mprt__nff_api_fail(r, st, start);
    }
    mprt__scene_warn(r->scene, "%s:%ld: %s with zero area dropped", r->name, start, noun);
    return MPRT_OK;
}

/* ---- Parse -------------------------------------------------------------- */

char mprt__decimal_point(void)
{
    const struct lconv *lc = localeconv();
    return lc && lc->decimal_point && lc->decimal_point[0] ? lc->decimal_point[0] : '.';
}

int mprt_scene_parse_nff(mprt_scene *scene, const char *text, size_t len, const char *name)
{
    return mprt_scene_parse_nff_ex(scene, text, len, name, 0);
}

int mprt_scene_parse_nff_ex(mprt_scene *scene, const char *text, size_t len, const char *name, unsigned flags)
{
    nff_reader r;
    nff_skips skips;
    mprt__scene_saved saved;
    char shown[160];
    int st = MPRT_OK, had_material;
    if (!scene || (!text && len)) return MPRT_ERR_INVALID_ARG;
    if (mprt__scene_check_unshared(scene, "parse_nff") != MPRT_OK) return MPRT_ERR_STATE;
    memset(&r, 0, sizeof r);
    memset(&skips, 0, sizeof skips);
    had_material = scene->material >= 0; /* (what surfaces before the first 'f' take) */
    r.scene = scene;
    r.name = name ? name : "<string>";
    r.p = text ? text : "";
    r.end = r.p + len;
    r.point = mprt__decimal_point();
    r.flags = flags;
    if (flags & ~(unsigned)MPRT_NFF_SKIP_UNKNOWN)
        return mprt__scene_fail(scene, MPRT_ERR_INVALID_ARG, "parse_nff: unknown flags 0x%x", flags & ~(unsigned)MPRT_NFF_SKIP_UNKNOWN);
    mprt__scene_mark(scene, &saved);
    while (st == MPRT_OK && mprt__nff_next_entity_line(&r)) {
        nff_token k = r.tok[0];
        int was_unknown = r.in_unknown;
        r.in_unknown = 0;
        if (was_unknown && nff_numberlike(k)) r.in_unknown = 1; /* data of the skipped entity */
        else if (nff_is(k, "s")) st = nff_sphere(&r);
        else if (nff_is(k, "p")) st = nff_polygon(&r, 0);
        else if (nff_is(k, "c")) st = nff_cone(&r);
        else if (nff_is(k, "f")) {
            st = nff_fill(&r);
            skips.last_fill = r.line;
        }
        else if (nff_is(k, "pp")) st = nff_polygon(&r, 1);
        else if (nff_is(k, "l")) st = nff_light(&r);
        else if (nff_is(k, "b")) st = nff_background(&r);
        else if (nff_is(k, "v")) st = nff_view(&r);
        else if ((flags & MPRT_NFF_SKIP_UNKNOWN) && !nff_numberlike(k)) nff_skip_unknown(&r, &skips);
        else st = nff_fail(&r, r.line, "unknown entity '%s'", mprt__nff_show(k, shown, sizeof shown));
    }
    if (st == MPRT_OK) nff_notes(&r, &skips, had_material);
    if (st != MPRT_OK) mprt__scene_rollback(scene, &saved);
    free(r.verts);
    free(r.norms);
    return st;
}

int mprt_scene_load_nff(mprt_scene *s, const char *path) { return mprt_scene_load_nff_ex(s, path, 0); }

int mprt_scene_load_nff_ex(mprt_scene *s, const char *path, unsigned flags)
{
    FILE *f;
    struct stat info;
    char *buf = NULL;
    size_t len = 0, cap = 0;
    int st;
    if (!s || !path) return MPRT_ERR_INVALID_ARG;
    if (mprt__scene_check_unshared(s, "load_nff") != MPRT_OK) return MPRT_ERR_STATE;
    f = fopen(path, "rb");
    if (!f) return mprt__scene_fail(s, MPRT_ERR_IO, "%s: cannot open for reading (%s)", path, strerror(errno));
    if (fstat(fileno(f), &info) == 0 && S_ISDIR(info.st_mode)) {
        fclose(f);
        return mprt__scene_fail(s, MPRT_ERR_IO, "%s: is a directory, not an NFF file", path);
    }
    /* Read to the end in growing blocks: the size of a pipe or a device is
     * not known in advance */
    for (;;) {
        size_t got;
        if (cap - len < 4096) {
            size_t ncap = cap ? cap * 2 : 1 << 16;
            char *nbuf = ncap > cap ? realloc(buf, ncap + 1) : NULL;
            if (!nbuf) {
                free(buf);
                fclose(f);
                return mprt__scene_fail(s, MPRT_ERR_OUT_OF_MEMORY, "%s: out of memory after reading %zu bytes", path,
                                        len);
            }
            buf = nbuf;
            cap = ncap;
        }
        got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) break;
    }
    if (ferror(f)) {
        int err = errno;
        free(buf);
        fclose(f);
        return mprt__scene_fail(s, MPRT_ERR_IO, "%s: read failed after %zu bytes (%s)", path, len, strerror(err));
    }
    fclose(f);
    buf[len] = '\0';
    st = mprt_scene_parse_nff_ex(s, buf, len, path, flags);
    free(buf);
    return st;
}
