/* mprt.h: the whole public C API of mprt, a ray tracer built as the 3MPRT
 * macropipeline (object search OS, intersection calculation IC, shading SC).
 *
 * Usage (tests/c/test_header_example.c compiles and runs this block as it
 * stands):
 *
 *     mprt_scene *scene;  mprt_grid *grid;  mprt_render_desc rd;  mprt_counters c;
 *     mprt_scene_create(&scene);
 *     if (mprt_scene_spd(scene, "balls", 2) != MPRT_OK)       // or mprt_scene_load_nff
 *         fprintf(stderr, "%s\n", mprt_scene_errmsg(scene));
 *     mprt_grid_create(scene, 32, 32, 32, 0, &grid);           // the voxel grid; 0: default memory limit
 *     mprt_render_desc_init(&rd);                              // defaults: paper rules
 *     rd.width = rd.height = 256;
 *     float *rgb = malloc(sizeof(float) * 3 * 256 * 256);
 *     if (mprt_grid_render(grid, &rd, rgb, 3 * 256 * 256, &c) != MPRT_OK)
 *         fprintf(stderr, "%s\n", mprt_grid_errmsg(grid));
 *     mprt_image_write_png("balls.png", 256, 256, rgb);
 *     mprt_grid_destroy(grid);  mprt_scene_destroy(scene);  free(rgb);
 *
 * Limitations: one uniform grid per render; no textures, no area lights, no
 * instancing; NFF is the only scene format; polygons must be planar.
 *
 * Ownership and threads: the caller owns every handle it creates and destroys
 * it with the matching *_destroy (which accepts NULL).  A grid keeps a pointer
 * to its scene: destroy grids before their scene.  A scene with grids cannot
 * change: every call that would change it (add, set, load, parse, spd) fails
 * with MPRT_ERR_STATE until its grids are destroyed (a grid that failed to
 * build does not count).  The library owns error message strings; one stays valid
 * until the next call on the same handle.  There is no global mutable state:
 * different handles may be used from different threads at once, and one grid
 * may be rendered or intersected by several threads at once.  The library
 * never prints, never exits, never aborts on bad input.
 *
 * Numbers are double precision unless the library is built with MPRT_SINGLE,
 * in which case all internal geometry is float (the API stays in double).
 */
#ifndef MPRT_H
#define MPRT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define MPRT_VERSION "0.1.0"

/* Status codes: 0 is success, every error is negative. */
typedef enum {
    MPRT_OK = 0,
    MPRT_ERR_INVALID_ARG = -1,   /* an argument is out of range, NaN or malformed */
    MPRT_ERR_OUT_OF_MEMORY = -2, /* an allocation failed or would exceed a limit */
    MPRT_ERR_STATE = -3,         /* the call is not allowed in the handle's state */
    MPRT_ERR_CAPACITY = -4,      /* a caller buffer is too small; the needed size is reported */
    MPRT_ERR_PARSE = -5,         /* malformed scene text; message names file and line */
    MPRT_ERR_IO = -6,            /* a file could not be opened, read or written */
    MPRT_ERR_LIMIT = -7          /* a work limit was reached (the ray budget of a sample) */
} mprt_status;

/* Primitive kinds, in the order the counters use. */
typedef enum {
    MPRT_SPHERE = 0,
    MPRT_POLYGON = 1,
    MPRT_CYLINDER = 2,
    MPRT_CONE = 3,
    MPRT_NKINDS = 4
} mprt_kind;

/* Shading rule sets. */
typedef enum {
    MPRT_RULES_PAPER = 0, /* 3MPRT: one ray per pixel centre, contribution cutoff */
    MPRT_RULES_SPD = 1,   /* SPD test procedure: pixel corners, depth 5, no cutoff */
    MPRT_RULES_PAPER1992 = 2 /* paper rules with the workload conventions closest to the
                              * 1992 paper's counts: behind = skip, candidates = specular
                              * (see mprt_render_desc; studies/12_paper_workload) */
} mprt_rules;

typedef struct mprt_scene mprt_scene;
typedef struct mprt_grid mprt_grid;

/* Generic text for a status code. */
const char *mprt_status_str(int status);

/* ---- Scene ------------------------------------------------------------ */

/* Create an empty scene (default view, black background, no lights). OUT: scene. */
int mprt_scene_create(mprt_scene **out);
/* Destroy a scene; NULL is allowed.  With grids still built on it, it is freed when the last of
 * them is destroyed (so a caller that frees by collection may free them in any order); it must
 * not be used meanwhile. */
void mprt_scene_destroy(mprt_scene *scene);
/* Message of the last failed call on this scene ("" if none). */
const char *mprt_scene_errmsg(const mprt_scene *scene);

/* First warning of the scene ("" if none): an entity dropped by the NFF
 * reader, with file and line.  mprt_scene_info.dropped counts them all. */
const char *mprt_scene_warning(const mprt_scene *scene);

/* Append the contents of an NFF file (on error the scene is unchanged). */
int mprt_scene_load_nff(mprt_scene *scene, const char *path);
/* Append NFF text; name is used in error messages (e.g. the file name).
 * On error the scene is left as it was before the call. */
int mprt_scene_parse_nff(mprt_scene *scene, const char *text, size_t len, const char *name);
/* Flags of the _ex readers.  MPRT_NFF_SKIP_UNKNOWN: an entity the reader does
 * not know (an extension line such as "fp ...", "Q 0", "Z 481") is skipped
 * with the lines after it that start with a number (its data), and a note
 * names each such entity with its count; without it, such a line is an error
 * naming the entity. */
#define MPRT_NFF_SKIP_UNKNOWN 1
int mprt_scene_load_nff_ex(mprt_scene *scene, const char *path, unsigned flags);
int mprt_scene_parse_nff_ex(mprt_scene *scene, const char *text, size_t len, const char *name, unsigned flags);
/* Notes of the NFF reads so far ("" if none), one line each ending in '\n':
 * a file's materials with Ks + T over 1 (read as written: the ray budget of a
 * sample bounds their ray trees) and the unknown entities skipped. */
const char *mprt_scene_notes(const mprt_scene *scene);
/* Write the scene as NFF text into buf (cap bytes, NUL included). OUT: needed
 * (bytes incl. NUL); MPRT_ERR_CAPACITY when cap < needed. */
int mprt_scene_write_nff(const mprt_scene *scene, char *buf, size_t cap, size_t *needed);
/* Append SPD scene name (balls, gears, mount, rings, tetra, tree) at SPD size
 * factor size; size <= 0 selects the SPD default for that scene. */
int mprt_scene_spd(mprt_scene *scene, const char *name, int size);

/* Geometry (positions, radii, the view's points and hither distance) must be
 * finite and at most 1e100 in magnitude (1e18 with MPRT_SINGLE), so that
 * the squares intersection forms stay finite; else MPRT_ERR_INVALID_ARG. */

/* Set the view: eye, look-at point, up vector, field angle in degrees (NFF
 * "angle": between the centres of the first and last pixel column, and of
 * the first and last row), hither distance, resolution. */
