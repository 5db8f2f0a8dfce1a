/* crc32.h: CRC-32 of a buffer (internal; mprt_crc32_copy is public). */
#ifndef MPRT_CRC32_H
#define MPRT_CRC32_H

#include "mprt.h"

#include <stddef.h>
#include <stdint.h>

/* mprt_crc32_copy by the portable loop alone (tests compare it with the folding copy). */
uint32_t mprt__crc32_copy_portable(void *dst, const void *src, size_t n, uint32_t crc);

/* 1 when mprt_crc32_copy folds with PCLMULQDQ (x86-64 that has it, MPRT_CRC_SIMD not "0"). */
int mprt__crc32_simd(void);

#endif
