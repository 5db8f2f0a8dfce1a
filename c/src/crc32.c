/* crc32.c: CRC-32 (the polynomial of zip, gzip and PNG, as zlib's crc32)
 * of a buffer, copying it on the way when asked (mprt_crc32_copy).
 *
 * Where the compiler and processor allow (x86-64 with PCLMULQDQ and
 * SSE4.1, chosen at run time), 64 bytes at a time are folded with
 * carry-less multiplications (Gopal et al., "Fast CRC Computation for
 * Generic Polynomials Using PCLMULQDQ Instruction", Intel, 2009: four
 * 128-bit lanes folded in parallel, then into one, then Barrett-reduced),
 * each 16-byte load stored to the copy as it is read.  Elsewhere, and for
 * the bytes before and after the folded run, a portable C99 loop reads
 * eight bytes a step through eight tables ("slicing by 8").  Both give
 * zlib's crc32 exactly (tests/c/test_crc32.c, tests/test_trace_write.py). */
#include "crc32.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#if defined(__GNUC__) && defined(__x86_64__)
#define MPRT__CRC_HAVE_CLMUL 1
#include <immintrin.h>
#endif

/* ---- The portable loop --------------------------------------------------------- */

static uint32_t table[8][256];          /* table[k][b]: byte b followed by k zero bytes */

static void make_table(void)
{
    uint32_t n, c;
    int k;
    for (n = 0; n < 256; n++) {
        c = n;
        for (k = 0; k < 8; k++) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
        table[0][n] = c;
    }
    for (n = 0; n < 256; n++) {
        c = table[0][n];
        for (k = 1; k < 8; k++) {
            c = table[0][c & 0xff] ^ (c >> 8);
            table[k][n] = c;
        }
    }
}