int mprt_scene_set_view(mprt_scene *scene, const double from[3], const double at[3],
                        const double up[3], double angle, double hither, int width,
                        int height);
/* Set the background colour. */
int mprt_scene_set_background(mprt_scene *scene, const double rgb[3]);
/* Add a point light; rgb may be NULL (NFF default intensity). */
int mprt_scene_add_light(mprt_scene *scene, const double pos[3], const double *rgb);
/* Set the material used by primitives added after this call (NFF "f"):
 * colour, diffuse Kd, specular Ks, Phong exponent shine, transmittance t and
 * index of refraction ior.  Kd, Ks and t must each be in [0, 1] and Ks + t
 * at most 1 (a hit's reflection and refraction rays never carry more than
 * their parent), shine >= 0, ior > 0 when t > 0; else MPRT_ERR_INVALID_ARG. */
int mprt_scene_set_material(mprt_scene *scene, const double rgb[3], double kd, double ks,
                            double shine, double t, double ior);
/* Add a sphere. */
int mprt_scene_add_sphere(mprt_scene *scene, const double center[3], double radius);
/* Add a planar polygon of n >= 3 vertices (xyz triples); normals (n triples)
 * may be NULL, else it is a polygon patch with interpolated vertex normals. */
int mprt_scene_add_polygon(mprt_scene *scene, int n, const double *verts, const double *normals);
/* Add an open cone frustum or cylinder (equal radii) between two discs. */
int mprt_scene_add_cone(mprt_scene *scene, const double base[3], double base_r,
                        const double apex[3], double apex_r);

/* Summary of a scene. */
typedef struct {
    long long prims;             /* all primitives */
    long long count[MPRT_NKINDS];/* by kind */
    long long patches;           /* polygons with vertex normals */
    long long vertices;          /* polygon vertices in all */
    long long lights;
    long long materials;
    long long dropped;           /* entities dropped with a warning (e.g. degenerate) */
    double lo[3], hi[3];         /* bounding box of all primitives */
    double from[3], at[3], up[3], angle, hither;
    int width, height;
    double background[3];
} mprt_scene_info;

/* Fill a summary of the scene. OUT: info. */
int mprt_scene_get_info(const mprt_scene *scene, mprt_scene_info *info);

/* Per primitive: kind (mprt_kind), size of its shape data in 32-bit words
 * (sphere 4; polygon 3 per vertex + 4 for its plane; cone/cylinder 8) and
 * material index; n entries each (cap >= primitive count). OUT: all three. */
int mprt_scene_get_prims(const mprt_scene *scene, int32_t *kind, int32_t *words, int32_t *material, size_t cap);

/* Shape data by kind, in primitive-id order within each kind, as the
 * renderer stores it (float values in MPRT_SINGLE builds); ids receive the
 * primitive ids.  spheres: 4 doubles each (centre xyz, radius).  cones: 8
 * doubles each (base centre xyz, base radius, apex centre xyz, apex radius);
 * the scene keeps cylinders and cones as one kind of shape, so this returns
 * both, MPRT_CYLINDER and MPRT_CONE, in id order (count[MPRT_CYLINDER] +
 * count[MPRT_CONE] entries; mprt_scene_get_prims tells them apart).
 * polygons: vstart (cap_polys + 1 entries) receives npoly + 1 offsets into
 * verts counted in vertices (polygon k is vertices vstart[k] ..
 * vstart[k+1]), verts 3 doubles per vertex.  cap and cap_* are capacities in
 * entries (shapes, polygons, vertices); the counts come from
 * mprt_scene_info (count[kind], vertices).  MPRT_ERR_CAPACITY when a
 * capacity is below its count; a NULL buffer is allowed for a count of 0.
 * OUT: ids, data (vstart, verts). */
int mprt_scene_get_spheres(const mprt_scene *scene, int32_t *ids, double *data, size_t cap);
int mprt_scene_get_cones(const mprt_scene *scene, int32_t *ids, double *data, size_t cap);
int mprt_scene_get_polygons(const mprt_scene *scene, int32_t *ids, int32_t *vstart, size_t cap_polys,
                            double *verts, size_t cap_verts);
/* Materials in table order (mprt_scene_get_prims gives each primitive's
 * index): 8 doubles each (r, g, b, kd, ks, shine, t, ior).  Lights in the
 * order added: 6 doubles each (position xyz, intensity rgb); a light added
 * without a colour gets the intensity the renderer gives it, 1/sqrt(number
 * of lights) per channel.  cap: capacity in materials or lights. OUT: data. */
int mprt_scene_get_materials(const mprt_scene *scene, double *data, size_t cap);
int mprt_scene_get_lights(const mprt_scene *scene, double *data, size_t cap);

/* ---- Grid --------------------------------------------------------------- */

/* Build a uniform grid of nx*ny*nz voxels (each 1..1024) over the scene's
 * bounding box; the scene refuses changes while the grid exists.  OUT: grid.  On failure *out still holds a grid in a failed
 * state whose errmsg says why (or NULL when even that could not be
 * allocated); destroy it.  max_bytes bounds the memory the grid may use
 * (0 selects the default, 4 GiB). */
int mprt_grid_create(const mprt_scene *scene, int nx, int ny, int nz, size_t max_bytes,
                     mprt_grid **out);
/* How a grid lists primitives in voxels: in every voxel the primitive's
 * surface may touch (exact overlap tests, the default); in every voxel its
 * bounding box touches (as simpler tracers do); or in those and one more
 * voxel beyond the box's last on each axis (a box's voxel range rounded
 * outward, floor(lo) to ceil(hi), as an off-by-one tracer would).  More
 * list entries, more intersection tests, the same hits.  MPRT_LIST_OCCUPIED
 * (a study): only in the voxels whose interior the surface meets (or whose
 * face a flat primitive lies in), leaving out those it meets only on their
 * boundary; fewer entries, but not watertight: a ray through a voxel edge
 * or corner can miss or break a tie differently (studies/03_bench). */
typedef enum {
    MPRT_LIST_EXACT = 0,
    MPRT_LIST_BOX = 1,
    MPRT_LIST_BOX_OUTWARD = 2,
    MPRT_LIST_OCCUPIED = 3
} mprt_listing;

/* mprt_grid_create with a listing convention (mprt_listing). */
int mprt_grid_create_listing(const mprt_scene *scene, int nx, int ny, int nz, size_t max_bytes, int listing,
                             mprt_grid **out);
/* Destroy a grid; NULL is allowed. */
void mprt_grid_destroy(mprt_grid *grid);
/* Message of the last failed call on this grid ("" if none). */
const char *mprt_grid_errmsg(const mprt_grid *grid);

typedef struct {
    int n[3];                    /* voxels per axis */
    long long voxels;            /* n[0]*n[1]*n[2] */
    long long nonempty;          /* voxels whose list is not empty */
    long long refs;              /* list entries in all */
    long long max_len;           /* longest list */
    double mean_len;             /* refs / nonempty (0 if none) */
    long long bytes;             /* memory of the grid's arrays */
    long long jump_voxels;       /* empty voxels from which the 3DDDA jumps over empty space
                                  * (0 unless the environment held MPRT_SKIP=1 or MPRT_JUMP_MIN=k
                                  * when the grid was made) */
    double lo[3], hi[3];         /* box the grid covers */
    int listing;                 /* mprt_listing */
} mprt_grid_stats;

