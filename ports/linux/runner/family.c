/*
 * family.c - what every family's operations share (family.h).
 */
#include "family.h"

#include <stdlib.h>

void *dkf_runner_calloc(size_t size, const dkf_scenario_t *s, char *err, size_t errlen, int *rc)
{
    void *r = calloc(1, size);
    if (r == NULL) *rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", s->file);
    return r;
}
