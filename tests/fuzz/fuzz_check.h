/*
 * fuzz_check.h - how a harness reports a broken property: it names the
 * property on stderr and aborts, which both libFuzzer (a crash, with the
 * input saved) and the corpus replay (a failed ctest) see.
 */
#ifndef DKF_FUZZ_CHECK_H
#define DKF_FUZZ_CHECK_H

#include <stdio.h>
#include <stdlib.h>

#define FUZZ_REQUIRE(cond)                                                              \
    do {                                                                                \
        if (!(cond)) {                                                                  \
            fprintf(stderr, "%s:%d: property broken: %s\n", __FILE__, __LINE__, #cond); \
            abort();                                                                    \
        }                                                                               \
    } while (0)

#endif /* DKF_FUZZ_CHECK_H */