/* Statistics of the grid. OUT: stats. */
int mprt_grid_get_stats(const mprt_grid *grid, mprt_grid_stats *stats);

/* The voxel lists in compressed-sparse-row form: voxel v (x fastest, then y,
 * then z) lists ids[start[v] .. start[v+1]).  cap_start >= voxels + 1,
 * cap_ids >= refs (see mprt_grid_stats). OUT: start, ids. */
int mprt_grid_get_lists(const mprt_grid *grid, uint32_t *start, size_t cap_start, int32_t *ids, size_t cap_ids);

/* ---- Rendering ---------------------------------------------------------- */

/* Counters of one render or one intersect batch. */
typedef struct {
    long long eye_rays;          /* primary rays */
    long long eye_hits;          /* primary rays that hit a primitive */
    long long reflect_rays;      /* reflection rays traced */
    long long refract_rays;      /* refraction rays traced */
    long long shadow_rays;       /* shadow rays traced */
    long long suppressed_rays;   /* rays not traced: contribution under the threshold or depth limit */
    long long voxels_traversed;  /* voxels entered by 3DDDA, over all rays */
    long long tests[MPRT_NKINDS];/* ray/primitive intersection tests by kind */
    long long polygon_vertices;  /* vertices touched by polygon tests */
    long long hits;              /* rays that hit a primitive (shadow rays: blocked) */
    long long os_visits;         /* OS stage visits */
    long long ic_visits;         /* IC stage visits */
    long long sc_visits;         /* SC stage visits */
    long long tir;               /* SC visits on a transmitting surface where total
                                  * internal reflection left no refraction ray, counted
                                  * where the depth limit allowed a child (SPD's "refract
                                  * rays" column is refract_rays + tir); not in the
                                  * trace records */
} mprt_counters;

typedef struct {
    int width, height;   /* image size; 0 = the scene's view resolution */
    int rules;           /* MPRT_RULES_PAPER, MPRT_RULES_SPD or MPRT_RULES_PAPER1992 */
    double threshold;    /* contribution cutoff (paper and paper1992 rules only) */
    int max_depth;       /* deepest ray tree level, eye ray = 1 (0 = rules' default) */
    int threads;         /* worker threads; 0 = 1 */
    int tile;            /* tile edge in pixels for the thread work split */
    double ambient;      /* ambient light level multiplying the surface colour */
    int mailbox;         /* 1: IC skips primitives this ray already tested in an
                          * earlier voxel (fewer tests, same image); 0: test every
                          * listed primitive in every voxel, as the paper's IC does */
    /* Workload conventions; 0 selects the rule set's choice (the MPRT_OFFSET_*,
     * MPRT_ACCEPT_*, MPRT_BEHIND_*, MPRT_CANDIDATES_* and MPRT_SHADOW_*
     * values below).  Each is one way a tracer may do a thing the paper
     * leaves open; paper rules pick the first of each, spd rules too except
     * behind (skip), paper1992 skip and specular. */
    int offset;          /* where secondary and shadow rays start */
    int accept;          /* which hit IC accepts in a voxel */
    int behind;          /* a light behind the surface */
    int candidates;      /* the secondary candidates SC counts at a hit */
    int shadow_term;     /* what the threshold compares for a shadow ray */
    int max_rays;        /* ray budget of one sample (its eye ray and every ray of its
                          * tree); a sample that needs more fails the render or trace
                          * with MPRT_ERR_LIMIT naming the sample, so no scene can
                          * run away (0 = MPRT_DEFAULT_MAX_RAYS) */
} mprt_render_desc;

/* Default ray budget of a sample: SPD's scenes need at most about 120. */
#define MPRT_DEFAULT_MAX_RAYS 65536

/* The workload conventions' choices (fields of mprt_render_desc). */
enum {
    /* offset: off the surface by 512 ulps of the hit point's largest
     * coordinate (paper, spd), or exactly on it (a ray may hit the surface
     * it leaves at t ~ 1e-17) */
    MPRT_OFFSET_SCALED = 1,
    MPRT_OFFSET_NONE = 2,
    /* accept: a hit within the voxel's stretch of the ray only (paper, spd:
     * results do not depend on the grid), or the nearest hit among the
     * voxel's primitives wherever it lies (results depend on the grid) */
    MPRT_ACCEPT_IN_VOXEL = 1,
    MPRT_ACCEPT_LISTED = 2,
    /* behind (N.L <= 0): a shadow candidate carrying 0, cut by the threshold
     * like any (paper), no candidate (spd), or a shadow ray cast whatever
     * the threshold */
    MPRT_BEHIND_CUTOFF = 1,
    MPRT_BEHIND_SKIP = 2,
    MPRT_BEHIND_CAST = 3,
    /* candidates: a reflection candidate when Ks > 0 (spd: or T > 0) and a
     * refraction one when T > 0 (paper, spd); both on every specular
     * surface (Ks > 0 or T > 0); or both at every hit.  A candidate of
     * weight 0 is suppressed by any threshold. */
    MPRT_CANDIDATES_MATERIAL = 1,
    MPRT_CANDIDATES_SPECULAR = 2,
    MPRT_CANDIDATES_ALL = 3,
    /* shadow_term: N.L x Kd x contribution times the light's mean intensity
     * (paper), or without the light (the digest's luminance term) */
    MPRT_SHADOW_LIGHT = 1,
    MPRT_SHADOW_SURFACE = 2
};

/* Fill a render description with defaults. OUT: desc. */
void mprt_render_desc_init(mprt_render_desc *desc);

/* Resolve a render description's defaults against the grid's scene: width
 * and height 0 -> the view's resolution, max_depth 0 -> the rules' default
 * (paper 64, spd 5), threads 0 -> 1, tile <= 0 -> 16, max_rays 0 ->
 * MPRT_DEFAULT_MAX_RAYS; and validate every
 * field (the same checks, with the same messages, as mprt_grid_render).
 * OUT: out (may alias desc). */
int mprt_grid_resolve_desc(mprt_grid *grid, const mprt_render_desc *desc, mprt_render_desc *out);

/* Render the grid's scene.  rgb receives width*height*3 floats, row-major
 * from the top row; cap is its length in floats.  OUT: rgb, counters
 * (counters may be NULL). */
int mprt_grid_render(mprt_grid *grid, const mprt_render_desc *desc, float *rgb, size_t cap,
                     mprt_counters *counters);

/* Closest hit of n arbitrary rays (origins and directions as xyz triples;
 * directions need not be unit), with mailboxing.  OUT: t[i] (distance in units of the given
 * direction, +inf for a miss) and prim[i] (primitive id or -1); counters may be
 * NULL. */
int mprt_grid_intersect(mprt_grid *grid, size_t n, const double *origins,
                        const double *directions, double *t, int32_t *prim,
                        mprt_counters *counters);

