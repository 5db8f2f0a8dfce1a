/* spd.c: the Standard Procedural Databases scene generators (balls, gears,
 * mount, rings, tetra, tree): the entry point.  The generators are in
 * spd_fractals.c (balls, mount, tetra, tree) and spd_objects.c (gears,
 * rings).
 *
 * The SPD are Eric Haines' benchmark scenes for ray tracers (public domain,
 * now CC0: github.com/erich666/StandardProceduralDatabases).  This file
 * rebuilds, from the published procedural rules, the scenes those programs
 * write as NFF with true curved primitives (their default output).  The
 * entities are added in the order the programs print them, so primitive ids
 * follow the order of an SPD .nff file, and the arithmetic follows the same
 * operation order (row-vector 4x4 matrices, same constants) so the numbers
 * agree with the originals to rounding, for every size factor. */
#include "spd.h"

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
    {"balls", 4, 8, mprt__spd_balls},
    {"gears", 4, 69, mprt__spd_gears},
    {"mount", 6, 12, mprt__spd_mount},
    {"rings", 7, 135, mprt__spd_rings},
    {"tetra", 6, 12, mprt__spd_tetra},
    {"tree", 11, 23, mprt__spd_tree},
};

int mprt_scene_spd(mprt_scene *scene, const char *name, int size)
{
    size_t i;
    if (!scene) return MPRT_ERR_INVALID_ARG;
    if (mprt__scene_check_unshared(scene, "spd") != MPRT_OK) return MPRT_ERR_STATE;
    if (!name)
        return mprt__scene_fail(scene, MPRT_ERR_INVALID_ARG,
                                "spd: no scene name (expected balls, gears, mount, rings, tetra or tree)");
    for (i = 0; i < sizeof spd_table / sizeof spd_table[0]; i++) {
        const spd_entry *e = &spd_table[i];
        mprt__scene_saved saved;
        int st;
        if (strcmp(name, e->name) != 0) continue;
        if (size <= 0) size = e->def_size;
        if (size > e->max_size)
            return mprt__scene_fail(scene, MPRT_ERR_INVALID_ARG,
                                    "spd: size %d is too large for %s (allowed 1..%d, or <= 0 for the default %d)",
                                    size, e->name, e->max_size, e->def_size);
        /* On error (out of memory) the scene is left as it was */
        mprt__scene_mark(scene, &saved);
        st = e->gen(scene, size);
        if (st != MPRT_OK) mprt__scene_rollback(scene, &saved);
        return st;
    }
    return mprt__scene_fail(scene, MPRT_ERR_INVALID_ARG,
                            "spd: unknown scene '%.100s' (expected balls, gears, mount, rings, tetra or tree)",
                            name);
}
