/*
 * dkf-keygen - the key files of an authenticated network (auth.h;
 * docs/guide/network.md, "Authentication").
 *
 *   dkf-keygen DIR NODES            dkf-sim, dkf-node, dkf-fusion
 *   dkf-keygen --edges DIR NODES    dkf-tw-node (a graph filter)
 *
 * Writes DIR/node-<i>.key for i < NODES and DIR/infra.key, or with --edges
 * DIR/edge-<i>-<j>.key for every i < j < NODES (the graph's edges take
 * theirs), fresh random 256-bit keys, mode 0600 (DIR created 0700). An
 * existing key file is kept, so running it again changes nothing. Exit 0,
 * or 2 with one line on stderr.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "auth.h"
#include "util.h"

int main(int argc, char **argv)
{
    char err[4200], *end = NULL;
    const int edges = argc > 1 && strcmp(argv[1], "--edges") == 0;
    unsigned long nodes;
    if (argc != 3 + edges || (nodes = strtoul(argv[2 + edges], &end, 10), *end != '\0') ||
        nodes < 1 || nodes > DKF_AUTH_MAX_KEYS) {
        fprintf(stderr, "usage: dkf-keygen [--edges] DIR NODES (NODES in 1..%d)\n",
                DKF_AUTH_MAX_KEYS);
        return DKF_EXIT_USAGE;
    }
    if ((edges ? dkf_auth_make_edge_keys(argv[2], (size_t)nodes, err, sizeof err)
               : dkf_auth_make_keys(argv[1], (size_t)nodes, err, sizeof err)) != 0) {
        fprintf(stderr, "dkf-keygen: %s\n", err);
        return DKF_EXIT_USAGE;
    }
    return DKF_EXIT_OK;
}