/* ---- Traces --------------------------------------------------------------
 * A trace records every stage visit of every ray of a tile of samples (pixel
 * centres under paper rules, pixel corners under spd rules).  Rays are
 * numbered from 0 within the tile in the order they are made; visits are
 * grouped by ray, each ray's visits in order, rays in the order traced. */

typedef enum { MPRT_STAGE_OS = 0, MPRT_STAGE_IC = 1, MPRT_STAGE_SC = 2 } mprt_stage;
typedef enum { MPRT_RAY_PRIMARY = 0, MPRT_RAY_REFLECT = 1, MPRT_RAY_REFRACT = 2, MPRT_RAY_SHADOW = 3 } mprt_ray_kind;
typedef enum {
    MPRT_OUT_TO_IC = 0,    /* OS: reached a voxel holding primitives; to IC */
    MPRT_OUT_LEFT = 1,     /* OS: a primary or secondary ray left the space; dies */
    MPRT_OUT_TO_SC = 2,    /* OS: a shadow ray left the space unblocked; to SC */
    MPRT_OUT_HIT = 3,      /* IC: nearest hit accepted; to SC */
    MPRT_OUT_BLOCKED = 4,  /* IC: a shadow ray hit something; dies */
    MPRT_OUT_RETURN = 5,   /* IC: no hit accepted in this voxel; back to OS */
    MPRT_OUT_SHADED = 6,   /* SC: shaded a hit and made its children; dies */
    MPRT_OUT_LIT = 7,      /* SC: added a shadow ray's light; dies */
    MPRT_OUT_LATE_HIT = 8  /* OS: the walk ended holding a hit found in an earlier
                            * voxel beyond that voxel's stretch (rounding at the
                            * grid box's face); to SC */
} mprt_outcome;

/* One ray of a trace. */
typedef struct {
    int64_t id;            /* tile-local ray number */
    int64_t parent;        /* the ray whose SC visit made it, -1 for primary rays */
    int32_t pixel;         /* sample index: y * samples_per_row + x */
    int16_t light;         /* shadow rays: light index; else -1 */
    uint8_t kind;          /* mprt_ray_kind */
    uint8_t depth;         /* ray tree level, the eye ray is 1 */
    double contribution;   /* how much the ray can still add to its pixel */
} mprt_trace_ray;

/* One stage visit of a trace. */
typedef struct {
    int64_t ray;           /* tile-local ray number */
    int64_t voxel_id;      /* OS: id of the voxel handed to IC (-1 if none); IC: voxel tested */
    int32_t steps;         /* OS: voxels entered by the 3DDDA during this visit */
    int32_t tests[MPRT_NKINDS]; /* IC: intersection tests by primitive kind */
    int32_t vertices;      /* IC: polygon vertices touched by the tests */
    int32_t prim;          /* IC/SC: primitive hit, or -1 */
    uint8_t stage;         /* mprt_stage */
    uint8_t outcome;       /* mprt_outcome */
    uint8_t made;          /* SC: rays made */
    uint8_t suppressed;    /* SC: rays not made (threshold or depth) */
} mprt_trace_visit;

/* Sample grid and tiling of a render: samples per row and column, tiles per
 * row and column (tile edge desc->tile). OUT: all four. */
int mprt_grid_tiling(mprt_grid *grid, const mprt_render_desc *desc, int *samples_w, int *samples_h,
                     int *tiles_x, int *tiles_y);

/* Rectangle of tile number tile (0 .. tiles_x*tiles_y-1, row by row) in
 * sample coordinates: x0, y0 (inclusive), x1, y1 (exclusive). OUT: rect. */
int mprt_grid_tile_rect(mprt_grid *grid, const mprt_render_desc *desc, int tile, int rect[4]);

/* Eye rays of samples first .. first+n-1 (sample index = y * samples_w + x,
 * samples as in mprt_grid_tiling: pixel centres under paper rules, pixel
 * corners under spd rules), exactly as the renderer makes them: the eye and
 * a unit direction (a ray starts at the hither plane, hither /
 * dot(direction, view direction) along it). OUT: origins, directions (3
 * doubles per ray). */
int mprt_grid_camera_rays(mprt_grid *grid, const mprt_render_desc *desc, size_t first, size_t n,
                          double *origins, double *directions);

/* Pixels from samples exactly as the renderer reconstructs them: under spd
 * rules the mean of each pixel's four corners (an image of (samples_w-1) x
 * (samples_h-1) pixels), under paper rules the sample itself (samples_w x
 * samples_h pixels).  samples: samples_h*samples_w*3 doubles, row by row
 * from the top; rgb receives width*height*3 floats (cap floats).
 * MPRT_ERR_CAPACITY when cap is too small. OUT: rgb. */
int mprt_samples_to_image(int rules, int samples_w, int samples_h, const double *samples, float *rgb,
                          size_t cap);

/* Trace one tile of samples.  samples receives the tile's sample colours
 * (rows of the tile, 3 doubles each; cap_samples doubles); rays and visits
 * receive the records.  OUT: nrays, nvisits (the numbers the tile needs:
 * when either exceeds its capacity, MPRT_ERR_CAPACITY is returned and the
 * caller retries with larger buffers), counters (may be NULL). */
int mprt_grid_trace_tile(mprt_grid *grid, const mprt_render_desc *desc, int tile, double *samples,
                         size_t cap_samples, mprt_trace_ray *rays, size_t cap_rays, size_t *nrays,
                         mprt_trace_visit *visits, size_t cap_visits, size_t *nvisits,
                         mprt_counters *counters);

/* Trace the tiles tiles[0..ntiles-1] in that order, writing each record
 * once, in place, into one pair of buffers: the tiles' records follow one
 * another, and ray ids (and so parents and visits' rays) are numbered on from
 * first_ray, as if the tiles were one.  samples is the whole sample image
 * (samples_h*samples_w*3 doubles, row by row; cap_samples doubles): each
 * tile's samples are written in place.  The call stops before a tile that
 * would not fit what is left of the buffers (it may trace it first, then
 * leave it unrecorded and uncounted): the caller hands the records on and
 * calls again with the tiles left.  OUT: ntraced (the tiles recorded),
 * nrays and nvisits (their records), counters (theirs; may be NULL).  When
 * not even the first tile fits, MPRT_ERR_CAPACITY is returned with nrays and
 * nvisits the sizes it needs. */
int mprt_grid_trace_tiles(mprt_grid *grid, const mprt_render_desc *desc, const int *tiles, size_t ntiles,
                          double *samples, size_t cap_samples, int64_t first_ray, mprt_trace_ray *rays,
                          size_t cap_rays, size_t *nrays, mprt_trace_visit *visits, size_t cap_visits,
                          size_t *nvisits, size_t *ntraced, mprt_counters *counters);

/* Write rgb (width*height*3 floats in [0,1], clamped) as an 8-bit PNG. */
int mprt_image_write_png(const char *path, int width, int height, const float *rgb);

