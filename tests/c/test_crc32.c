/* test_crc32.c: mprt_crc32_copy is the CRC-32 of zip and PNG (the bitwise
 * definition), for every length and alignment around its 16- and 64-byte
 * steps, continued across calls, and copies exactly the bytes it reads;
 * the folding copy (where the processor has it) equals the portable loop. */
#include "check.h"
#include "crc32.h"
#include "mprt.h"

#include <stdlib.h>
#include <string.h>

enum { MAX = 1200, PAD = 16 };

/* The definition, a bit at a time. */
static uint32_t crc_bitwise(uint32_t crc, const unsigned char *p, size_t n)
{
    int k;
    crc = ~crc;
    while (n--) {
        crc ^= *p++;
        for (k = 0; k < 8; k++) crc = crc & 1 ? 0xedb88320u ^ (crc >> 1) : crc >> 1;
    }
    return ~crc;
}

static unsigned char src[MAX + PAD], dst[MAX + 2 * PAD];

static void fill(void)
{
    unsigned i;
    uint32_t x = 12345;
    for (i = 0; i < sizeof src; i++) {
        x = x * 1103515245u + 12345u;
        src[i] = (unsigned char)(x >> 24);
    }
}

static void test_known_values(void)
{
    CHECK(mprt_crc32_copy(NULL, "123456789", 9, 0) == 0xcbf43926u);   /* the check value of CRC-32 */
    CHECK(mprt_crc32_copy(NULL, "", 0, 0) == 0);
    CHECK(mprt_crc32_copy(NULL, "", 0, 0x1234u) == 0x1234u);
}

static void test_every_length_and_alignment(void)
{
    size_t n, off;
    fill();
    for (off = 0; off < PAD; off += 3) {
        for (n = 0; n <= MAX; n += n < 300 ? 1 : 37) {
            uint32_t want = crc_bitwise(0, src + off, n);
            memset(dst, 0xa5, sizeof dst);
            CHECK_MSG(mprt_crc32_copy(dst + PAD + off % 5, src + off, n, 0) == want, "n %zu off %zu", n, off);
            CHECK_MSG(memcmp(dst + PAD + off % 5, src + off, n) == 0, "copy n %zu off %zu", n, off);
            CHECK(dst[PAD + off % 5 - 1] == 0xa5 && dst[PAD + off % 5 + n] == 0xa5);   /* nothing beyond */
            CHECK_MSG(mprt_crc32_copy(NULL, src + off, n, 0) == want, "no copy: n %zu off %zu", n, off);
            CHECK_MSG(mprt__crc32_copy_portable(NULL, src + off, n, 0) == want, "portable: n %zu off %zu", n, off);
        }
    }
}

static void test_continued_across_calls(void)
{
    size_t cut;
    uint32_t want = crc_bitwise(0, src, MAX);
    fill();
    for (cut = 0; cut <= MAX; cut += 61) {
        uint32_t c = mprt_crc32_copy(NULL, src, cut, 0);
        CHECK_MSG(mprt_crc32_copy(NULL, src + cut, MAX - cut, c) == want, "cut %zu", cut);
        c = mprt__crc32_copy_portable(NULL, src, cut, 0);
        CHECK_MSG(mprt__crc32_copy_portable(NULL, src + cut, MAX - cut, c) == want, "portable cut %zu", cut);
    }
}

int main(void)
{
    RUN(test_known_values);
    RUN(test_every_length_and_alignment);
    RUN(test_continued_across_calls);
    printf("crc32: %s\n", mprt__crc32_simd() ? "folding (PCLMULQDQ)" : "portable loop only");
    return CHECK_DONE();
}
