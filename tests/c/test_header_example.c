/* test_header_example.c: the usage example at the top of mprt.h, compiled
 * and run as it stands.  The Makefile extracts the indented block of the
 * header's "Usage" comment into header_example.inc, so the example cannot
 * drift from the API without this test failing to build.  It runs in a
 * temporary directory and must write a 256x256 PNG. */
#include "check.h"
#include "mprt.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The header's example, in a function of its own */
static void header_example(void)
{
#include "header_example.inc"
}

/* Big-endian 32-bit number at p. */
static unsigned long be32(const unsigned char *p)
{
    return (unsigned long)p[0] << 24 | (unsigned long)p[1] << 16 | (unsigned long)p[2] << 8 | (unsigned long)p[3];
}

static void test_the_header_example_writes_its_image(void)
{
    static const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    char dir[] = "/tmp/mprt-example-XXXXXX", cwd[4096];
    unsigned char head[24];
    FILE *f;
    CHECK(getcwd(cwd, sizeof cwd) != NULL);
    CHECK(mkdtemp(dir) != NULL && chdir(dir) == 0);
    header_example();
    f = fopen("balls.png", "rb");
    CHECK_MSG(f != NULL, "the example wrote no balls.png");
    if (f) {
        CHECK(fread(head, 1, sizeof head, f) == sizeof head);
        fclose(f);
        CHECK(memcmp(head, signature, sizeof signature) == 0);
        CHECK(memcmp(head + 12, "IHDR", 4) == 0);
        CHECK(be32(head + 16) == 256 && be32(head + 20) == 256);
        remove("balls.png");
    }
    CHECK(chdir(cwd) == 0);
    rmdir(dir);
}

int main(void)
{
    RUN(test_the_header_example_writes_its_image);
    return CHECK_DONE();
}
