/*
 * scn_keys.c - which keys an object of a scenario may have: a key no
 * layout knows is refused, naming the nearest known key
 * (docs/decisions.md item 51).
 */
#include "scn_values.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>

/* Keys longer than this are never near a known key. */
#define KEY_CMP_LEN 64

/* What the vector files carry at the top level beside the scenario: their
 * expected outputs, tolerances, dimensions, seeds, notes. */
static const char *const info_keys[] = {"outputs", "tolerance", "dims", "seed", "time_varying",
                                        "expect_error_case", "conventions", NULL};

/* Edit distance between a and b, letters compared without case. */
static size_t distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b), i, j, row[KEY_CMP_LEN + 1];
    if (la > KEY_CMP_LEN || lb > KEY_CMP_LEN) return (size_t)-1;
    for (j = 0; j <= lb; ++j) row[j] = j;
    for (i = 1; i <= la; ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (j = 1; j <= lb; ++j) {
            const size_t up = row[j];
            const int same = tolower((unsigned char)a[i - 1]) == tolower((unsigned char)b[j - 1]);
            size_t best = diag + (same ? 0u : 1u);
            if (up + 1 < best) best = up + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            row[j] = best;
            diag = up;
        }
    }
    return row[lb];
}

/* The entry of list (NULL-terminated) whose last dotted part is nearest to
 * key, if near enough to be a typo: at most a third of its letters (at
 * least one) differ. NULL otherwise. */
static const char *nearest(const char *key, const char *const *list)
{
    const char *best = NULL;
    size_t i, dbest = strlen(key) / 3 > 1 ? strlen(key) / 3 : 1;
    for (i = 0; list != NULL && list[i] != NULL; ++i) {
        const char *dot = strrchr(list[i], '.');
        const size_t d = distance(key, dot != NULL ? dot + 1 : list[i]);
        if (d < dbest || (d == dbest && best == NULL)) {
            best = list[i];
            dbest = d;
        }
    }
    return best;
}

int dkf_scn_check_keys(dkf_scn_ctx_t *c, const json_t *obj, const char *path,
                       const char *const *known, const char *const *elsewhere)
{
    const char *key, *near;
    json_t *val;
    size_t i;
    char p[DKF_SCN_PATH_LEN];
    if (!json_is_object(obj)) return 0; /* the caller reports the type */
    json_object_foreach((json_t *)obj, key, val) {
        if (json_is_string(val) || json_is_null(val)) continue; /* comments */
        for (i = 0; known[i] != NULL && strcmp(known[i], key) != 0; ++i) continue;
        if (known[i] != NULL) continue;
        for (i = 0; path[0] == '\0' && info_keys[i] != NULL && strcmp(info_keys[i], key); ++i)
            continue;
        if (path[0] == '\0' && info_keys[i] != NULL) continue;
        dkf_scn_subkey(p, path, key);
        if ((near = nearest(key, known)) == NULL) near = nearest(key, elsewhere);
        if (near != NULL) return dkf_scn_fail(c, p, "unknown key (did you mean %s?)", near);
        return dkf_scn_fail(c, p, "unknown key (not one of the keys this object may have: "
                            "docs/reference/scenario-format.md)");
    }
    return 0;
}
