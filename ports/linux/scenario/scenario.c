/*
 * scenario.c - the scenario reader's entry points (scenario.h): parses the
 * document, hands it to the reader of its layout (scn_canonical.c,
 * scn_cases.c, scn_steps.c), and the accessors of the normalised
 * dkf_scenario_t. The reader's toolkit and file map: scn_parse.h.
 */
#include "scenario.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "nlm.h"
#include "scn_parse.h"

/* ---- runs ------------------------------------------------------------------- */

int dkf_scn_alloc_runs(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t nruns)
{
    size_t r;
    if ((s->runs = dkf_scn_calloc(c, nruns, sizeof *s->runs)) == NULL) return -1;
    s->nruns = nruns;
    for (r = 0; r < nruns; ++r)
        if ((s->runs[r].y = dkf_scn_calloc(c, s->nsensors, sizeof *s->runs[r].y)) == NULL)
            return -1;
    return 0;
}

/* Hands the sensors' freshly parsed y series to run r; the sensors keep
 * viewing them. */
void dkf_scn_adopt_y(dkf_scenario_t *s, size_t r)
{
    size_t i;
    for (i = 0; i < s->nsensors; ++i) {
        dkf_scn_sensor_t *se = &s->sensors[i];
        s->runs[r].y[i].n = se->ny;
        s->runs[r].y[i].k = se->yk;
        s->runs[r].y[i].v = se->y;
        se->borrowed = 1;
    }
}

void dkf_scn_adopt_truth(dkf_scenario_t *s, size_t r)
{
    s->runs[r].ntruth = s->ntruth;
    s->runs[r].truth_k = s->truth_k;
    s->runs[r].truth_x = s->truth_x;
    s->truth_borrowed = 1;
}

static int parse_truth(dkf_scn_ctx_t *c, dkf_scenario_t *s, const json_t *tj, const char *path)
{
    if (tj == NULL || !json_is_object(tj) || json_object_get(tj, "x") == NULL) return 0;
    return dkf_scn_parse_series(c, tj, path, "x", s->n, &s->ntruth, &s->truth_k, &s->truth_x);
}

int dkf_scn_parse_run_truth(dkf_scn_ctx_t *c, dkf_scenario_t *s, size_t r, const json_t *tj,
                            const char *path)
{
    s->ntruth = 0;
    s->truth_k = NULL;
    s->truth_x = NULL;
    s->truth_borrowed = 0;
    if (parse_truth(c, s, tj, path) != 0) return -1;
    dkf_scn_adopt_truth(s, r);
    return 0;
}

/* ---- entry points ------------------------------------------------------------ */

/* The layout whose letters root's matrices have (before it is read). */
static dkf_scn_layout_t letters_layout(const json_t *root)
{
    if (json_object_get(root, "cases") != NULL) return DKF_SCN_LAYOUT_CASES;
    if (json_object_get(root, "steps") != NULL && json_object_get(root, "y") == NULL &&
        json_object_get(root, "runs") == NULL)
        return json_object_get(root, "graph") != NULL ? DKF_SCN_LAYOUT_NETWORK
                                                      : DKF_SCN_LAYOUT_STEPS;
    return DKF_SCN_LAYOUT_CANONICAL;
}

