/* png.c: write an RGB image as an 8-bit PNG.  The image data goes into
 * uncompressed ("stored") deflate blocks, so no compression library is
 * needed; images are a few hundred kilobytes, which is fine for a tool. */
#include "mprt_internal.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

static uint32_t crc_table_entry(uint32_t n)
{
    int k;
    for (k = 0; k < 8; k++) n = (n & 1) ? 0xedb88320u ^ (n >> 1) : n >> 1;
    return n;
}

static uint32_t crc_update(uint32_t crc, const unsigned char *p, size_t n, const uint32_t *table)
{
    size_t i;
    for (i = 0; i < n; i++) crc = table[(crc ^ p[i]) & 0xff] ^ (crc >> 8);
    return crc;
}

static void put32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* One chunk: length, type, data, CRC over type and data. */
static int chunk(FILE *f, const char *type, const unsigned char *data, size_t n, const uint32_t *table)
{
    unsigned char hdr[8], tail[4];
    uint32_t crc;
    put32(hdr, (uint32_t)n);
    hdr[4] = (unsigned char)type[0];
    hdr[5] = (unsigned char)type[1];
    hdr[6] = (unsigned char)type[2];
    hdr[7] = (unsigned char)type[3];
    crc = crc_update(0xffffffffu, hdr + 4, 4, table);
    crc = crc_update(crc, data, n, table) ^ 0xffffffffu;
    put32(tail, crc);
    return fwrite(hdr, 1, 8, f) != 8 || (n && fwrite(data, 1, n, f) != n) || fwrite(tail, 1, 4, f) != 4;
}

int mprt_image_write_png(const char *path, int width, int height, const float *rgb)
{
    static const unsigned char sig[8] = {137, 80, 78, 71, 13, 10, 26, 10};
    uint32_t table[256], a = 1, b = 0;
    size_t row = (size_t)width * 3 + 1, raw, nblocks, zlen, i, pos = 0;
    unsigned char ihdr[13], *z;
    FILE *f;
    int err;
    if (!path || !rgb || width < 1 || height < 1 || width > 65536 || height > 65536) return MPRT_ERR_INVALID_ARG;
    for (i = 0; i < 256; i++) table[i] = crc_table_entry((uint32_t)i);
    raw = row * (size_t)height;
    nblocks = (raw + 65534) / 65535;
    zlen = 2 + raw + 5 * nblocks + 4;
    z = malloc(zlen);
    if (!z) return MPRT_ERR_OUT_OF_MEMORY;
    /* zlib header: deflate, 32K window, no dictionary */
    z[pos++] = 0x78;
    z[pos++] = 0x01;
    {
        size_t left = raw, done = 0;
        while (left > 0) {
            size_t n = left > 65535 ? 65535 : left;
            z[pos++] = (unsigned char)(left == n);
            z[pos++] = (unsigned char)(n & 0xff);
            z[pos++] = (unsigned char)(n >> 8);
            z[pos++] = (unsigned char)(~n & 0xff);
            z[pos++] = (unsigned char)((~n >> 8) & 0xff);
            /* Scanline bytes: filter type 0, then R G B per pixel */
            for (i = 0; i < n; i++, done++) {
                size_t yy = done / row, xx = done % row;
                unsigned char v = 0;
                if (xx > 0) {
                    double c = rgb[yy * (size_t)width * 3 + (xx - 1)];
                    c = c != c ? 0 : c < 0 ? 0 : c > 1 ? 1 : c;
                    v = (unsigned char)(c * 255 + 0.5);
                }
                z[pos++] = v;
                a = (a + v) % 65521;
                b = (b + a) % 65521;
            }
            left -= n;
        }
    }
    put32(z + pos, (b << 16) | a);
    pos += 4;
    put32(ihdr, (uint32_t)width);
    put32(ihdr + 4, (uint32_t)height);
    ihdr[8] = 8;  /* bit depth */
    ihdr[9] = 2;  /* colour type: RGB */
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    f = fopen(path, "wb");
    if (!f) {
        free(z);
        return MPRT_ERR_IO;
    }
    err = fwrite(sig, 1, 8, f) != 8;
    err |= chunk(f, "IHDR", ihdr, 13, table);
    err |= chunk(f, "IDAT", z, pos, table);
    err |= chunk(f, "IEND", NULL, 0, table);
    err |= fclose(f) != 0;
    free(z);
    return err ? MPRT_ERR_IO : MPRT_OK;
}
