/*
 * registry.c - the registry of the host's filter families (registry.h).
 * A new family is one row here (and its own file).
 */
#include "registry.h"

#include <string.h>

/* Defined by each family's own file. */
extern const dkf_family_t dkf_family_kf;    /* est_kf.c: dkf/kf.h */
extern const dkf_family_t dkf_family_info;  /* est_info.c: dkf/info.h */
extern const dkf_family_t dkf_family_dkf;   /* est_diffkf.c: dkf/diffkf.h, diffkf_fusion.h */
extern const dkf_family_t dkf_family_askf;  /* est_askf.c: dkf/askf.h */
extern const dkf_family_t dkf_family_otskf; /* est_otskf.c: dkf/otskf.h */
extern const dkf_family_t dkf_family_uif;   /* uif_run.c: dkf/uif.h (seed 004) */
extern const dkf_family_t dkf_family_tw;    /* tw_run.c: dkf/tw.h (seed 003) */
extern const dkf_family_t dkf_family_nerts; /* est_nerts.c: dkf/nerts.h (seed 001) */
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

/* 1 if filter f takes option bit opt (opt != 0) or reads layout (>= 0). */
static int selected(const dkf_filter_t *f, unsigned opt, int layout)
{
    if (opt != 0) return (f->options & opt) != 0;
    return (f->family->layouts & (1u << layout)) != 0;
}

const char *dkf_registry_names(char *out, size_t cap, unsigned opt, int layout)
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
