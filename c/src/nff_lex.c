/* nff_lex.c: the NFF reader's lines, tokens and numbers, and its messages
 * "NAME:LINE: what was expected, found what was there" (the format rules are
 * described at the top of nff.c). */
#include "nff.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>

/* ---- Lines and tokens (the functions without a comment are described in nff.h) */

static int nff_space(char c) { return c == ' ' || c == '\t' || c == '\f' || c == '\v'; }

/* Read the next line into r->tok; 0 at the end of the text. */
static int nff_next_line(nff_reader *r)
{
    const char *p = r->p, *end = r->end;
    if (p >= end) return 0;
    r->line++;
    r->ntok = 0;
    while (p < end && *p != '\n' && *p != '\r') {
        const char *start;
        if (*p == '#') {
            while (p < end && *p != '\n' && *p != '\r') p++;
            break;
        }
        if (nff_space(*p)) {
            p++;
            continue;
        }
        start = p;
        while (p < end && !nff_space(*p) && *p != '\n' && *p != '\r' && *p != '#') p++;
        if (r->ntok < NFF_MAXTOK) {
            r->tok[r->ntok].s = start;
            r->tok[r->ntok].n = (size_t)(p - start);
        }
        r->ntok++;
    }
    if (p < end) {
        if (*p == '\r' && p + 1 < end && p[1] == '\n') p++;
        p++;
    }
    r->p = p;
    return 1;
}

int mprt__nff_next_entity_line(nff_reader *r)
{
    while (nff_next_line(r))
        if (r->ntok > 0) return 1;
    return 0;
}

int mprt__nff_is_word(nff_token t, const char *word)
{
    size_t n = strlen(word);
    return t.n == n && memcmp(t.s, word, n) == 0;
}

const char *mprt__nff_show(nff_token t, char *out, size_t cap)
{
    static const char hex[] = "0123456789abcdef";
    size_t i, k = 0;
    for (i = 0; i < t.n && i < 32 && k + 5 < cap; i++) {
        unsigned char c = (unsigned char)t.s[i];
        if (c >= 0x20 && c < 0x7f) {
            out[k++] = (char)c;
        } else {
            out[k++] = '\\';
            out[k++] = 'x';
            out[k++] = hex[c >> 4];
            out[k++] = hex[c & 15];
        }
    }
    if (i < t.n && k + 4 < cap) {
        memcpy(out + k, "...", 3);
        k += 3;
    }
    out[k] = '\0';
    return out;
}

/* ---- Numbers ------------------------------------------------------------ */

/* Copy a token into buf as a NUL-terminated string in the notation strtod
 * expects here ('.' becomes the locale's decimal point); 0 if it does not fit
 * or already holds that other decimal point. */
static int nff_cstring(const nff_reader *r, nff_token t, char *buf, size_t cap)
{
    size_t i;
    if (t.n == 0 || t.n >= cap) return 0;
    memcpy(buf, t.s, t.n);
    buf[t.n] = '\0';
    if (r->point != '.') {
        for (i = 0; i < t.n; i++) {
            if (buf[i] == r->point) return 0;
            if (buf[i] == '.') buf[i] = r->point;
        }
    }
    return 1;
}

#define NFF_NUMBER 0
#define NFF_GARBAGE 1
#define NFF_NONFINITE 2

/* Convert a token to a double: NFF_NUMBER, NFF_GARBAGE or NFF_NONFINITE. */
static int nff_number(const nff_reader *r, nff_token t, double *out)
{
    char buf[NFF_NUMBUF], *stop;
    double x;
    if (!nff_cstring(r, t, buf, sizeof buf)) return NFF_GARBAGE;
    x = strtod(buf, &stop);
    if (stop != buf + t.n) return NFF_GARBAGE;
    if (!isfinite(x)) return NFF_NONFINITE;
    *out = x;
    return NFF_NUMBER;
}

int mprt__nff_int(const nff_reader *r, nff_token t, int *out)
{
    char buf[NFF_NUMBUF], *stop;
    long x;
    if (!nff_cstring(r, t, buf, sizeof buf)) return 0;
    errno = 0;
    x = strtol(buf, &stop, 10);
    if (stop != buf + t.n || errno == ERANGE || x < INT_MIN || x > INT_MAX) return 0;
    *out = (int)x;
    return 1;
}

/* ---- Errors ------------------------------------------------------------- */

int mprt__nff_fail_status(nff_reader *r, int status, long line, const char *fmt, ...)
{
    char msg[MPRT__ERRMSG];
    va_list ap;
    va_start(ap, fmt);
    mprt__vformat(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return mprt__scene_fail(r->scene, status, "%s:%ld: %s", r->name, line, msg);
}

int mprt__nff_api_fail(nff_reader *r, int status, long line)
{
    char msg[MPRT__ERRMSG];
    memcpy(msg, r->scene->errmsg, sizeof msg);
    msg[sizeof msg - 1] = '\0';
    if (status == MPRT_ERR_INVALID_ARG) status = MPRT_ERR_PARSE;
    return mprt__nff_fail_status(r, status, line, "%s", msg);
}

int mprt__nff_numbers(nff_reader *r, int first, int want, double *v, const char *what)
{
    char shown[160];
    long have = r->ntok - first;
    int i, kind;
    if (have != want) {
        double dummy;
        if (first == 0 && nff_number(r, r->tok[0], &dummy) == NFF_GARBAGE)
            return nff_fail(r, r->line, "expected %d number%s %s, found '%s'", want,
                            want == 1 ? "" : "s", what, mprt__nff_show(r->tok[0], shown, sizeof shown));
        return nff_fail(r, r->line, "expected %d number%s %s, found %ld", want, want == 1 ? "" : "s",
                        what, have);
    }
    for (i = 0; i < want; i++) {
        nff_token t = r->tok[first + i];
        kind = nff_number(r, t, &v[i]);
        if (kind == NFF_GARBAGE)
            return nff_fail(r, r->line, "expected a number %s, found '%s'", what,
                            mprt__nff_show(t, shown, sizeof shown));
        if (kind == NFF_NONFINITE)
            return nff_fail(r, r->line, "expected a finite number %s, found '%s'", what,
                            mprt__nff_show(t, shown, sizeof shown));
    }
    return MPRT_OK;
}

int mprt__nff_try_numbers(const nff_reader *r, int first, int want, double *v)
{
    int i;
    if (r->ntok - first != want) return 0;
    for (i = 0; i < want; i++)
        if (nff_number(r, r->tok[first + i], &v[i]) != NFF_NUMBER) return 0;
    return 1;
}