/* The scenario of a parsed document (takes the reference to root). */
static dkf_scenario_t *load_root(dkf_scn_ctx_t *c, json_t *root, const json_error_t *je,
                                 const char *case_sel)
{
    dkf_scenario_t *s;
    int rc;
    if (root == NULL) {
        if (je->line <= 0)
            dkf_scn_fail(c, NULL, "cannot read: %s", je->text);
        else
            dkf_scn_fail(c, NULL, "invalid JSON at line %d, column %d: %s", je->line, je->column,
                         je->text);
        return NULL;
    }
    if (!json_is_object(root)) {
        dkf_scn_fail(c, NULL, "expected a JSON object at the top level, got %s",
                     dkf_scn_json_kind(root));
        json_decref(root);
        return NULL;
    }
    s = calloc(1, sizeof *s);
    if (s == NULL || (s->file = dkf_scn_dupstr(c->file)) == NULL) {
        free(s);
        json_decref(root);
        dkf_scn_fail(c, NULL, "out of memory");
        return NULL;
    }
    s->root = root;
    s->k_first = 1;
    if (dkf_scn_letters(c, root, letters_layout(root), s->notice, sizeof s->notice) != 0) {
        dkf_scenario_free(s);
        return NULL;
    }
    if (json_object_get(root, "cases") != NULL) {
        rc = dkf_scn_load_cases(c, s, root, case_sel);
    } else if (case_sel != NULL) {
        rc = dkf_scn_fail(c, "cases", "--case given but the file has no cases (%s layout)",
                          json_object_get(root, "steps") != NULL ? "steps" : "canonical");
    } else if (json_object_get(root, "steps") != NULL && json_object_get(root, "y") == NULL &&
               json_object_get(root, "runs") == NULL) {
        rc = dkf_scn_load_steps(c, s, root);
    } else {
        static const char *const read_in[] = {"y", "runs", "truth"};
        size_t i;
        rc = dkf_scn_load_canonical(c, s, root);
        for (i = 0; rc == 0 && i < sizeof read_in / sizeof *read_in; ++i)
            json_object_del(root, read_in[i]);
    }
    if (rc != 0) {
        dkf_scenario_free(s);
        return NULL;
    }
    return s;
}

/* A refused file's message is one line, whoever wrote it (the readers, the
 * model loader, jansson quoting the offending token): a control character
 * the file put into a key, a name or an expression is shown as '?'. */
static dkf_scenario_t *one_line(dkf_scenario_t *s, char *err, size_t errlen)
{
    size_t i;
    for (i = 0; s == NULL && err != NULL && i < errlen && err[i] != '\0'; ++i)
        if ((unsigned char)err[i] < 0x20 || err[i] == 0x7f) err[i] = '?';
    return s;
}

static void ctx_init(dkf_scn_ctx_t *c, const char *file, char *err, size_t errlen)
{
    c->file = file != NULL ? file : "(null)";
    c->err = err;
    c->errlen = errlen;
    if (err != NULL && errlen > 0) err[0] = '\0';
}

dkf_scenario_t *dkf_scenario_load(const char *path, const char *case_sel, char *err,
                                  size_t errlen)
{
    dkf_scn_ctx_t c;
    json_error_t je;
    dkf_scenario_t *s;
    ctx_init(&c, path, err, errlen);
    if (path == NULL) {
        dkf_scn_fail(&c, NULL, "no scenario file given");
        return NULL;
    }
    s = one_line(load_root(&c, json_load_file(path, JSON_REJECT_DUPLICATES, &je), &je,
                           case_sel), err, errlen);
    if (s != NULL && s->notice[0] != '\0') fprintf(stderr, "%s\n", s->notice);
    return s;
}

dkf_scenario_t *dkf_scenario_load_buffer(const char *buf, size_t len, const char *name,
                                         const char *case_sel, char *err, size_t errlen)
{
    dkf_scn_ctx_t c;
    json_error_t je;
    ctx_init(&c, name, err, errlen);
    if (buf == NULL) {
        dkf_scn_fail(&c, NULL, "no scenario buffer given");
        return NULL;
    }
    return one_line(
        load_root(&c, json_loadb(buf, len, JSON_REJECT_DUPLICATES, &je), &je, case_sel), err,
        errlen);
}

void dkf_scenario_free(dkf_scenario_t *s)
{
    size_t i, r;
    if (s == NULL) return;
    for (i = 0; s->sensors != NULL && i < s->nsensors; ++i) {
        dkf_scn_mats_free(&s->sensors[i].mats);
        if (!s->sensors[i].borrowed) {
            free(s->sensors[i].yk);
            free(s->sensors[i].y);
        }
    }
    for (r = 0; s->runs != NULL && r < s->nruns; ++r) {
        for (i = 0; s->runs[r].y != NULL && i < s->nsensors; ++i) {
            free(s->runs[r].y[i].k);
            free(s->runs[r].y[i].v);
        }
        free(s->runs[r].y);
        free(s->runs[r].truth_k);
        free(s->runs[r].truth_x);
    }
    free(s->runs);
    free(s->sensors);
    dkf_scn_mats_free(&s->model);
    dkf_scn_mats_free(&s->init);
    if (!s->truth_borrowed) {
        free(s->truth_k);
        free(s->truth_x);
    }
    free(s->case_name);
    free(s->file);
    if (s->net != NULL) {
        free(s->net->edges);
        free(s->net->W_rc);
        free(s->net->W_v);
        free(s->net->alpha_rc);
        free(s->net->alpha_v);
        free(s->net);
    }
    free(s->truth_u_k);
    free(s->truth_u);
    if (s->nl != NULL) {
        for (i = 0; s->nl->models != NULL && i < s->nsensors; ++i) dkf_nlm_free(s->nl->models[i]);
        free(s->nl->models);
        free(s->nl);
    }
    json_decref(s->root);
    free(s);
}

