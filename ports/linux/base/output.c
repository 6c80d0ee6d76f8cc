/*
 * output.c - dkf-run's streamed output (output.h).
 */
#define _POSIX_C_SOURCE 200809L
#include "output.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>

#include "util.h"

/* Key paths and CSV column names longer than this are refused. */
#define OUT_PATH_LEN 512
/* Spooled bytes a list keeps in memory before it writes a chunk: the
 * larger of OUT_CHUNK_MIN and OUT_BUFFERED / (number of lists). */
#define OUT_CHUNK_MIN 4096u
#define OUT_BUFFERED (4u << 20)
#define OUT_ENCODING (JSON_COMPACT | JSON_ENCODE_ANY | JSON_REAL_PRECISION(17))

typedef struct {
    char *p;
    size_t len, cap;
} buf_t;

typedef struct {
    off_t off;
    size_t len;
} chunk_t;

/* One per-step list: its placeholder in the document and its spool. */
typedef struct {
    const json_t *leaf;
    buf_t buf;
    chunk_t *chunks;
    size_t nchunks, capchunks;
    size_t count; /* values written */
} series_t;

struct dkf_out {
    char *path;
    FILE *f;
    dkf_out_format_t format;
    unsigned long every;
    long k_first, k;
    int kept;
    /* JSON */
    FILE *spool;
    off_t spool_len;
    json_t *doc;   /* lists are empty placeholder arrays */
    json_t *index; /* path -> index into series */
    series_t *series;
    size_t nseries, capseries;
    /* CSV: the header (first step only) and the current row */
    buf_t head, row;
    size_t columns, row_columns;
    unsigned long rows;
    int failed;
    char msg[OUT_PATH_LEN + 256];
};

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static void fail(dkf_out_t *w, const char *fmt, ...)
{
    va_list ap;
    if (w->failed) return;
    w->failed = 1;
    va_start(ap, fmt);
    vsnprintf(w->msg, sizeof w->msg, fmt, ap);
    va_end(ap);
}

static int buf_add(buf_t *b, const char *s, size_t n)
{
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap > 0 ? b->cap : 256;
        char *p;
        while (b->len + n + 1 > cap) cap *= 2;
        if ((p = realloc(b->p, cap)) == NULL) return -1;
        b->p = p;
        b->cap = cap;
    }
    memcpy(b->p + b->len, s, n);
    b->len += n;
    b->p[b->len] = '\0';
    return 0;
}

static int buf_str(buf_t *b, const char *s)
{
    return buf_add(b, s, strlen(s));
}

/* ---- the document's tree ---- */

/* "name" or "name[i]" (seg is modified): *idx = i, or -1. 0, or -1 if malformed. */
static int split_index(char *seg, long *idx)
{
    char *br = strchr(seg, '['), *end;
    *idx = -1;
    if (br == NULL) return 0;
    *br = '\0';
    *idx = strtol(br + 1, &end, 10);
    return end == br + 1 || *idx < 0 || strcmp(end, "]") != 0 ? -1 : 0;
}

/* obj[name] (an object; created) or, with idx >= 0, obj[name][idx] (the
 * list filled with objects up to idx). NULL if the path crosses a value. */
static json_t *child(json_t *obj, const char *name, long idx)
{
    json_t *c = json_object_get(obj, name);
    if (c == NULL) {
        c = idx >= 0 ? json_array() : json_object();
        if (json_object_set_new(obj, name, c) != 0) return NULL;
    }
    if (idx < 0) return json_is_object(c) ? c : NULL;
    if (!json_is_array(c)) return NULL;
    while (json_array_size(c) <= (size_t)idx)
        if (json_array_append_new(c, json_object()) != 0) return NULL;
    c = json_array_get(c, (size_t)idx);
    return json_is_object(c) ? c : NULL;
}

/* doc[path] = value (stolen); -1 if path is malformed, crosses a value or
 * is already set. */
