/* dda.c: the bits the walk's inner loop reads (grid.h, plain). */
#include "grid.h"

#include <stdlib.h>

int mprt__dda_plain(mprt_grid *g)
{
    const long long nvox = g->voxels;
    const size_t words = (size_t)(nvox + 63) / 64;
    const unsigned below = g->jump_min - 1; /* plain: 1 <= empty <= jump_min - 1 */
    size_t w;
    g->plain = malloc((words ? words : 1) * sizeof *g->plain);
    if (!g->plain) return MPRT_ERR_OUT_OF_MEMORY;
    for (w = 0; w < words; w++) {
        const uint8_t *e = g->empty + 64 * w;
        int j, n = nvox - (long long)(64 * w) < 64 ? (int)(nvox - (long long)(64 * w)) : 64;
        uint64_t bits = 0;
        for (j = 0; j < n; j++) bits |= (uint64_t)((unsigned)e[j] - 1u < below) << j;
        g->plain[w] = bits;
    }
    return MPRT_OK;
}