/* CRC-32 of n bytes at src (the polynomial of zip, gzip and PNG: zlib's
 * crc32(crc, src, n)), crc being the value so far (0 to start); when dst is
 * not NULL the bytes are copied to dst (n bytes, not overlapping src) in the
 * same pass.  Folded with carry-less multiplications where the processor
 * has them (x86-64 PCLMULQDQ); a portable loop elsewhere; the same value. */
uint32_t mprt_crc32_copy(void *dst, const void *src, size_t n, uint32_t crc);

/* Copy n trace records from src to dst (not overlapping; either at any byte
 * offset), their ray numbers moved on by offset on the way: visits (visits
 * not 0) their ray, rays their id and their parent unless it is negative (a
 * primary ray's -1).  This is how records numbered from 0 for a group of
 * tiles join a trace after offset rays.  With crc_out not NULL, *crc_out is
 * the CRC-32 of the bytes written, continuing from its value (as
 * mprt_crc32_copy); the same pass, over bytes still in cache. */
void mprt_trace_records_shift(int visits, void *dst, const void *src, size_t n, int64_t offset, uint32_t *crc_out);

/* ---- Visit costs -----------------------------------------------------------
 * What every visit of a trace costs on given processors, in one pass (the
 * cost model's arithmetic, python/mprt/cost/model.py; the tables come from
 * it).  A visit's process cycles are its stage's per-visit overhead plus its
 * kernel runs times each kernel's cycles (columns per stage below); its
 * receive cycles one packet's plus its flits in, its send cycles its packets
 * out and their flits.  Counted per visit, by stage (MPRT_COST_KERNELS
 * columns, unused ones 0):
 *   OS: ray set-up (its ray's first visit), voxel steps, 1, and on a late
 *       hit the hit finalisation of the primitive's kind (4 columns)
 *   IC: 1, tests by primitive kind (4), polygon vertices, and on a hit the
 *       hit finalisation of the primitive's kind (4)
 *   SC: on a shaded hit 1, lights, made + suppressed, children made by kind
 *       (shadow, reflect, refract); on a lit shadow ray 1 (column 6)
 * A visit's packet in comes from SC for a ray's first visit, else from the
 * stage before it (OS after IC, IC after OS, SC after IC or, following a
 * late hit, OS); it sends one packet to the next stage, or (SC, shaded) one
 * per ray made, of flits[src][dst][kind] flits (children: their own kinds). */
#define MPRT_COST_KERNELS 10
typedef struct {
    int64_t kernel[3][MPRT_COST_KERNELS]; /* cycles of one run, by stage and column */
    int64_t overhead[3];                  /* cycles added to every visit of a stage */
    int64_t send_packet[3], send_flit[3], receive_packet[3], receive_flit[3];
    int64_t flits[3][3][4];               /* flits of a packet src -> dst of a ray kind (0: none) */
    int64_t lights;                       /* lights of the scene (SC's work per shaded hit) */
} mprt_cost_table;

/* Children of every ray by kind: children[4 * r + k] rays of kind k have
 * ray r as parent (nrays x 4 entries).  A ray of an unknown kind or whose
 * parent is not among rays[0 .. nrays-1] is MPRT_ERR_INVALID_ARG with errmsg
 * (errlen bytes) naming it.  OUT: children. */
int mprt_cost_children(const mprt_trace_ray *rays, size_t nrays, int64_t *children, char *errmsg, size_t errlen);

/* Cost visits[0 .. nvisits-1] of a trace whose rays are rays[0 .. nrays-1]
 * (ids are indices; children as mprt_cost_children gives them) and whose
 * primitives have kinds prim_kind[0 .. nprims-1].  prev_ray and
 * prev_outcome: the visit before visits[0] in the trace (-1 and 0: none).
 * Every output may be NULL; each has one entry per visit (runs:
 * MPRT_COST_KERNELS, packets: 3 (flits in, packets out, flits out)).
 * Arithmetic wraps modulo 2^64 (flits, runs and packets modulo 2^32).  A
 * visit that does not fit (its stage, its ray or the ray's kind, its
 * primitive) is MPRT_ERR_INVALID_ARG with errmsg (errlen bytes) naming it.
 * Without runs and packets, up to threads threads (1..16) share the visits
 * (at least 2^20 each); the results do not depend on their number.
 * OUT: process, receive, send (cycles), flits (flits out), runs, packets. */
int mprt_cost_visits(const mprt_cost_table *table, const mprt_trace_ray *rays, const int64_t *children,
                     size_t nrays, const int32_t *prim_kind, size_t nprims, const mprt_trace_visit *visits,
                     size_t nvisits, int64_t prev_ray, int prev_outcome, int64_t *process, int64_t *receive,
                     int64_t *send, int32_t *flits, int32_t *runs, int32_t *packets, int threads, char *errmsg,
                     size_t errlen);

/* ---- Replay ----------------------------------------------------------------
 * A compiled replay of a trace on any machine of the fidelity ladder's levels
 * 1 to 3: PEs of 1 to 3 stages (each a processor, or several replicas of one,
 * running one or more of the subtasks OS, IC, SC), send and receive FIFOs
 * of any capacity, an ideal network (no latency, no bandwidth limit) or the
 * ring (links, flit buffers by class, wormhole paths), an ideal memory
 * (every access hits) or, at level 3, the IC and SC memories
 * (mprt_replay_set_memory below), DIS admitting primary rays under a window.
 * It applies the same event rules as the SimPy machine model
 * (python/mprt/machine, README.md there) and returns the same cycle counts
 * to the cycle; python/mprt/fidelity binds it.
 *
 * In C:
 *
 *     mprt_replay_config c;  mprt_replay *r;  mprt_replay_info info;
 *     mprt_replay_config_init(&c);            // model M: 3 stages, 1 PE
 *     mprt_replay_create(&c, &r);
 *     if (mprt_replay_load(r, rays, nrays, visits, nvisits, process, receive, send) != MPRT_OK ||
 *         mprt_replay_run(r, NULL, 0) != MPRT_OK)
 *         fprintf(stderr, "%s\n", mprt_replay_errmsg(r));   // bad input, or a deadlock
 *     mprt_replay_get_info(r, &info);          // info.cycles
 *     mprt_replay_destroy(r);
 *
 * Costs come from the caller (the cost model), one entry per visit:
 * process, receive and send cycles; a visit lasts their sum (at least 1).
 * On the ring the packets' flits too (mprt_replay_set_flits). */

/* How DIS deals primary rays (trees) to PEs: static blocks of consecutive
 * trees, interleaved (tree t to PE t mod pes), or one shared sequence each
 * PE draws from when its window has room. */
typedef enum { MPRT_DIS_BLOCKS = 0, MPRT_DIS_INTERLEAVED = 1, MPRT_DIS_DYNAMIC = 2 } mprt_dis;

/* States of a processor (mprt_replay_proc.state). */
typedef enum {
    MPRT_PROC_IDLE = 0,     /* nothing to do: its receive FIFO and local queue are empty */
    MPRT_PROC_BUSY = 1,     /* running a visit */
    MPRT_PROC_BLOCKED = 2,  /* holding packets its full send FIFO cannot take */
    MPRT_PROC_RESUMING = 3  /* its packets placed, resuming at this cycle */
} mprt_proc_state;

