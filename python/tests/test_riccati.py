"""dkf.dare and dkf.stein (dkf/mat_riccati.h): seed 002's steady
predictor covariances (the values tests/test_mat_riccati.c checks), scipy's
solve_discrete_are on random models when scipy is installed, the Stein
equation against its Kronecker form, and the error statuses."""

import numpy as np
import pytest

import dkf
from conftest import load_vector, rand_spd, rel_err

# double: the file's rtol 1e-8; float: a problem of condition ~10 rounded
# to float, 64 eps of max|expected| (tests/test_mat_riccati.c).
TOL = {np.float64: 1e-8, np.float32: 64 * np.finfo(np.float32).eps}


def test_dare_seed002(mod):
    m, dt = mod
    c = load_vector("infofusion/s2_weighted_fusion.json")["cases"][0]
    G, F = np.array(c["Gamma"]), np.array(c["Phi"])
    Q = G @ np.array(c["Qe"]) @ G.T
    for i in range(5):
        X = m.dare(F, np.array(c["H"][i]), Q, np.array(c["R"][i]))
        want = np.array(c["steady_state"]["Sigma_pred"][i])
        assert X.dtype == dt and X.shape == (4, 4)
        assert np.max(np.abs(X - want)) <= TOL[dt] * max(1.0, np.max(np.abs(want))), i


def random_model(rng, n, m):
    F = rng.normal(size=(n, n))
    F *= 1.2 / max(abs(np.linalg.eigvals(F)))  # unstable, and detectable with a random H
    return F, rng.normal(size=(m, n)), rand_spd(rng, n, 10.0, 0.5), rand_spd(rng, m, 5.0, 1.0)


@pytest.mark.parametrize("seed", range(5))
def test_dare_against_scipy(seed):
    scipy_linalg = pytest.importorskip(
        "scipy.linalg", reason="scipy is not installed: the comparison with "
        "scipy.linalg.solve_discrete_are is skipped")
    rng = np.random.default_rng(1100 + seed)
    n, mm = int(rng.integers(2, 7)), int(rng.integers(1, 4))
    F, H, Q, R = random_model(rng, n, mm)
    X = dkf.dare(F, H, Q, R)
    # scipy solves the control DARE; the filtering one is its dual (F^T, H^T)
    Xs = scipy_linalg.solve_discrete_are(F.T, H.T, Q, R)
    assert rel_err(X, Xs) <= 1e-9 * max(1.0, np.linalg.cond(Xs)) ** 0.5
    # and X solves the equation it is documented to solve
    S = H @ X @ H.T + R
    resid = F @ X @ F.T - F @ X @ H.T @ np.linalg.solve(S, H @ X @ F.T) + Q - X
    assert np.max(np.abs(resid)) <= 1e-9 * np.max(np.abs(X))


@pytest.mark.parametrize("seed", range(4))
def test_stein_against_its_kronecker_form(mod, seed):
    m, dt = mod
    rng = np.random.default_rng(1200 + seed)
    r, k = int(rng.integers(1, 6)), int(rng.integers(1, 6))
    A, B = rng.normal(size=(r, r)), rng.normal(size=(k, k))
    A *= 0.9 / max(abs(np.linalg.eigvals(A)))
    B *= 0.95 / max(abs(np.linalg.eigvals(B)))
    C = rng.normal(size=(r, k))
    X = m.stein(A, B, C)
    # vec(A X B^T) = (B kron A) vec(X), vec stacking columns
    ref = np.linalg.solve(np.eye(r * k) - np.kron(B, A), C.flatten("F")).reshape((r, k), order="F")
    assert X.dtype == dt and X.shape == (r, k)
    assert rel_err(X, ref) <= (1e-10 if dt == np.float64 else 1e-4)


def test_errors(mod):
    m, _ = mod
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])
    H, R = np.array([[1.0, 0.0]]), np.eye(1)
    with pytest.raises(dkf.UnstableError, match=r"^dare: .*no stabilising solution"):
        m.dare(rot, H, np.zeros((2, 2)), R)
    with pytest.raises(dkf.NotSPDError):
        m.dare(0.5 * np.eye(2), H, np.eye(2), -R)
    with pytest.raises(dkf.NonFiniteError) as info:
        m.dare(0.5 * np.eye(2), H, np.array([[1.0, np.nan], [0.0, 1.0]]), R)
    assert info.value.matrix == "Q" and info.value.call == "dare"
    with pytest.raises(dkf.UnstableError, match=r"^stein: .*does not contract"):
        m.stein(1.1 * np.eye(2), np.eye(3), np.ones((2, 3)))
    with pytest.raises(ValueError):
        m.stein(np.eye(2), np.eye(2), np.ones((2, 3)))
    with pytest.raises(ValueError):
        m.dare(np.ones((2, 3)), H, np.eye(2), R)


def test_stein_closed_forms(mod):
    """tests/test_mat_riccati.c's closed forms: A nilpotent gives C + A C B^T
    exactly; the scalar Lyapunov x = a^2 x + 1 at a = 0.999; rho(A) rho(B) =
    1 exactly is not a contraction."""
    m, dt = mod
    X = m.stein(np.array([[0.0, 2.0], [0.0, 0.0]]), np.diag([3.0, 0.5]),
                np.array([[1.0, 2.0], [3.0, 4.0]]))
    assert X.tolist() == [[19.0, 6.0], [3.0, 4.0]]
    a = dt(0.999)
    x = m.stein(np.array([[a]]), np.array([[a]]), np.ones((1, 1)))
    want = 1.0 / (1.0 - float(a) * float(a))
    assert abs(float(x[0, 0]) - want) / want <= 2048 * np.finfo(dt).eps
    with pytest.raises(dkf.UnstableError):
        m.stein(np.diag([2.0, 0.3]), np.array([[0.5]]), np.ones((2, 1)))
