/**
 * @file harness.h
 * @brief Minimal unit-test harness: CHECK macros count passed and failed checks; a
 *        failed check prints file, line and the expression (tests keep running).
 */
#ifndef FORTE_TEST_HARNESS_H
#define FORTE_TEST_HARNESS_H

#include <stdio.h>

extern unsigned harness_passed;
extern unsigned harness_failed;

#define CHECK(condition)                                                                   \
    do {                                                                                   \
        if (condition) {                                                                   \
            harness_passed++;                                                              \
        } else {                                                                           \
            harness_failed++;                                                              \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #condition);  \
        }                                                                                  \
    } while (0)

#define CHECK_EQ_INT(actual, expected)                                                     \
    do {                                                                                   \
        const long long check_a_ = (long long)(actual);                                    \
        const long long check_e_ = (long long)(expected);                                  \
        if (check_a_ == check_e_) {                                                        \
            harness_passed++;                                                              \
        } else {                                                                           \
            harness_failed++;                                                              \
            fprintf(stderr, "%s:%d: CHECK_EQ failed: %s = %lld, expected %s = %lld\n",     \
                    __FILE__, __LINE__, #actual, check_a_, #expected, check_e_);           \
        }                                                                                  \
    } while (0)

#define RUN_TEST(function)                                                                 \
    do {                                                                                   \
        const unsigned failed_before_ = harness_failed;                                    \
        function();                                                                        \
        printf("%-40s %s\n", #function, harness_failed == failed_before_ ? "ok" : "FAILED"); \
    } while (0)

#endif /* FORTE_TEST_HARNESS_H */