typedef struct {
    int nstages;                        /* stages per PE, in ring order, 1..3 */
    int stage_of[3];                    /* the stage running OS, IC and SC */
    int replicas[3];                    /* processors of each stage (first nstages used), >= 1 */
    int64_t receive_fifo[3];            /* capacity in packets; 0 = unbounded */
    int64_t send_fifo[3];               /* capacity in packets; 0 = unbounded */
    int feed[3];                        /* how a stage's replicas get packets: 0 one shared receive
                                         * FIFO; 1 round-robin, 2 shortest queue: a receive FIFO
                                         * (of receive_fifo) and local queue per replica */
    int pes;                            /* processing elements, >= 1 */
    int dis;                            /* mprt_dis */
    int64_t window;                     /* live rays a PE's DIS admits up to, >= 1 */
    int64_t gen_cycles;                 /* cycles SC spends making a primary ray and sending
                                         * it to OS; 0: DIS hands primaries to OS directly */
    /* level 2: the ring (python/mprt/machine/README.md, "The ring"): each PE's
     * stages on a unidirectional ring, packets of the flits mprt_replay_set_flits
     * gives, wormhole-routed; ring 0: the ideal network */
    int ring;                           /* 1: the ring (needs nstages >= 2) */
    int buffer_classes;                 /* header buffers per node, 1..nstages */
    int64_t flit_time;                  /* cycles a link takes per flit, >= 1 */
    /* level 3: the memories.  Index 0: the IC data (voxel lists, shapes) behind ICGM; 1: the
     * SC data (materials) behind SCGM.  A modelled memory needs mprt_replay_set_memory's data. */
    int memory[2];                      /* 1: modelled (a local memory per PE); 0: every access hits */
    int64_t cache_size[2];              /* bytes, at most MPRT_REPLAY_MAX_CACHE; 0: no cache */
    int64_t cache_line[2];              /* bytes, a power of two (no cache: the unit of a read) */
    int64_t cache_ways[2];              /* lines per set (with a cache: size / (line x ways) sets) */
    int64_t gm_latency[2];              /* cycles from a miss's transfer to its data */
    int64_t gm_bandwidth[2];            /* bytes per cycle, >= 1 */
    int gm_contention[2];               /* 1: one port shared by all PEs; 0: one per PE */
} mprt_replay_config;

typedef struct mprt_replay mprt_replay;

/* Model M's configuration: 3 stages OS, IC, SC, one processor each,
 * unbounded FIFOs, 1 PE, dynamic DIS, window 256, gen_cycles 0. OUT: cfg. */
void mprt_replay_config_init(mprt_replay_config *cfg);
/* Check a configuration and make a replay of it (an invalid field fails
 * with a message naming it, readable from *out; destroy it). OUT: out. */
int mprt_replay_create(const mprt_replay_config *cfg, mprt_replay **out);
/* Destroy a replay; NULL is allowed. */
void mprt_replay_destroy(mprt_replay *r);
/* Message of the last failed call on this replay ("" if none). */
const char *mprt_replay_errmsg(const mprt_replay *r);

/* Change the configuration (the loaded trace stays). */
int mprt_replay_set_config(mprt_replay *r, const mprt_replay_config *cfg);

/* Load a trace (rays and visits as mprt_grid_trace_tile records them, tiles
 * joined: ray ids 0..nrays-1, each primary ray's tree contiguous, parents
 * before children) with its per-visit costs (nvisits entries each): checked
 * and copied in the replay's own compact form (16 bytes per visit), so the
 * caller's arrays may go, and one load serves runs of any configuration.  A
 * malformed trace or cost fails with MPRT_ERR_INVALID_ARG naming it. */
int mprt_replay_load(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits,
                     size_t nvisits, const int64_t *process, const int64_t *receive, const int64_t *send);

/* mprt_replay_load with each visit priced as it is loaded, a few thousand at
 * a time (mprt_cost_visits's arithmetic, with table, children and prim_kind
 * as it takes them): the same replay as loading the arrays mprt_cost_visits
 * gives, without making them; flits (nvisits entries, or NULL) receives
 * each visit's flits out, as mprt_cost_visits gives them (for the ring:
 * mprt_replay_set_flits).  A visit it cannot price is MPRT_ERR_INVALID_ARG,
 * the message starting "cannot cost this trace: ". */
int mprt_replay_load_priced(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays, const mprt_trace_visit *visits,
                            size_t nvisits, const mprt_cost_table *table, const int64_t *children,
                            const int32_t *prim_kind, size_t nprims, int32_t *flits);
/* mprt_replay_load_priced with the flits (or NULL) as int64, what
 * mprt_replay_set_flits takes; with threads >= 2 (and a large trace) the
 * visits priced on a thread of its own while this one loads them, a block
 * ahead: the same replay, flits and errors as with one thread. */
int mprt_replay_load_priced_threads(mprt_replay *r, const mprt_trace_ray *rays, size_t nrays,
                                    const mprt_trace_visit *visits, size_t nvisits, const mprt_cost_table *table,
                                    const int64_t *children, const int32_t *prim_kind, size_t nprims, int64_t *flits,
                                    int threads);

/* The packets' sizes for the ring (level 2), for the loaded trace: flits[j]
 * (nvisits entries) of the packet visit j sends on to its ray's next visit;
 * kid_flits[kind] (nkinds entries, a kind per mprt_ray_kind) of a packet
 * carrying a ray an SC visit made; inject_flits of a primary ray SC made.
 * Flits 0..65535 (0 and 1: the header alone).  Needed before a run on a ring. */
int mprt_replay_set_flits(mprt_replay *r, const int64_t *flits, size_t nvisits, const int64_t *kid_flits,
                          size_t nkinds, int64_t inject_flits);

/* Replay the loaded trace on the configuration.  log (may be NULL)
 * receives 4 int64 per event: cycle, 0 start / 1 end, processor, visit (~t:
 * making primary ray t); log_cap (int64 entries) must hold 8 * (visits +
 * primary rays).  A machine that stops with rays still in it (full FIFOs
 * waiting on each other) fails with MPRT_ERR_STATE and info.deadlocked set,
 * its final state readable by the getters below. */
int mprt_replay_run(mprt_replay *r, int64_t *log, size_t log_cap);