const dkf_scn_mat_t *dkf_scn_model(const dkf_scenario_t *s, const char *name)
{
    return dkf_scn_mats_find(&s->model, name);
}

const dkf_scn_mat_t *dkf_scn_sensor_model(const dkf_scenario_t *s, size_t i, const char *name)
{
    const dkf_scn_mat_t *m = NULL;
    if (i < s->nsensors) m = dkf_scn_mats_find(&s->sensors[i].mats, name);
    return m != NULL ? m : dkf_scn_mats_find(&s->model, name);
}

const dkf_scn_mat_t *dkf_scn_init(const dkf_scenario_t *s, const char *name)
{
    return dkf_scn_mats_find(&s->init, name);
}

const dkf_scn_mat_t *dkf_scn_node_init(const dkf_scenario_t *s, size_t i, const char *name)
{
    const dkf_scn_mat_t *m = NULL;
    if (i < s->nsensors) m = dkf_scn_mats_find(&s->sensors[i].mats, name);
    return m != NULL ? m : dkf_scn_mats_find(&s->init, name);
}

const double *dkf_scn_at(const dkf_scn_mat_t *m, size_t k)
{
    if (m == NULL) return NULL;
    if (m->count == 0) return m->data;
    if (k < m->k0 || k - m->k0 >= m->count) return NULL;
    return m->data + (k - m->k0) * m->rows * m->cols;
}

const double *dkf_scn_P00_local(const dkf_scenario_t *s, size_t i)
{
    const dkf_scn_mat_t *Pl = dkf_scn_init(s, "P00_local");
    if (Pl != NULL) return dkf_scn_at(Pl, i);
    return dkf_scn_at(dkf_scn_init(s, "P00"), 0);
}

const double *dkf_scn_P00_central(const dkf_scenario_t *s)
{
    const dkf_scn_mat_t *Pc = dkf_scn_init(s, "P00_central");
    return dkf_scn_at(Pc != NULL ? Pc : dkf_scn_init(s, "P00"), 0);
}

const double *dkf_scn_y(const dkf_scenario_t *s, size_t i, long k)
{
    long j;
    if (i >= s->nsensors) return NULL;
    j = dkf_scn_find_time(s->sensors[i].yk, s->sensors[i].ny, k);
    return j < 0 ? NULL : s->sensors[i].y + (size_t)j * s->sensors[i].m;
}

const double *dkf_scn_truth(const dkf_scenario_t *s, long k)
{
    long j = dkf_scn_find_time(s->truth_k, s->ntruth, k);
    return j < 0 ? NULL : s->truth_x + (size_t)j * s->n;
}

const double *dkf_scn_truth_u(const dkf_scenario_t *s, long k)
{
    long j = dkf_scn_find_time(s->truth_u_k, s->ntruth_u, k);
    return j < 0 ? NULL : s->truth_u + (size_t)j * s->m_u;
}

void dkf_scn_to_real(dkf_real_t *dst, const double *src, size_t n)
{
    size_t i;
    for (i = 0; i < n; ++i) dst[i] = (dkf_real_t)src[i];
}

void dkf_scn_select_run(dkf_scenario_t *s, size_t r)
{
    size_t i;
    if (s->runs == NULL || r >= s->nruns) return;
    s->run = r;
    for (i = 0; i < s->nsensors; ++i) {
        s->sensors[i].ny = s->runs[r].y[i].n;
        s->sensors[i].yk = s->runs[r].y[i].k;
        s->sensors[i].y = s->runs[r].y[i].v;
        s->sensors[i].borrowed = 1;
    }
    s->ntruth = s->runs[r].ntruth;
    s->truth_k = s->runs[r].truth_k;
    s->truth_x = s->runs[r].truth_x;
    s->truth_borrowed = 1;
}
