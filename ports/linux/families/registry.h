/*
 * registry.h - the registry of the host's filter families (family.h says
 * what a family is): every family in --help order, the lookup by --filter
 * name, and the families' options as dkf-run and the network processes
 * parse them. A new family is one row in registry.c (and its own file):
 * docs/layout.md, "Adding a filter family on the host".
 */
#ifndef DKF_HOST_REGISTRY_H
#define DKF_HOST_REGISTRY_H

#include <stddef.h>

#include "family.h"

/* The registry: every family, in --help order; NULL-terminated. */
extern const dkf_family_t *const dkf_registry[];

/* The filter called name, or NULL. */
const dkf_filter_t *dkf_registry_find(const char *name);

/* The names of the filters that take option --opt (opt != NULL) / read
 * layout (opt NULL), joined as "a", "a and b" or "a, b, c" into out (cap
 * bytes). Returns out. */
const char *dkf_registry_names(char *out, size_t cap, const char *opt, int layout);

/* Option --name of family fam (fam NULL: of the first family that has
 * one), or NULL. */
const dkf_run_opt_t *dkf_registry_opt(const dkf_family_t *fam, const char *name);

/* "--d00/--Pd00-scale": option --name and those sharing its bit in the
 * family that has it, into out (cap bytes). Returns out. */
const char *dkf_registry_opt_label(char *out, size_t cap, const char *name);

/* Filter f's family's options at their defaults, in a new area (free it);
 * NULL if the family takes none (or out of memory: *oom = 1). */
void *dkf_registry_opts_new(const dkf_filter_t *f, int *oom);

/* --name arg (NULL for a flag) into area (from dkf_registry_opts_new(f)).
 * DKF_EXIT_OK, or DKF_EXIT_USAGE with "--name ARG: problem" in err (a bad
 * value, or not an option of f's family). */
int dkf_registry_opt_set(const dkf_filter_t *f, void *area, const char *name, const char *arg,
                         char *err, size_t errlen);

/* 1 if filter f takes option --name. */
int dkf_registry_takes(const dkf_filter_t *f, const char *name);

#endif /* DKF_HOST_REGISTRY_H */
