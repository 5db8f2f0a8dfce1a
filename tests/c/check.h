/* check.h: a minimal C test harness.  Each test file defines test functions,
 * lists them in main() with RUN(name), and ends with CHECK_DONE(), which
 * prints "N passed, N failed" and returns nonzero on any failure. */
#ifndef MPRT_CHECK_H
#define MPRT_CHECK_H

#include <math.h>
#include <stdio.h>

static int check_failures_;
static int check_passed_;
static int check_failed_;
static const char *check_current_ = "";

#define CHECK(cond)                                                                   \
    do {                                                                              \
        if (!(cond)) {                                                                \
            check_failures_++;                                                        \
            fprintf(stderr, "%s:%d: %s: CHECK(%s) failed\n", __FILE__, __LINE__,      \
                    check_current_, #cond);                                           \
        }                                                                             \
    } while (0)

#define CHECK_MSG(cond, ...)                                                          \
    do {                                                                              \
        if (!(cond)) {                                                                \
            check_failures_++;                                                        \
            fprintf(stderr, "%s:%d: %s: CHECK(%s) failed: ", __FILE__, __LINE__,      \
                    check_current_, #cond);                                           \
            fprintf(stderr, __VA_ARGS__);                                             \
            fputc('\n', stderr);                                                      \
        }                                                                             \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                         \
    CHECK_MSG(fabs((double)(a) - (double)(b)) <= (tol), "%.17g vs %.17g (tol %g)",  \
              (double)(a), (double)(b), (double)(tol))

#define RUN(fn)                                                                       \
    do {                                                                              \
        int before_ = check_failures_;                                                \
        check_current_ = #fn;                                                         \
        fn();                                                                         \
        if (check_failures_ == before_) check_passed_++;                              \
        else check_failed_++;                                                         \
    } while (0)

#define CHECK_DONE()                                                                  \
    (printf("%s: %d passed, %d failed\n", __FILE__, check_passed_, check_failed_),    \
     check_failed_ != 0)

#endif
