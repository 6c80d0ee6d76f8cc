/*
 * replay_main.c - runs a libFuzzer harness without libFuzzer (docs/guide/fuzzing.md).
 *
 * usage: fuzz_<name> PATH...   (each PATH a file, or a directory whose
 * regular files are all run, in name order). Every input is passed once to
 * LLVMFuzzerTestOneInput, as libFuzzer would; a harness reports a broken
 * property by aborting, and the sanitizers of the build (double-asan) by
 * aborting too, so the ctest fails on the first bad input. Exit 0 after the
 * last input; 1 if a path cannot be read or no input was found (an empty or
 * missing corpus is an error, not a pass).
 */
#define _POSIX_C_SOURCE 200809L
/* 64-bit inode numbers and directory offsets on 32-bit hosts (armhf under
 * qemu-arm): without it readdir fails with EOVERFLOW on ext4. */
#define _FILE_OFFSET_BITS 64

#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Reads the whole file into a fresh heap buffer (exactly size bytes, so
 * ASan sees a read past the end); NULL on error. */
static uint8_t *read_all(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    uint8_t *buf = NULL;
    long n;
    if (f == NULL) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0) {
        buf = malloc(n > 0 ? (size_t)n : 1);
        if (buf != NULL && fread(buf, 1, (size_t)n, f) != (size_t)n) {
            free(buf);
            buf = NULL;
        }
        *size = (size_t)n;
    }
    fclose(f);
    return buf;
}

static int run_file(const char *path)
{
    size_t size = 0;
    uint8_t *buf = read_all(path, &size);
    if (buf == NULL) {
        fprintf(stderr, "replay: %s: cannot read\n", path);
        return -1;
    }
    fprintf(stderr, "replay: %s (%zu bytes)\n", path, size);
    (void)LLVMFuzzerTestOneInput(buf, size);
    free(buf);
    return 0;
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Runs every regular file of directory dir; *count += files run. */
static int run_dir(const char *dir, size_t *count)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    char **names = NULL;
    size_t n = 0, cap = 0, i;
    int rc = 0;
    if (d == NULL) {
        fprintf(stderr, "replay: %s: cannot open\n", dir);
        return -1;
    }
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.') continue;
        if (n == cap) {
            char **g = realloc(names, (cap = cap ? 2 * cap : 64) * sizeof *names);
            if (g == NULL) break;
            names = g;
        }
        names[n] = malloc(strlen(dir) + strlen(e->d_name) + 2);
        if (names[n] == NULL) break;
        sprintf(names[n], "%s/%s", dir, e->d_name);
        ++n;
    }
    closedir(d);
    if (n > 0) qsort(names, n, sizeof *names, by_name);
    for (i = 0; i < n; ++i) {
        struct stat st;
        if (rc == 0 && stat(names[i], &st) == 0 && S_ISREG(st.st_mode)) {
            rc = run_file(names[i]);
            ++*count;
        }
        free(names[i]);
    }
    free(names);
    return rc;
}

int main(int argc, char **argv)
{
    size_t count = 0;
    int i;
    for (i = 1; i < argc; ++i) {
        struct stat st;
        int rc;
        if (stat(argv[i], &st) != 0) {
            fprintf(stderr, "replay: %s: no such file or directory\n", argv[i]);
            return 1;
        }
        if (S_ISDIR(st.st_mode)) {
            rc = run_dir(argv[i], &count);
        } else {
            rc = run_file(argv[i]);
            ++count;
        }
        if (rc != 0) return 1;
    }
    if (count == 0) {
        fprintf(stderr, "replay: no input (usage: %s FILE-OR-DIR...)\n", argv[0]);
        return 1;
    }
    printf("replay: %zu input(s), no property broken\n", count);
    return 0;
}
