/* nff.h: the NFF reader's lines, tokens, numbers and messages (internal;
 * nff_lex.c), used by the entity parsers in nff.c. */
#ifndef MPRT_NFF_H
#define MPRT_NFF_H

#include "mprt_internal.h"

#include <string.h>

#define NFF_MAXTOK 12  /* tokens kept per line; further ones are only counted */
#define NFF_NUMBUF 128 /* longest token accepted as a number */
#define NFF_UNKNOWN 8  /* unknown entities named in the note of a skipping read */

typedef struct {
    const char *s;
    size_t n;
} nff_token;

typedef struct {
    mprt_scene *scene;
    const char *name;
    const char *p, *end;     /* unread text */
    long line;               /* number of the line read last */
    nff_token tok[NFF_MAXTOK];
    long ntok;               /* tokens on that line (may exceed NFF_MAXTOK) */
    char point;              /* the C library's decimal point in this locale */
    double *verts, *norms;   /* polygon scratch, 3 doubles per vertex each */
    size_t capverts;         /* vertices the scratch arrays hold */
    unsigned flags;          /* MPRT_NFF_* */
    long over_one;           /* materials with Ks + T over 1 */
    long over_line;          /* the first one's line */
    double over_ks, over_t;  /* and its weights */
    int in_unknown;          /* the last entity was skipped: its number lines are skipped too */
    int nunknown;            /* distinct unknown entities skipped (those kept in unknown[]) */
    long unknown_more;       /* skipped entities beyond unknown[]'s names */
    struct {
        char name[40];       /* as mprt__nff_show quotes it */
        long count, first;   /* how many; the line of the first */
    } unknown[NFF_UNKNOWN];
} nff_reader;

/* The token is the string literal word. */
#define nff_is(t, word) ((t).n == sizeof(word) - 1 && memcmp((t).s, word, sizeof(word) - 1) == 0)

/* Read lines up to the next one with a token; 0 at the end of the text. */
int mprt__nff_next_entity_line(nff_reader *r);
/* The token is the string word. */
int mprt__nff_is_word(nff_token t, const char *word);
/* Quote a token for a message: at most 32 bytes, unprintable ones as \xNN. */
const char *mprt__nff_show(nff_token t, char *out, size_t cap);
/* Convert a token to an int; 0 if it is not a decimal integer within int. */
int mprt__nff_int(const nff_reader *r, nff_token t, int *out);

/* Record "NAME:LINE: message" as the scene's error; returns status. */
int mprt__nff_fail_status(nff_reader *r, int status, long line, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
#define nff_fail(r, line, ...) mprt__nff_fail_status((r), MPRT_ERR_PARSE, (line), __VA_ARGS__)
/* A scene API call refused an entity: prefix its message with the place.
 * Invalid values become MPRT_ERR_PARSE; other statuses pass through. */
int mprt__nff_api_fail(nff_reader *r, int status, long line);

/* Parse tokens first.. of the current line as exactly want numbers into v.
 * what completes the messages: "expected 4 numbers <what>, found 3".  On a
 * continuation line (first == 0) a leading word is shown instead of a count,
 * since it is most likely the next entity. */
int mprt__nff_numbers(nff_reader *r, int first, int want, double *v, const char *what);
/* The same without a message; 1 when they are numbers.  A fast path for
 * vertex lines. */
int mprt__nff_try_numbers(const nff_reader *r, int first, int want, double *v);

#endif
