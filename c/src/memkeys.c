/* memkeys.c: each visit's memory key for level 3 (python/mprt/fidelity/
 * memdata.py, visit_keys) and the references to each key (machine/memory.py,
 * DataLayout's counts), in one pass over the records where they lie (read
 * through memcpy: a memory-mapped member need not be aligned). */
#include <stdio.h>
#include <string.h>

#include "mprt_internal.h"

int mprt_visit_keys(const mprt_trace_visit *visits, size_t nvisits, const int64_t *prim_material, size_t nprims,
                    int32_t *keys, int64_t *voxel_refs, size_t nvoxels, int64_t *material_refs, size_t nmaterials,
                    char *errmsg, size_t errlen)
{
    size_t j;
    if (errmsg && errlen) errmsg[0] = '\0';
    if ((nvisits && (!visits || !keys)) || (nprims && !prim_material) || (nvoxels && !voxel_refs) ||
        (nmaterials && !material_refs)) {
        if (errmsg && errlen) snprintf(errmsg, errlen, "mprt_visit_keys: an array is missing");
        return MPRT_ERR_INVALID_ARG;
    }
    /* zeroed, written only where not zero already: an array the caller got zeroed (calloc, a
     * fine grid's 16 M voxels of which a small trace visits few) keeps its untouched pages */
    for (j = 0; j < nvoxels; j++)
        if (voxel_refs[j]) voxel_refs[j] = 0;
    for (j = 0; j < nmaterials; j++) material_refs[j] = 0;
    for (j = 0; j < nvisits; j++) {
        const mprt_trace_visit a = mprt__visit_at(visits, j);
        if (!mprt__visit_key(&a, prim_material, nprims, voxel_refs, nvoxels, material_refs, nmaterials, &keys[j]))
            break;
    }
    if (j < nvisits) {
        if (errmsg && errlen)
            snprintf(errmsg, errlen, "memory keys: visit %zu's voxel or material is outside the trace's, or does not "
                     "fit 32 bits", j);
        return MPRT_ERR_INVALID_ARG;
    }
    return MPRT_OK;
}
