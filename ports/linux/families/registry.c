/*
 * registry.c - the registry of the host's filter families (registry.h).
 * A new family is one row here (and its own file).
 */
#include "registry.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "util.h"

/* Defined by each family's own file. */
extern const dkf_family_t dkf_family_kf;    /* est_kf.c: dkf/kf.h */
extern const dkf_family_t dkf_family_info;  /* est_info.c: dkf/info.h */
extern const dkf_family_t dkf_family_dkf;   /* est_diffkf.c: dkf/diffkf.h, diffkf_fusion.h */
extern const dkf_family_t dkf_family_askf;  /* est_askf.c: dkf/askf.h */
extern const dkf_family_t dkf_family_otskf; /* est_otskf.c: dkf/otskf.h */
extern const dkf_family_t dkf_family_uif;   /* uif_run.c: dkf/uif.h (seed 004) */
extern const dkf_family_t dkf_family_tw;    /* tw_run.c: dkf/tw.h (seed 003) */
extern const dkf_family_t dkf_family_nerts; /* nerts_run.c: dkf/nerts.h (seed 001) */
extern const dkf_family_t dkf_family_dfnerts; /* dfnerts_run.c: dkf/dfnerts.h (seed 001) */
extern const dkf_family_t dkf_family_wfusion; /* wfusion_run.c: dkf/wfusion.h (seed 002) */

const dkf_family_t *const dkf_registry[] = {
    &dkf_family_kf, &dkf_family_info, &dkf_family_dkf, &dkf_family_askf, &dkf_family_otskf,
    &dkf_family_uif, &dkf_family_tw, &dkf_family_nerts, &dkf_family_dfnerts,
    &dkf_family_wfusion, NULL,
};

const dkf_filter_t *dkf_registry_find(const char *name)
{
    size_t i, j;
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; j < dkf_registry[i]->nfilters; ++j)
            if (strcmp(dkf_registry[i]->filters[j].name, name) == 0)
                return &dkf_registry[i]->filters[j];
    return NULL;
}

const dkf_run_opt_t *dkf_registry_opt(const dkf_family_t *fam, const char *name)
{
    size_t i, j;
    for (i = 0; dkf_registry[i] != NULL; ++i) {
        const dkf_run_optset_t *set = dkf_registry[i]->options;
        if ((fam != NULL && dkf_registry[i] != fam) || set == NULL) continue;
        for (j = 0; j < set->nopts; ++j)
            if (strcmp(set->opts[j].name, name) == 0) return &set->opts[j];
    }
    return NULL;
}

int dkf_registry_takes(const dkf_filter_t *f, const char *name)
{
    const dkf_run_opt_t *opt = dkf_registry_opt(f->family, name);
    return opt != NULL && (f->options & opt->bit) != 0;
}

const char *dkf_registry_opt_label(char *out, size_t cap, const char *name)
{
    size_t i, j, len = 0;
    out[0] = '\0';
    for (i = 0; dkf_registry[i] != NULL; ++i) {
        const dkf_run_optset_t *set = dkf_registry[i]->options;
        const dkf_run_opt_t *opt = dkf_registry_opt(dkf_registry[i], name);
        if (opt == NULL) continue;
        for (j = 0; j < set->nopts; ++j)
            if (set->opts[j].bit == opt->bit && len < cap)
                len += (size_t)snprintf(out + len, cap - len, "%s--%s", len == 0 ? "" : "/",
                                        set->opts[j].name);
        break;
    }
    return out;
}

void *dkf_registry_opts_new(const dkf_filter_t *f, int *oom)
{
    const dkf_run_optset_t *set = f->family->options;
    void *area;
    *oom = 0;
    if (set == NULL) return NULL;
    if ((area = calloc(1, set->size)) == NULL) {
        *oom = 1;
        return NULL;
    }
    set->init(area);
    return area;
}

int dkf_registry_opt_set(const dkf_filter_t *f, void *area, const char *name, const char *arg,
                         char *err, size_t errlen)
{
    const dkf_run_opt_t *opt = dkf_registry_opt(f->family, name);
    if (opt == NULL || area == NULL)
        return dkf_failf(err, errlen, DKF_EXIT_USAGE, "--%s: not an option of filter %s", name,
                         f->name);
    return f->family->options->parse(area, opt, arg, err, errlen);
}

/* 1 if filter f takes option --opt (opt != NULL) or reads layout (>= 0). */
static int selected(const dkf_filter_t *f, const char *opt, int layout)
{
    if (opt != NULL) return dkf_registry_takes(f, opt);
    return (f->family->layouts & (1u << layout)) != 0;
}

const char *dkf_registry_names(char *out, size_t cap, const char *opt, int layout)
{
    size_t i, j, n = 0, total = 0, len = 0;
    out[0] = '\0';
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; j < dkf_registry[i]->nfilters; ++j)
            total += (size_t)selected(&dkf_registry[i]->filters[j], opt, layout);
    for (i = 0; dkf_registry[i] != NULL; ++i)
        for (j = 0; j < dkf_registry[i]->nfilters; ++j) {
            const dkf_filter_t *f = &dkf_registry[i]->filters[j];
            const char *sep = n == 0 ? "" : total == 2 ? " and " : ", ";
            if (!selected(f, opt, layout)) continue;
            if (len < cap) len += (size_t)snprintf(out + len, cap - len, "%s%s", sep, f->name);
            ++n;
        }
    return out;
}