/* A lower bound of the cycles a run of the loaded trace on the configuration
 * set would take, at any level (the ring and the memories only add to a
 * visit): no processor finishes before its share of its stage's work, a
 * stage's work being its visits' process and communication cycles, on the
 * stage running SC gen_cycles per primary ray made, and at level 3, for a
 * memory whose data mprt_replay_set_memory gave, the reads no state of it can
 * spare, each at a transfer and the latency at least: without a cache every
 * line of a visit's key, with one the key's distinct lines in each set beyond
 * its ways; shared among its replicas; with the static DIS policies each PE's
 * own trees, with the dynamic one all trees over all PEs.  Nor does it finish
 * before its trees' lifetimes over window (DIS admits a tree while fewer than
 * window rays are live, so at most window trees of a PE are in flight; with
 * the dynamic DIS, window x PEs trees in all), a tree living at least
 * gen_cycles and its critical path, and at least its work on a stage over
 * the stage's replicas.  Its critical path is the longest chain of its
 * visits' cycles and reads as above, a ray's visits in turn and the rays an
 * SC visit made after it; on a ring (packet sizes set) each step between
 * stages adds its packet's least time (the header's hops, then its other
 * flits, a flit time each).  Nothing is run; the last run's figures stay.
 * A configuration the run would refuse for its figures (a trace without
 * primary rays, cycles beyond 2^62) fails as the run does. OUT: cycles. */
int mprt_replay_work_bound(mprt_replay *r, int64_t *cycles);

typedef struct {
    int64_t cycles;         /* when the last ray retired; -1 after a deadlock or before a run */
    int64_t deadlocked;     /* 1: the machine stopped with rays still in it */
    int64_t rays, visits, trees;   /* of the trace; trees = primary rays */
    int64_t retired;        /* rays retired */
    int64_t max_leaves;     /* the most leaves (rays making none) of any tree */
    int64_t events;         /* log entries written (4 int64 each) */
    int64_t processors;     /* entries of mprt_replay_get_procs: pes x sum of replicas */
    int64_t nodes;          /* entries of mprt_replay_get_nodes: pes x nstages */
    int64_t pes;            /* entries of mprt_replay_get_pes */
} mprt_replay_info;

/* One processor, after the run (order: PE, stage, replica). */
typedef struct {
    int64_t busy;           /* cycles running visits (making primary rays included) */
    int64_t blocked;        /* cycles blocked on a full send FIFO */
    int64_t visits;         /* visits run (making primary rays included) */
    int64_t state;          /* mprt_proc_state at the end */
    int64_t visit;          /* busy or blocked: its visit (~t: making primary ray t); else -1 */
    int64_t pending;        /* blocked: packets it still holds */
} mprt_replay_proc;

/* One stage of one PE (order: PE, stage): its FIFOs (area: occupancy
 * integrated over the run, in packet-cycles), local queue and the primary
 * rays it made. */
typedef struct {
    int64_t receive_occupancy, receive_max, receive_puts, receive_area;
    int64_t send_occupancy, send_max, send_puts, send_area;
    int64_t local_queue;
    int64_t generated;
    int64_t receive_reserved;   /* receive slots claimed by packets still on the ring */
} mprt_replay_node;

/* One PE: its DIS and rays, and its visits' costs by subtask (OS, IC, SC). */
typedef struct {
    int64_t admitted;       /* primary rays its DIS admitted */
    int64_t retired;        /* rays retired */
    int64_t end;            /* when its last ray retired */
    int64_t live, max_live; /* rays in the PE at the end, and at most */
    int64_t dis_holding;    /* 1: its DIS holds a primary waiting for a FIFO slot */
    int64_t processing[3];  /* process cycles of the visits run */
    int64_t communication[3];      /* receive + send cycles of the visits run */
    int64_t visits[3];      /* visits run */
} mprt_replay_pe;

/* Figures of the last run (also after a deadlock; info also after a load,
 * with nothing run yet).  cap: entries. OUT: out. */
int mprt_replay_get_info(const mprt_replay *r, mprt_replay_info *info);
int mprt_replay_get_procs(const mprt_replay *r, mprt_replay_proc *out, size_t cap);
int mprt_replay_get_nodes(const mprt_replay *r, mprt_replay_node *out, size_t cap);
int mprt_replay_get_pes(const mprt_replay *r, mprt_replay_pe *out, size_t cap);
/* Per primary ray (tree): the PE that admitted it and when (-1: never);
 * either pointer may be NULL.  cap: entries of each. OUT: pe, admitted. */
int mprt_replay_get_trees(const mprt_replay *r, int32_t *pe, int64_t *admitted, size_t cap);
/* Record in later runs (on 1; 0: stop), at each tree's admission, the cycles
 * each stage's processors (all PEs and replicas) had been busy by then (a
 * visit under way counted up to that cycle): what a sampled replay measures
 * the machine's idle time with. */
int mprt_replay_record_busy(mprt_replay *r, int on);
/* Per primary ray (tree), nstages entries: the busy cycles recorded at its
 * admission (-1: never admitted, or nothing recorded).  cap: int64 entries,
 * at least trees x nstages. OUT: out. */
int mprt_replay_get_tree_busy(const mprt_replay *r, int64_t *out, size_t cap);
/* Who waits for a slot in stage's receive FIFO of PE pe (which 0: sending
 * stages, -1 for the DIS), or in its send FIFO (which 1: replicas), in
 * order.  OUT: out (cap entries), n (the number waiting). */
int mprt_replay_get_waiters(const mprt_replay *r, int pe, int stage, int which, int64_t *out, size_t cap,
                            size_t *n);
/* The ring (a run with ring 1): each link's busy cycles (pes x nstages
 * entries, link n of a PE from its stage n to stage n + 1), and PE pe's ring
 * at the end: buffers (nstages x buffer_classes entries, node by node: the
 * packet holding it as source stage x 4 + destination stage, -1 free) and the
 * packets waiting for a grant in the order they began to wait, 4 entries each
 * (source stage, destination stage, the node its header is at, phase: 0 the
 * header waits for a link and buffer, 1 for the receive FIFO, 2 the body for
 * the path).  OUT: links; buffers, waiting (cap entries each), nwaiting (packets). */
int mprt_replay_get_links(const mprt_replay *r, int64_t *out, size_t cap);
int mprt_replay_get_ring(const mprt_replay *r, int pe, int64_t *buffers, size_t cap_buffers, int64_t *waiting,
                         size_t cap_waiting, size_t *nwaiting);

/* ---- level 3: the memories (replay_memory.c) ----
 *
 * Each visit reads the data of one key (IC: a voxel's list and its primitives'
 * shapes; SC: a material): some items from resident memory (no cost), the
 * rest as lines through the PE's cache (LRU, set-associative; a stage's
 * replicas share it), each miss read from the global memory one after the
 * other, when the visit starts: the port's first free cycle (ports serve in
 * the order visits start), the line's transfer (line / bandwidth, rounded
 * up), then the latency.  The resident set is chosen by the caller. */
#define MPRT_REPLAY_MAX_CACHE 1099511627776   /* 2^40 bytes */
/* A run refuses (before it starts) caches whose arrays over all PEs would hold
 * more entries (pes x sets x ways, the sets and ways limited to the lines the
 * memory data can fill). */
#define MPRT_REPLAY_MAX_CACHE_ENTRIES 268435456   /* 2^28 */

/* One memory's data: per key, items read (resident ones among them) and the
 * lines read outside resident memory, keys' lines in CSR form. */