/* The running (inverted) register over n bytes of p, copied to dst unless NULL. */
static uint32_t crc_portable(uint32_t c, unsigned char *dst, const unsigned char *p, size_t n)
{
    if (dst) memcpy(dst, p, n);
    while (n >= 8) {
        uint32_t lo = c ^ ((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
        uint32_t hi = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 | (uint32_t)p[7] << 24;
        c = table[7][lo & 0xff] ^ table[6][(lo >> 8) & 0xff] ^ table[5][(lo >> 16) & 0xff] ^ table[4][lo >> 24] ^
            table[3][hi & 0xff] ^ table[2][(hi >> 8) & 0xff] ^ table[1][(hi >> 16) & 0xff] ^ table[0][hi >> 24];
        p += 8;
        n -= 8;
    }
    while (n--) c = table[0][(c ^ *p++) & 0xff] ^ (c >> 8);
    return c;
}


/* ---- The folding copy ---------------------------------------------------------- */

#ifdef MPRT__CRC_HAVE_CLMUL
#define TARGET_CLMUL __attribute__((target("pclmul,sse4.1")))

/* 64 bytes at p into four registers, and copied to dst when there is one; the dst after them. */
TARGET_CLMUL static inline unsigned char *load64(const unsigned char *p, unsigned char *dst, __m128i *a, __m128i *b,
                                                 __m128i *c, __m128i *d)
{
    *a = _mm_loadu_si128((const __m128i *)(const void *)(p + 0x00));
    *b = _mm_loadu_si128((const __m128i *)(const void *)(p + 0x10));
    *c = _mm_loadu_si128((const __m128i *)(const void *)(p + 0x20));
    *d = _mm_loadu_si128((const __m128i *)(const void *)(p + 0x30));
    if (!dst) return NULL;
    _mm_storeu_si128((__m128i *)(void *)(dst + 0x00), *a);
    _mm_storeu_si128((__m128i *)(void *)(dst + 0x10), *b);
    _mm_storeu_si128((__m128i *)(void *)(dst + 0x20), *c);
    _mm_storeu_si128((__m128i *)(void *)(dst + 0x30), *d);
    return dst + 64;
}

/* The register c over a whole number of 16-byte blocks (n >= 64), copied to
 * dst unless NULL. Constants: x^(4*128+32) and x^(4*128-32) mod P (folding
 * four lanes), x^(128+32) and x^(128-32) (one lane), x^64 (128 to 64 bits),
 * then P' and P for the Barrett reduction; all bit-reflected. */
TARGET_CLMUL static uint32_t crc_clmul(uint32_t c, unsigned char *dst, const unsigned char *p, size_t n)
{
    const __m128i k1k2 = _mm_set_epi64x(0x01c6e41596LL, 0x0154442bd4LL);
    const __m128i k3k4 = _mm_set_epi64x(0x00ccaa009eLL, 0x01751997d0LL);
    const __m128i k5k0 = _mm_set_epi64x(0, 0x0163cd6124LL);
    const __m128i poly = _mm_set_epi64x(0x01f7011641LL, 0x01db710641LL);
    const __m128i mask32 = _mm_setr_epi32(-1, 0, -1, 0);
    __m128i x1, x2, x3, x4, x5, x6, x7, x8, y5, y6, y7, y8;

    dst = load64(p, dst, &x1, &x2, &x3, &x4);
    x1 = _mm_xor_si128(x1, _mm_cvtsi32_si128((int)c));
    p += 64;
    n -= 64;
    while (n >= 64) {
        x5 = _mm_clmulepi64_si128(x1, k1k2, 0x00);
        x6 = _mm_clmulepi64_si128(x2, k1k2, 0x00);
        x7 = _mm_clmulepi64_si128(x3, k1k2, 0x00);
        x8 = _mm_clmulepi64_si128(x4, k1k2, 0x00);
        x1 = _mm_clmulepi64_si128(x1, k1k2, 0x11);
        x2 = _mm_clmulepi64_si128(x2, k1k2, 0x11);
        x3 = _mm_clmulepi64_si128(x3, k1k2, 0x11);
        x4 = _mm_clmulepi64_si128(x4, k1k2, 0x11);
        dst = load64(p, dst, &y5, &y6, &y7, &y8);
        x1 = _mm_xor_si128(_mm_xor_si128(x1, x5), y5);
        x2 = _mm_xor_si128(_mm_xor_si128(x2, x6), y6);
        x3 = _mm_xor_si128(_mm_xor_si128(x3, x7), y7);
        x4 = _mm_xor_si128(_mm_xor_si128(x4, x8), y8);
        p += 64;
        n -= 64;
    }
    /* four lanes into one */
    x5 = _mm_clmulepi64_si128(x1, k3k4, 0x00);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x11), x2), x5);
    x5 = _mm_clmulepi64_si128(x1, k3k4, 0x00);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x11), x3), x5);
    x5 = _mm_clmulepi64_si128(x1, k3k4, 0x00);
    x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x11), x4), x5);
    while (n >= 16) {
        x2 = _mm_loadu_si128((const __m128i *)(const void *)p);
        if (dst) {
            _mm_storeu_si128((__m128i *)(void *)dst, x2);
            dst += 16;
        }
        x5 = _mm_clmulepi64_si128(x1, k3k4, 0x00);
        x1 = _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x1, k3k4, 0x11), x2), x5);
        p += 16;
        n -= 16;
    }
    /* 128 bits to 64 */
    x2 = _mm_clmulepi64_si128(x1, k3k4, 0x10);
    x1 = _mm_xor_si128(_mm_srli_si128(x1, 8), x2);
    x2 = _mm_srli_si128(x1, 4);
    x1 = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, mask32), k5k0, 0x00), x2);
    /* Barrett reduction to 32 bits */
    x2 = _mm_clmulepi64_si128(_mm_and_si128(x1, mask32), poly, 0x10);
    x2 = _mm_clmulepi64_si128(_mm_and_si128(x2, mask32), poly, 0x00);
    x1 = _mm_xor_si128(x1, x2);
    return (uint32_t)_mm_extract_epi32(x1, 1);
}

static int clmul_wanted(void)
{
    const char *s = getenv("MPRT_CRC_SIMD");   /* "0": the portable loop (tests compare the two) */
    __builtin_cpu_init();
    return !(s && strcmp(s, "0") == 0) && __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("sse4.1");
}
#endif

static int use_clmul;
static pthread_once_t choice_once = PTHREAD_ONCE_INIT;

static void choose(void)
{
    make_table();
#ifdef MPRT__CRC_HAVE_CLMUL
    use_clmul = clmul_wanted();
#endif
}

uint32_t mprt__crc32_copy_portable(void *dst, const void *src, size_t n, uint32_t crc)
{
    pthread_once(&choice_once, choose);
    return ~crc_portable(~crc, dst, src, n);
}

int mprt__crc32_simd(void)
{
    pthread_once(&choice_once, choose);
    return use_clmul;
}

uint32_t mprt_crc32_copy(void *dst, const void *src, size_t n, uint32_t crc)
{
    unsigned char *d = dst;
    const unsigned char *p = src;
    uint32_t c = ~crc;
    pthread_once(&choice_once, choose);
    if (n == 0) return crc;
#ifdef MPRT__CRC_HAVE_CLMUL
    if (use_clmul && n >= 64) {
        size_t run = n & ~(size_t)15;
        c = crc_clmul(c, d, p, run);
        p += run;
        if (d) d += run;
        n -= run;
    }
#endif
    return ~crc_portable(c, d, p, n);
}