static int place(dkf_out_t *w, const char *path, json_t *value)
{
    char copy[OUT_PATH_LEN], *seg, *dot;
    json_t *node = w->doc;
    long idx;
    if (strlen(path) >= sizeof copy) goto bad;
    strcpy(copy, path);
    for (seg = copy; (dot = strchr(seg, '.')) != NULL; seg = dot + 1) {
        *dot = '\0';
        if (split_index(seg, &idx) != 0 || (node = child(node, seg, idx)) == NULL) goto bad;
    }
    if (split_index(seg, &idx) != 0 || idx >= 0 || json_object_get(node, seg) != NULL) goto bad;
    if (json_object_set_new(node, seg, value) == 0) return 0;
    value = NULL;
bad:
    json_decref(value);
    return -1;
}

/* The list at path, created on first use; NULL after a failure. */
static series_t *series_at(dkf_out_t *w, const char *path)
{
    json_t *known = json_object_get(w->index, path), *leaf;
    series_t *s;
    if (known != NULL) return &w->series[json_integer_value(known)];
    if (w->nseries == w->capseries) {
        size_t cap = w->capseries > 0 ? 2 * w->capseries : 16;
        series_t *p = realloc(w->series, cap * sizeof *p);
        if (p == NULL) return NULL;
        w->series = p;
        w->capseries = cap;
    }
    if ((leaf = json_array()) == NULL) return NULL;
    if (place(w, path, json_incref(leaf)) != 0 ||
        json_object_set_new(w->index, path, json_integer((json_int_t)w->nseries)) != 0) {
        json_decref(leaf);
        fail(w, "%s: %s: a per-step list where the document has another value", w->path, path);
        return NULL;
    }
    s = &w->series[w->nseries++];
    memset(s, 0, sizeof *s);
    s->leaf = leaf;
    json_decref(leaf); /* the document holds it */
    return s;
}

/* s's buffered bytes as a chunk of the spool. 0 or -1. */
static int spill(dkf_out_t *w, series_t *s)
{
    if (s->nchunks == s->capchunks) {
        size_t cap = s->capchunks > 0 ? 2 * s->capchunks : 8;
        chunk_t *p = realloc(s->chunks, cap * sizeof *p);
        if (p == NULL) return -1;
        s->chunks = p;
        s->capchunks = cap;
    }
    if (fwrite(s->buf.p, 1, s->buf.len, w->spool) != s->buf.len) return -1;
    s->chunks[s->nchunks].off = w->spool_len;
    s->chunks[s->nchunks++].len = s->buf.len;
    w->spool_len += (off_t)s->buf.len;
    s->buf.len = 0;
    return 0;
}

static void json_put(dkf_out_t *w, const char *path, const json_t *value)
{
    series_t *s = series_at(w, path);
    size_t limit = OUT_BUFFERED / (w->nseries + 1);
    char *text;
    if (s == NULL) {
        fail(w, "%s: out of memory", w->path);
        return;
    }
    if ((text = json_dumps(value, OUT_ENCODING)) == NULL ||
        (s->count > 0 && buf_add(&s->buf, ",", 1) != 0) || buf_str(&s->buf, text) != 0) {
        free(text);
        fail(w, "%s: out of memory", w->path);
        return;
    }
    free(text);
    s->count++;
    if (s->buf.len >= (limit > OUT_CHUNK_MIN ? limit : OUT_CHUNK_MIN) && spill(w, s) != 0)
        fail(w, "%s: cannot spool the output: %s", w->path, strerror(errno));
}

/* ---- CSV ---- */

