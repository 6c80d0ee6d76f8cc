/*
 * scn_letters.c - the library's letters for the model's matrices, the
 * older letters of the vector files read as them (docs/reference/scenario-format.md,
 * "Letters"; docs/decisions.md item 51).
 */
#include "scn_parse.h"

#include <stdio.h>
#include <string.h>

/* ---- letters ---- */

/* Old letter -> the library's, per layout (docs/reference/scenario-format.md, "Letters"). */
typedef struct {
    const char *old_key, *new_key;
} rename_t;

static const rename_t canonical_letters[] = {{"A", "D"}, {NULL, NULL}};
static const rename_t cases_letters[] = {{"C", "H"}, {NULL, NULL}};
/* seed 004: A, C, H = F, H, D (H first: C becomes H) */
static const rename_t steps_letters[] = {{"H", "D"}, {"C", "H"}, {"A", "F"}, {NULL, NULL}};
/* seed 003: A, B, Sv, Sw = F, G, Q, R */
static const rename_t network_letters[] = {{"A", "F"}, {"B", "G"}, {"Sv", "Q"}, {"Sw", "R"},
                                           {NULL, NULL}};

/* Letters that only the old convention has (the file uses it if any is
 * present) and that only the new one has (then it is mixed). */
static const char *const canonical_old[] = {"A", NULL}, *const canonical_new[] = {"D", NULL};
static const char *const cases_old[] = {"C", NULL}, *const cases_new[] = {"H", NULL};
static const char *const steps_old[] = {"A", "C", NULL}, *const steps_new[] = {"F", "D", NULL};
static const char *const network_old[] = {"A", "B", "Sv", "Sw", NULL},
                         *const network_new[] = {"F", "G", "Q", "R", NULL};

/* Per layout (CANONICAL, CASES, STEPS, NETWORK: dkf_scn_layout_t 0..3). */
static const struct {
    const rename_t *map;
    const char *const *old_only, *const *new_only;
} conventions[] = {
    {canonical_letters, canonical_old, canonical_new},
    {cases_letters, cases_old, cases_new},
    {steps_letters, steps_old, steps_new},
    {network_letters, network_old, network_new},
};

typedef struct {
    const rename_t *map;
    const char *const *old_only, *const *new_only;
    int renaming;         /* 0: looking for the letters in use; 1: renaming */
    unsigned char seen[8][2]; /* map entry, plain / _prev: renamed somewhere */
    int old_seen, new_seen;
    char old_path[DKF_SCN_PATH_LEN], new_path[DKF_SCN_PATH_LEN];
} letters_t;

/* key or key_prev of obj in list; the found key in which (32 bytes). */
static int has_letter(const json_t *obj, const char *const *list, char *which)
{
    size_t i;
    char prev[32];
    for (i = 0; list[i] != NULL; ++i) {
        snprintf(prev, sizeof prev, "%s_prev", list[i]);
        if (json_object_get(obj, list[i]) != NULL || json_object_get(obj, prev) != NULL) {
            snprintf(which, 32, "%s", json_object_get(obj, list[i]) != NULL ? list[i] : prev);
            return 1;
        }
    }
    return 0;
}

/* obj's old keys (and their _prev) renamed to the library's letters. */
static void rename_keys(letters_t *L, json_t *obj)
{
    size_t i, v;
    for (i = 0; L->map[i].old_key != NULL; ++i)
        for (v = 0; v < 2; ++v) {
            char from[32], to[32];
            json_t *val;
            snprintf(from, sizeof from, "%s%s", L->map[i].old_key, v ? "_prev" : "");
            snprintf(to, sizeof to, "%s%s", L->map[i].new_key, v ? "_prev" : "");
            if ((val = json_object_get(obj, from)) == NULL) continue;
            json_incref(val);
            json_object_del(obj, from);
            json_object_set_new(obj, to, val);
            L->seen[i][v] = 1;
        }
}

/* One object holding matrices: its letters noted, or renamed. */
static void visit(letters_t *L, json_t *obj, const char *path)
{
    char which[32];
    if (!json_is_object(obj)) return;
    if (L->renaming) {
        rename_keys(L, obj);
        return;
    }
    if (!L->old_seen && has_letter(obj, L->old_only, which)) {
        L->old_seen = 1;
        dkf_scn_subkey(L->old_path, path, which);
    }
    if (!L->new_seen && has_letter(obj, L->new_only, which)) {
        L->new_seen = 1;
        dkf_scn_subkey(L->new_path, path, which);
    }
}

/* Every element of list (at path base), or its member key (NULL: itself). */
static void visit_each(letters_t *L, json_t *list, const char *base, const char *key)
{
    char p[DKF_SCN_PATH_LEN];
    size_t i;
    for (i = 0; i < json_array_size(list); ++i) {
        json_t *e = json_array_get(list, i);
        dkf_scn_pathf(p, "%s[%zu]%s%s", base, i, key != NULL ? "." : "", key != NULL ? key : "");
        visit(L, key != NULL ? json_object_get(e, key) : e, p);
    }
}

/* Every object of root that holds the model's matrices, per layout. */
static void visit_all(letters_t *L, json_t *root, dkf_scn_layout_t layout)
{
    json_t *model = json_object_get(root, "model");
    if (layout == DKF_SCN_LAYOUT_CASES) {
        visit_each(L, json_object_get(root, "cases"), "cases", NULL);
        return;
    }
    visit(L, model, "model");
    if (layout == DKF_SCN_LAYOUT_CANONICAL)
        visit_each(L, json_object_get(model, "sensors"), "model.sensors", NULL);
    else
        visit_each(L, json_object_get(root, "steps"), "steps", "inputs");
}

int dkf_scn_letters(dkf_scn_ctx_t *c, json_t *root, dkf_scn_layout_t layout, char *notice,
                    size_t len)
{
    letters_t L;
    char note[256] = "";
    size_t i, v;
    memset(&L, 0, sizeof L);
    /* the nonlinear and weighted-fusion layouts keep their papers' keys */
    if (layout > DKF_SCN_LAYOUT_NETWORK) return 0;
    L.map = conventions[layout].map;
    L.old_only = conventions[layout].old_only;
    L.new_only = conventions[layout].new_only;
    visit_all(&L, root, layout);
    if (!L.old_seen) return 0;
    if (L.new_seen)
        return dkf_scn_fail(c, L.new_path, "the library's letters mixed with the old ones (%s): "
                            "give one convention (docs/reference/scenario-format.md, \"Letters\")",
                            L.old_path);
    L.renaming = 1;
    visit_all(&L, root, layout);
    for (i = 0; L.map[i].old_key != NULL; ++i)
        for (v = 0; v < 2; ++v)
            if (L.seen[i][v])
                snprintf(note + strlen(note), sizeof note - strlen(note), "%s%s%s -> %s%s",
                         note[0] != '\0' ? ", " : "", L.map[i].old_key, v ? "_prev" : "",
                         L.map[i].new_key, v ? "_prev" : "");
    snprintf(notice, len, "%s: deprecated letters %s (%s): read as the "
             "library's (docs/reference/scenario-format.md, \"Letters\")", c->file, note, L.old_path);
    return 0;
}
