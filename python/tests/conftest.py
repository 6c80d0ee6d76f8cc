"""What the Python package's tests share: the repository's golden
vectors, random models with fixed seeds, and an independent numpy Kalman
filter (the oracle: textbook equations, no dkf code)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import dkf
import dkf.float32

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "tests" / "vectors"

# dkf and dkf.float32 with the dtype their arrays have: the tests that hold
# for both are parametrised over this.
MODULES = [(dkf, np.float64), (dkf.float32, np.float32)]


@pytest.fixture(params=MODULES, ids=["float64", "float32"])
def mod(request):
    return request.param


def load_vector(rel: str) -> dict:
    with open(VECTORS / rel, encoding="utf-8") as f:
        return json.load(f)


def model_at(model: dict, key: str, k: int) -> np.ndarray:
    """A model matrix of a vector at step k: "const" or "per_k"[k]
    (tests/support/dkf_test.c's test_json_model_at)."""
    spec = model[key]
    m = spec["const"] if "const" in spec else spec["per_k"][k]
    return np.atleast_2d(np.array(m, dtype=np.float64))


def rand_spd(rng: np.random.Generator, n: int, cond: float, scale: float) -> np.ndarray:
    """A random SPD matrix with eigenvalues scale * [1, cond]."""
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    ev = scale * np.geomspace(1.0, cond, n)
    return (q * ev) @ q.T


def rand_model(rng: np.random.Generator, n: int, m: int, T: int) -> dict:
    """A random stable time-varying model of T steps, stacked: F = 0.95 *
    orthogonal (bounded, rotating differently each step), Q and R SPD with
    condition numbers 5 and 3, H Gaussian, and measurements Y."""
    F = np.stack([0.95 * np.linalg.qr(rng.normal(size=(n, n)))[0] for _ in range(T)])
    Q = np.stack([rand_spd(rng, n, 5.0, 0.1) for _ in range(T)])
    H = rng.normal(size=(T, m, n))
    R = np.stack([rand_spd(rng, m, 3.0, 0.5) for _ in range(T)])
    return dict(
        F=F, Q=Q, H=H, R=R,
        x0=rng.normal(size=n), P0=rand_spd(rng, n, 10.0, 1.0),
        Y=rng.normal(size=(T, m)),
    )


def oracle_step(x, P, F, Q, H, R, y):
    """One textbook predict + update in float64 (the short form of P; the
    core uses the Joseph form: they differ by rounding only)."""
    x = F @ x
    P = F @ P @ F.T + Q
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T
    x = x + K @ (y - H @ x)
    P = P - K @ H @ P
    return x, P


def rel_err(got, ref) -> float:
    """max |got - ref| / max(1, max |ref|)."""
    ref = np.asarray(ref, dtype=np.float64)
    return float(np.max(np.abs(np.asarray(got, dtype=np.float64) - ref)) / max(1.0, np.max(np.abs(ref))))


def same_bits(a, b) -> bool:
    """The same dtype, shape and bytes."""
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def poker(rng: np.random.Generator):
    """poke(a, v): a copy of a with one entry, chosen by rng, set to v."""

    def poke(a, v):
        a = np.array(a, copy=True)
        a.flat[int(rng.integers(a.size))] = v
        return a

    return poke


def assert_refused_untouched(bad, rng, state, want, cls_name):
    """Each (call, exception, matrix) of bad, in an order rng draws, raises
    its exception (a dkf.Error naming matrix, status and the class's call)
    and leaves state() == want."""
    for k in rng.permutation(len(bad)):
        call, exc, matrix = bad[k]
        with pytest.raises(exc) as info:
            call()
        if issubclass(exc, dkf.Error):
            assert info.value.matrix == matrix and info.value.status == exc.status, str(info.value)
            assert info.value.call.startswith(cls_name + ".")
        assert state() == want, k
