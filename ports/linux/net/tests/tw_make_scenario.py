#!/usr/bin/env python3
"""A seed-003 scenario on a random geometric graph (fixed seed), for dkf-tw-node.

    tw_make_scenario.py --nodes 36 --steps 40 --seed 36 --out rgg36.json

Nodes uniform in the unit square, an edge when two are closer than
--radius (default sqrt(7 / (pi N)): mean degree ~6 before border losses); the layout is redrawn (seed + 1, ...)
until the graph is connected. The model, the sensors (H_l = [I 0], Sw_l
alternating 1x and 4x the paper's [[.052, .01], [.01, .052]]), the input
profile and the simulation are those of tools/tw_example.py (imported, not
copied); no weights in the file (library defaults: uniform alpha,
Metropolis W), eta from --eta.
"""
import argparse
import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "..", "..", "tools"))
import tw_example  # noqa: E402

SW = [[0.052, 0.01], [0.01, 0.052]]


def graph(N, radius, seed):
    for attempt in range(1000):
        rng = np.random.default_rng(seed + attempt)
        p = rng.random((N, 2))
        edges = [[i, j] for i in range(N) for j in range(i + 1, N)
                 if np.hypot(*(p[i] - p[j])) < radius]
        adj = {i: set() for i in range(N)}
        for i, j in edges:
            adj[i].add(j)
            adj[j].add(i)
        seen, todo = {0}, [0]
        while todo:
            for j in adj[todo.pop()] - seen:
                seen.add(j)
                todo.append(j)
        if len(seen) == N:
            return edges
    raise SystemExit("tw_make_scenario: no connected layout found; use a larger --radius")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", type=int, default=36)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--seed", type=int, default=36)
    ap.add_argument("--eta", type=int, default=10)
    ap.add_argument("--radius", type=float, default=None)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    N = a.nodes
    radius = a.radius if a.radius else math.sqrt(7.0 / (math.pi * N))
    edges = graph(N, radius, a.seed)
    base = {"graph": {"edges": edges},
            "model": {"F": [[1.0, 0, 0.1, 0], [0, 1.0, 0, 0.1], [0, 0, 1.0, 0], [0, 0, 0, 1.0]],
                      "G": [[0.5, 0], [0, 0.5], [0.1, 0], [0, 0.1]],
                      "Q": [[2.5e-05, 0, 0.0005, 0], [0, 2.5e-05, 0, 0.0005],
                            [0.0005, 0, 0.01, 0], [0, 0.0005, 0, 0.01]],
                      "H": [[[1.0, 0, 0, 0], [0, 1.0, 0, 0]] for _ in range(N)],
                      "R": [[[v * (1 if l % 2 == 0 else 4) for v in row] for row in SW]
                            for l in range(N)]}}
    x, y, z = tw_example.simulate(base, a.steps, a.seed)
    doc = tw_example.scenario(base, x, y, z, a.steps, a.eta)
    doc["name"] = "rgg%d" % N
    doc["description"] = ("tw_make_scenario.py: random geometric graph, %d nodes, %d edges, "
                          "radius %.3f, seed %d; model and sensors of seed 003" %
                          (N, len(edges), radius, a.seed))
    with open(a.out, "w") as f:
        json.dump(doc, f)
    print("%s: %d nodes, %d edges, %d steps" % (a.out, N, len(edges), a.steps))


if __name__ == "__main__":
    main()
