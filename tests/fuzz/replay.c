/* replay.c: run the fuzz target (fuzz_nff.c) on saved inputs, without
 * libFuzzer: every file named on the command line, and every file in a
 * directory named there.  The normal test suite builds it with gcc and the
 * sanitizers and replays tests/fuzz/corpus and tests/fuzz/crashes (make
 * fuzz-replay); a broken property aborts with a message. */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Run the target on one file; returns 0, or 1 if it could not be read. */
static int replay_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    uint8_t *buf = NULL;
    size_t len = 0, cap = 0, got;
    if (!f) {
        fprintf(stderr, "replay: cannot open %s\n", path);
        return 1;
    }
    do {
        if (cap - len < 4096) {
            cap = cap ? 2 * cap : 1 << 16;
            buf = realloc(buf, cap);
            if (!buf) abort();
        }
        got = fread(buf + len, 1, cap - len, f);
        len += got;
    } while (got > 0);
    fclose(f);
    LLVMFuzzerTestOneInput(buf, len);
    free(buf);
    return 0;
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

int main(int argc, char **argv)
{
    int i, errors = 0;
    long files = 0;
    for (i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) == 0 && S_ISDIR(st.st_mode)) {
            /* the directory's files in name order, so a failure repeats the same way */
            DIR *d = opendir(argv[i]);
            struct dirent *e;
            char **names = NULL;
            size_t n = 0, k;
            if (!d) {
                fprintf(stderr, "replay: cannot open directory %s\n", argv[i]);
                errors++;
                continue;
            }
            while ((e = readdir(d)) != NULL) {
                size_t len = strlen(argv[i]) + strlen(e->d_name) + 2;
                if (e->d_name[0] == '.') continue;
                names = realloc(names, (n + 1) * sizeof *names);
                if (!names || !(names[n] = malloc(len))) abort();
                snprintf(names[n++], len, "%s/%s", argv[i], e->d_name);
            }
            closedir(d);
            if (n) qsort(names, n, sizeof *names, by_name);
            for (k = 0; k < n; k++) {
                errors += replay_file(names[k]);
                files++;
                free(names[k]);
            }
            free(names);
        } else {
            errors += replay_file(argv[i]);
            files++;
        }
    }
    printf("fuzz replay: %ld inputs, %d unreadable\n", files, errors);
    return errors != 0;
}