typedef struct {
    size_t nkeys;
    int64_t line;                       /* bytes per line the lines were numbered with */
    const int32_t *items;               /* per key: items read */
    const int32_t *resident;            /* per key: items found in resident memory */
    const int64_t *line_start;          /* per key + 1: its lines are lines[line_start[k] .. line_start[k+1]) */
    const int64_t *lines;               /* line numbers (address / line), >= 0; line_start[nkeys] entries */
} mprt_replay_memory_data;

/* Give the loaded trace its memory data (copied; kept for later runs until the
 * next load or call): key[j] per visit (nvisits = the trace's): >= 0 a key of
 * ic (an IC visit's voxel), <= -2 key -2 - key[j] of sc (an SC visit's
 * material), -1 none.  ic or sc may be NULL (no key of it). */
int mprt_replay_set_memory(mprt_replay *r, const int32_t *key, size_t nvisits, const mprt_replay_memory_data *ic,
                           const mprt_replay_memory_data *sc);

/* One PE's figures for one memory after a run. */
typedef struct {
    int64_t stall;                      /* memory stall cycles of its visits */
    int64_t cache_accesses, cache_hits;
    int64_t resident_accesses, resident_hits;   /* items */
    int64_t gm_accesses, gm_busy, gm_queued;    /* its reads: transfer cycles, cycles waited for the port */
} mprt_replay_memory;

/* Per PE and memory (out: pes x 2 entries, PE-major; zeros for a memory not
 * modelled) and per processor (stall: processors entries, may be NULL): the
 * memory figures of the last run. */
int mprt_replay_get_memory(const mprt_replay *r, mprt_replay_memory *out, size_t cap, int64_t *stall,
                           size_t stall_cap);

/* ---- Level 3's memory keys -------------------------------------------------
 * Per visit the key of the data level 3 reads (python/mprt/fidelity/
 * memdata.py): an IC visit's voxel_id (>= 0, or -1), an SC visit that names
 * a primitive -2 - its material (prim_material[prim]), else -1; and the
 * references to each key: voxel_refs[nvoxels] (IC visits by voxel),
 * material_refs[nmaterials] (SC visits by material).  A voxel, primitive or
 * material outside those arrays, or a key below INT32_MIN, is
 * MPRT_ERR_INVALID_ARG with errmsg naming the visit.  OUT: keys, voxel_refs,
 * material_refs. */
int mprt_visit_keys(const mprt_trace_visit *visits, size_t nvisits, const int64_t *prim_material, size_t nprims,
                    int32_t *keys, int64_t *voxel_refs, size_t nvoxels, int64_t *material_refs, size_t nmaterials,
                    char *errmsg, size_t errlen);

/* ---- Trace check -----------------------------------------------------------
 * The checks every reader of a trace runs on its records (python/mprt/
 * tracevalid.py: each field's range; python/mprt/tracecheck.py: the
 * invariants between records), in one pass over the records where they lie
 * (a memory-mapped file is read in place), in chunks so the caller can let
 * the pages go between calls.  It answers whether the records pass, with a
 * short reason; the Python checkers name the first fault in their own words.
 * Memory: 9 bytes a ray. */
typedef struct {
    int64_t pixels;      /* samples_w * samples_h: a ray's pixel is below */
    int64_t lights;      /* a ray's light is -1 .. lights - 1; made, suppressed 0 .. lights + 2 */
    int64_t max_depth;   /* a ray's depth is at most this */
    int64_t voxels;      /* a visit's voxel_id is -1 .. voxels - 1 */
    int64_t prims;       /* a visit's prim is -1 .. prims - 1 */
    int64_t steps;       /* a visit's steps are 0 .. steps */
    int64_t tests;       /* each of a visit's tests is 0 .. tests */
    int64_t vertices;    /* a visit's vertices are 0 .. vertices */
    int invariants;      /* nonzero: the invariants too, else the ranges only */
} mprt_trace_limits;

typedef struct mprt_trace_checker mprt_trace_checker;

/* Fault kinds (mprt_trace_checker_fault). */
enum { MPRT_TRACE_SOUND = 0, MPRT_TRACE_RANGE = 1, MPRT_TRACE_INVARIANT = 2, MPRT_TRACE_REDO = 3 };

/* A checker of rays[0..nrays-1] (kept, not copied: they must stay until the
 * last call) under lim; NULL when out of memory. */
mprt_trace_checker *mprt_trace_checker_create(const mprt_trace_limits *lim, const mprt_trace_ray *rays,
                                              size_t nrays);
void mprt_trace_checker_destroy(mprt_trace_checker *c);
/* Check rays [lo, hi) (every ray once, in order, before the visits), then the
 * visits a chunk at a time in order (visits: the next nvisits of them), then
 * finish.  Each returns the fault kind found so far (0: none; after a fault
 * the later calls do nothing and return it). */
int mprt_trace_checker_rays(mprt_trace_checker *c, size_t lo, size_t hi);
int mprt_trace_checker_visits(mprt_trace_checker *c, const mprt_trace_visit *visits, size_t nvisits);
int mprt_trace_checker_finish(mprt_trace_checker *c);
/* The first fault's reason ("" when none). */
const char *mprt_trace_checker_errmsg(const mprt_trace_checker *c);
/* Level 3's memory keys made in the same pass (before the first visit is
 * checked): each visit whose ranges hold gets mprt_visit_keys's key in
 * keys[nvisits] and its reference in voxel_refs[nvoxels] or
 * material_refs[nmaterials] (zeroed here), the primitives' materials read
 * from prim_material[nprims].  A key mprt_visit_keys would refuse (or a
 * voxel id beyond 32 bits) stops the keys, not the check.
 * mprt_trace_checker_keys_done: 1 when every visit's key was made and the
 * records passed so far (call after finish), else 0 (then make them with
 * mprt_visit_keys). */
int mprt_trace_checker_keys(mprt_trace_checker *c, const int64_t *prim_material, size_t nprims, int32_t *keys,
                            size_t nvisits, int64_t *voxel_refs, size_t nvoxels, int64_t *material_refs,
                            size_t nmaterials);
int mprt_trace_checker_keys_done(const mprt_trace_checker *c);
/* A check split in two parts run at once (on two threads): after the rays,
 * before any visit, mprt_trace_checker_split(c, &visits[from - 1], from)
 * makes a checker of visits from .. n-1 (before: the visit before them;
 * NULL when from is 0) with state of its own (9 bytes a ray; its memory
 * keys into the same keys, its references apart); c then checks visits
 * 0 .. from-1, the part visits from on (each a chunk at a time, in order),
 * then mprt_trace_checker_join(c, part) settles what lies across the
 * split and merges the part into c (destroy the part after), for c's
 * finish.  join answers the first part's fault if it has one, else
 * MPRT_TRACE_REDO when the second part or what lies across the split has
 * one (then check again in one part: only one pass says which fault comes
 * first), else SOUND.  split: NULL when out of memory or called out of
 * order. */
mprt_trace_checker *mprt_trace_checker_split(mprt_trace_checker *c, const mprt_trace_visit *before, size_t from);
int mprt_trace_checker_join(mprt_trace_checker *c, mprt_trace_checker *part);

#ifdef __cplusplus
}
#endif
#endif
