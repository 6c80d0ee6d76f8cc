#!/usr/bin/env python3
"""diffkf_coupling.py - how the nodes of a Difference-KF network are coupled in
the central filter's innovation covariance L_k (docs/design/diffkf-fusion.md §10).

Builds a random network (state n, N nodes with p_i = 2 unknown inputs and
m_i = 2 or 3 measurements, time-invariant), runs the covariance recursion of
the centralized Difference KF (docs/design/derivation-seed000.md §4: W, P_{k|k-1}, J_k, L_k,
written here in numpy, independent of the C library) and prints, per step,
the rank of L_k's block between the first N/2 nodes and the others: the rank
of the coupling that a block-diagonal-plus-low-rank (Woodbury, "information
form") centre would have to carry. In exact arithmetic it grows by n per step
(M P M^T and the v_k part of Ru give 2n at k = 1; each step's C L^{-1} C^T
carries the previous coupling on, and J's update adds n more) until the block
is full. Numerically it stops where the oldest directions fall below the
tolerance.

  tools/diffkf_coupling.py                  # n = 4, N = 24, 30 steps
  tools/diffkf_coupling.py --n 2 --nodes 40 --check

The recursion stays numpy, not the Python package's DifferenceKF: it is an
independent check of the claim, from the equations, and the ctests run it
with the system python3 (docs/decisions.md item 74).

--check exits 1 unless the rank is (k + 1) n at k = 1, 2, 3 (the exact growth;
needs 4n <= the block's size) and reaches at least 4n: the coupling is no
fixed rank-2n term.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_diffkf_vectors import blkdiag  # noqa: E402  (the vectors' reference code)


def network(n, nodes, rng):
    """F, Q and the stacked H, A, B, R, Rd of a random stable network."""
    F = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    F /= max(1.0, max(abs(np.linalg.eigvals(F))) / 0.98)
    H, A, B, R, Rd = [], [], [], [], []
    for i in range(nodes):
        m, p = 2 + i % 2, 2
        H.append(rng.standard_normal((m, n)))
        A.append(rng.standard_normal((m, p)))
        B.append(0.9 * np.eye(p) + 0.05 * rng.standard_normal((p, p)))
        R.append((0.5 + rng.random()) * np.eye(m))
        Rd.append((0.2 + rng.random()) * np.eye(p))
    return F, 0.1 * np.eye(n), np.vstack(H), blkdiag(A), blkdiag(B), blkdiag(R), blkdiag(Rd)


def coupling_ranks(n, nodes, steps, seed, tol):
    """Rank of L_k[first half, second half] for k = 1..steps, the block's size,
    and the last step's singular values (relative)."""
    F, Q, H, A, B, R, Rd = network(n, nodes, np.random.default_rng(seed))
    Ap, Bi = np.linalg.pinv(A), np.linalg.inv(B)
    G = Bi @ Ap                                            # B^{-1} A^+        (derivation §3)
    M = G @ H @ F - Ap @ H
    S = Q @ H.T @ G.T                                      # E[v u^T]          (13)
    Ru = G @ H @ Q @ H.T @ G.T + Bi @ Rd @ Bi.T + G @ R @ G.T + Ap @ R @ Ap.T   # (14)
    C = -Ap @ R @ Ap.T @ Bi.T                              # E[u_k u_{k-1}^T]  (15)
    half = 2 * (nodes // 2)

    def svals(L):
        s = np.linalg.svd(L[:half, half:], compute_uv=False)
        return s / s[0]

    P = np.eye(n)                                          # P_{1|0}
    J = P @ M.T                                            # J_1
    L = M @ P @ M.T + Ru                                   # L_1
    Pf = P - J @ np.linalg.solve(L, J.T)
    ranks = [int((svals(L) > tol).sum())]
    for _ in range(2, steps + 1):
        Li = np.linalg.inv(L)
        W = (F @ J + S) @ Li                                                   # W_{k-1}
        Pp = F @ Pf @ F.T + Q - F @ J @ Li @ S.T - S @ Li @ J.T @ F.T - S @ Li @ S.T  # (17)
        J = Pp @ M.T - W @ C.T                                                 # (19)
        L = M @ Pp @ M.T - M @ W @ C.T - C @ W.T @ M.T + Ru - C @ Li @ C.T     # (20)
        Pf = Pp - J @ np.linalg.solve(L, J.T)
        ranks.append(int((svals(L) > tol).sum()))
    return ranks, min(half, L.shape[0] - half), svals(L)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=4, help="state dimension (default 4)")
    ap.add_argument("--nodes", type=int, default=24, help="nodes, even (default 24)")
    ap.add_argument("--steps", type=int, default=30, help="steps (default 30, at most 1000)")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--tol", type=float, default=1e-10,
                    help="singular values above tol * the largest count (default 1e-10)")
    ap.add_argument("--check", action="store_true", help="exit 1 unless the growth is as stated")
    a = ap.parse_args()
    if not (1 <= a.n <= 64 and 2 <= a.nodes <= 400 and a.nodes % 2 == 0 and
            1 <= a.steps <= 1000 and 0 < a.tol < 1):
        ap.error("need 1 <= n <= 64, an even 2 <= nodes <= 400, 1 <= steps <= 1000, 0 < tol < 1")
    ranks, size, s = coupling_ranks(a.n, a.nodes, a.steps, a.seed, a.tol)
    print(f"n = {a.n}, N = {a.nodes}, sum p = {2 * a.nodes}: rank of L_k between nodes "
          f"0..{a.nodes // 2 - 1} and {a.nodes // 2}..{a.nodes - 1} (a {size} x {size} block), "
          f"singular values above {a.tol:g} of the largest")
    print("k = 1..%d: %s" % (a.steps, " ".join(map(str, ranks))))
    print("last step: %s" % ", ".join(f"{int((s > t).sum())} above {t:g}"
                                       for t in (1e-3, 1e-6, 1e-10, 1e-14)))
    if a.check:
        first = min(3, a.steps)
        ok = (4 * a.n <= size and all(ranks[k] == (k + 2) * a.n for k in range(first))
              and max(ranks) >= 4 * a.n)
        print("check: rank = (k + 1) n for k = 1..%d, at least 4n = %d later: %s"
              % (first, 4 * a.n, "yes" if ok else "NO"))
        return 0 if ok else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
