/* dda.c: the bits the walk's inner loop reads (grid.h, plain). */
#include "grid.h"

#include <stdlib.h>

int mprt__dda_plain(mprt_grid *g)
{
    long long v, nvox = g->voxels;
    size_t words = (size_t)(nvox + 63) / 64;
    g->plain = calloc(words ? words : 1, sizeof *g->plain);
    if (!g->plain) return MPRT_ERR_OUT_OF_MEMORY;
    for (v = 0; v < nvox; v++) {
        unsigned e = g->empty[v];
        if (e != 0 && e < g->jump_min) g->plain[v >> 6] |= (uint64_t)1 << (v & 63);
    }
    return MPRT_OK;
}
