/* grid_reference.h: the grid built the plain way, voxel by voxel, kept as
 * the reference the library's build must match bit for bit
 * (test_grid_build.c; grid_reference.c holds it, linked into that test). */
#ifndef MPRT_TEST_GRID_REFERENCE_H
#define MPRT_TEST_GRID_REFERENCE_H

#include "grid.h"

/* mprt_grid_create_listing with the plain stages of grid_reference.c. */
int mprt__grid_create_reference(const mprt_scene *s, int nx, int ny, int nz, size_t max_bytes, int listing,
                                mprt_grid **out);

#endif