/* Every number (or true/false/null) of value, as columns named path[i]... */
static void csv_put(dkf_out_t *w, const char *path, const json_t *value)
{
    char name[OUT_PATH_LEN];
    if (json_is_array(value) || json_is_object(value)) {
        const char *key;
        json_t *v;
        size_t i;
        json_array_foreach(value, i, v) {
            snprintf(name, sizeof name, "%s[%zu]", path, i);
            csv_put(w, name, v);
        }
        json_object_foreach((json_t *)value, key, v) {
            snprintf(name, sizeof name, "%s.%s", path, key);
            csv_put(w, name, v);
        }
        return;
    }
    {
        char *text = json_dumps(value, OUT_ENCODING);
        int bad = text == NULL || buf_add(&w->row, ",", 1) != 0 ||
                  buf_str(&w->row, json_is_null(value) ? "" : text) != 0;
        if (!bad && w->rows == 0)
            bad = buf_add(&w->head, ",", 1) != 0 || buf_str(&w->head, path) != 0;
        free(text);
        if (bad) fail(w, "%s: out of memory", w->path);
        w->row_columns++;
    }
}

/* The current row (after the header, with the first). */
static void csv_end_row(dkf_out_t *w)
{
    if (!w->kept || w->failed) return;
    if (w->rows == 0) {
        w->columns = w->row_columns;
        if (fprintf(w->f, "%s\n", w->head.p) < 0) fail(w, "%s: %s", w->path, strerror(errno));
    } else if (w->row_columns != w->columns) {
        fail(w, "%s: step k=%ld has %zu values where the first step had %zu (CSV needs the "
             "same values every step; use --format json)", w->path, w->k, w->row_columns,
             w->columns);
        return;
    }
    if (fprintf(w->f, "%s\n", w->row.p) < 0) fail(w, "%s: %s", w->path, strerror(errno));
    w->rows++;
    w->kept = 0;
}

/* ---- the public calls ---- */

dkf_out_t *dkf_out_open(const char *path, dkf_out_format_t format, unsigned long every,
                        long k_first, char *err, size_t errlen)
{
    dkf_out_t *w = calloc(1, sizeof *w);
    if (w == NULL || (w->path = malloc(strlen(path) + 1)) == NULL) {
        free(w);
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: out of memory", path);
        return NULL;
    }
    strcpy(w->path, path);
    w->format = format;
    w->every = every > 0 ? every : 1;
    w->k_first = k_first;
    w->doc = json_object();
    w->index = json_object();
    errno = 0;
    w->f = fopen(path, "w");
    if (w->f == NULL || (format == DKF_OUT_JSON && (w->spool = tmpfile()) == NULL) ||
        w->doc == NULL || w->index == NULL || buf_str(&w->head, "k") != 0) {
        dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s: cannot write the output: %s", path,
                  errno != 0 ? strerror(errno) : "out of memory");
        dkf_out_close(w, 0, NULL, 0);
        return NULL;
    }
    return w;
}

void dkf_out_value(dkf_out_t *w, const char *path, json_t *value)
{
    if (w->failed || w->format != DKF_OUT_JSON) {
        json_decref(value);
        return;
    }
    if (value == NULL || place(w, path, value) != 0)
        fail(w, "%s: %s: cannot set the value (out of memory or set twice)", w->path, path);
}

int dkf_out_step(dkf_out_t *w, long k)
{
    char text[32];
    if (w->format == DKF_OUT_CSV) csv_end_row(w);
    w->k = k;
    w->kept = k >= w->k_first && (unsigned long)(k - w->k_first) % w->every == 0;
    if (!w->kept || w->failed) return w->kept;
    if (w->format == DKF_OUT_JSON) {
        json_t *jk = json_integer((json_int_t)k);
        json_put(w, "k", jk);
        json_decref(jk);
        return 1;
    }
    snprintf(text, sizeof text, "%ld", k);
    w->row.len = 0;
    w->row_columns = 0;
    if (buf_str(&w->row, text) != 0) fail(w, "%s: out of memory", w->path);
    return 1;
}

void dkf_out_put(dkf_out_t *w, const char *path, json_t *value)
{
    if (value == NULL) fail(w, "%s: out of memory", w->path);
    if (w->kept && !w->failed) {
        if (w->format == DKF_OUT_JSON)
            json_put(w, path, value);
        else
            csv_put(w, path, value);
    }
    json_decref(value);
}

