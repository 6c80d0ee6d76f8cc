/*
 * model.c - the network processes' scenario check and model id (model.h).
 */
#include "model.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "codec.h"
#include "registry.h"
#include "util.h"

/* The state and every sensor's measurement fit a message (DKF_NET_MAX_VEC). */
static int vectors_fit(const dkf_scenario_t *s, char *err, size_t errlen)
{
    size_t i;
    if (s->n > DKF_NET_MAX_VEC) {
        snprintf(err, errlen, "%s: a state of n = %zu: network messages carry at most %d",
                 s->file, s->n, DKF_NET_MAX_VEC);
        return -1;
    }
    for (i = 0; i < s->nsensors; ++i)
        if (s->sensors[i].m > DKF_NET_MAX_VEC) {
            snprintf(err, errlen, "%s: sensor %zu: m = %zu: network messages carry at most %d",
                     s->file, i, s->sensors[i].m, DKF_NET_MAX_VEC);
            return -1;
        }
    return 0;
}

int dkf_net_check_scenario(const dkf_scenario_t *s, char *err, size_t errlen)
{
    const dkf_filter_t *f = dkf_registry_find("dkf");
    dkf_run_opts_t o;
    size_t i, ms = 0, ps = 0;
    if (s->layout == DKF_SCN_LAYOUT_WFCASES) {
        /* seed 002's weighted fusion: what `dkf-run --filter fusion_matrix`
         * checks (the wfusion family), and the node count of the messages */
        f = dkf_registry_find("fusion_matrix");
        memset(&o, 0, sizeof o);
        if (f == NULL || f->family->check(f, &o, s, err, errlen) != DKF_EXIT_OK) return -1;
        if (s->nsensors > DKF_NET_MAX_NODES) {
            snprintf(err, errlen, "%s: %zu sensors, at most %d", s->file, s->nsensors,
                     DKF_NET_MAX_NODES);
            return -1;
        }
        return vectors_fit(s, err, errlen);
    }
    /* what the Difference KF needs of the file: the registry's check */
    memset(&o, 0, sizeof o);
    if (f->family->check(f, &o, s, err, errlen) != DKF_EXIT_OK) return -1;
    if (s->nsensors > DKF_NET_MAX_NODES) {
        snprintf(err, errlen, "%s: model.sensors: %zu sensors, at most %d", s->file, s->nsensors,
                 DKF_NET_MAX_NODES);
        return -1;
    }
    for (i = 0; i < s->nsensors; ++i) {
        ms += s->sensors[i].m;
        ps += dkf_scn_sensor_model(s, i, "D")->cols;
    }
    if (ms > DKF_MAX_DIM || ps > DKF_MAX_DIM || s->n > DKF_MAX_DIM) {
        snprintf(err, errlen, "%s: model.sensors: stacked dimensions (sum m_i = %zu, sum p_i = "
                 "%zu, n = %zu) exceed DKF_MAX_DIM = %d", s->file, ms, ps, s->n, DKF_MAX_DIM);
        return -1;
    }
    return vectors_fit(s, err, errlen);
}

/* ---- model id ---------------------------------------------------------------- */

/* Shape, number of entries and every value of a scenario matrix (or a
 * marker for an absent one). */
static uint64_t fnv_mat(uint64_t h, const dkf_scn_mat_t *m)
{
    if (m == NULL) return dkf_fnv1a_u64(h, 0xffffffffffffffffull);
    h = dkf_fnv1a_u64(dkf_fnv1a_u64(dkf_fnv1a_u64(h, m->rows), m->cols), m->count);
    return dkf_fnv1a_doubles(h, m->data, (m->count ? m->count : 1) * m->rows * m->cols);
}

int64_t dkf_net_model_id(const dkf_scenario_t *s)
{
    static const char *const sensor_keys[] = {"H", "D", "R", "B", "Rd"};
    uint64_t h = DKF_FNV1A_OFFSET;
    size_t i, j;
    h = dkf_fnv1a_u64(dkf_fnv1a_u64(dkf_fnv1a_u64(h, s->n), s->nsensors), s->steps);
    if (s->layout == DKF_SCN_LAYOUT_WFCASES) {
        /* weighted fusion: a tag, F, Q, Hs, every sensor's H, R, x00, P00 */
        h = dkf_fnv1a_u64(h, 0x57465553ull); /* "WFUS" */
        h = fnv_mat(h, dkf_scn_model(s, "F"));
        h = fnv_mat(h, dkf_scn_model(s, "Q"));
        h = fnv_mat(h, dkf_scn_model(s, "Hs"));
        for (i = 0; i < s->nsensors; ++i) {
            h = fnv_mat(h, dkf_scn_sensor_model(s, i, "H"));
            h = fnv_mat(h, dkf_scn_sensor_model(s, i, "R"));
        }
        h = fnv_mat(h, dkf_scn_init(s, "x00"));
        h = fnv_mat(h, dkf_scn_init(s, "P00"));
        return (int64_t)h;
    }
    h = fnv_mat(h, dkf_scn_model(s, "F"));
    h = fnv_mat(h, dkf_scn_model(s, "Q"));
    for (i = 0; i < s->nsensors; ++i) {
        for (j = 0; j < sizeof sensor_keys / sizeof sensor_keys[0]; ++j)
            h = fnv_mat(h, dkf_scn_sensor_model(s, i, sensor_keys[j]));
        h = dkf_fnv1a_doubles(h, dkf_scn_P00_local(s, i), s->n * s->n);
    }
    h = fnv_mat(h, dkf_scn_init(s, "x00"));
    h = dkf_fnv1a_doubles(h, dkf_scn_P00_central(s), s->n * s->n);
    return (int64_t)h;
}