void dkf_out_series(dkf_out_t *w, const char *base, json_t *series)
{
    char path[OUT_PATH_LEN];
    const char *key;
    json_t *list, *v;
    size_t i;
    json_object_foreach(series, key, list) {
        snprintf(path, sizeof path, "%s.%s", base, key);
        json_array_foreach(list, i, v) dkf_out_put(w, path, json_incref(v));
        json_array_clear(list);
    }
}

void dkf_out_outputs(dkf_out_t *w, const char *label, json_t *series)
{
    char base[OUT_PATH_LEN];
    snprintf(base, sizeof base, "outputs.%s", label);
    dkf_out_series(w, base, series);
}

int dkf_out_failed(const dkf_out_t *w)
{
    return w->failed;
}

/* The spooled list s as a JSON list. */
static void write_series(dkf_out_t *w, const series_t *s)
{
    char chunk[1 << 16];
    size_t c;
    fputc('[', w->f);
    for (c = 0; c < s->nchunks && !w->failed; ++c) {
        size_t left = s->chunks[c].len;
        if (fseeko(w->spool, s->chunks[c].off, SEEK_SET) != 0) fail(w, "%s: spool", w->path);
        while (left > 0 && !w->failed) {
            size_t n = fread(chunk, 1, left < sizeof chunk ? left : sizeof chunk, w->spool);
            if (n == 0 || fwrite(chunk, 1, n, w->f) != n)
                fail(w, "%s: cannot write the output: %s", w->path, strerror(errno));
            left -= n;
        }
    }
    if (s->buf.len > 0) fwrite(s->buf.p, 1, s->buf.len, w->f);
    fputc(']', w->f);
}

/* node as compact JSON, every placeholder replaced by its list. */
static void write_node(dkf_out_t *w, const json_t *node)
{
    const char *key;
    json_t *v;
    size_t i;
    char *text;
    for (i = 0; i < w->nseries; ++i)
        if (w->series[i].leaf == node) {
            write_series(w, &w->series[i]);
            return;
        }
    if (json_is_object(node)) {
        int first = 1;
        fputc('{', w->f);
        json_object_foreach((json_t *)node, key, v) {
            json_t *jk = json_string(key);
            text = json_dumps(jk, OUT_ENCODING);
            fprintf(w->f, "%s%s:", first ? "" : ",", text != NULL ? text : "\"\"");
            free(text);
            json_decref(jk);
            write_node(w, v);
            first = 0;
        }
        fputc('}', w->f);
    } else if (json_is_array(node)) {
        fputc('[', w->f);
        json_array_foreach(node, i, v) {
            if (i > 0) fputc(',', w->f);
            write_node(w, v);
        }
        fputc(']', w->f);
    } else if ((text = json_dumps(node, OUT_ENCODING)) != NULL) {
        fputs(text, w->f);
        free(text);
    } else {
        fail(w, "%s: out of memory", w->path);
    }
}

int dkf_out_close(dkf_out_t *w, int keep, char *err, size_t errlen)
{
    size_t i;
    int rc = DKF_EXIT_OK;
    if (w == NULL) return rc;
    if (keep && w->format == DKF_OUT_CSV) csv_end_row(w);
    if (keep && w->format == DKF_OUT_JSON && !w->failed) write_node(w, w->doc);
    if (w->f != NULL) {
        int bad = fflush(w->f) != 0 || ferror(w->f);
        if (fclose(w->f) != 0 || bad)
            fail(w, "%s: cannot write the output: %s", w->path, strerror(errno));
        if (w->failed || !keep) remove(w->path);
    }
    if (w->failed) rc = dkf_failf(err, errlen, DKF_EXIT_USAGE, "%s", w->msg);
    if (w->spool != NULL) fclose(w->spool);
    for (i = 0; i < w->nseries; ++i) {
        free(w->series[i].buf.p);
        free(w->series[i].chunks);
    }
    free(w->series);
    json_decref(w->doc);
    json_decref(w->index);
    free(w->head.p);
    free(w->row.p);
    free(w->path);
    free(w);
    return rc;
}
