"""Native models: dkf.jit_model (numba cfuncs) and NLModel.native (any C
function of the core's callback type; here ctypes callbacks). A jit model
gives seed 001's radar vector (dnertsif_single.json) and the same bits as
the same Python function called as an NLModel callable; a native
function's non-zero return and a non-finite value fail the step with the
filter as it was; a bad address is refused before any C call."""

import ctypes
import functools
import math

import numpy as np
import pytest

import dkf
from conftest import load_vector, same_bits
from test_nerts import arr, run_case

numba = pytest.importorskip("numba", reason="numba is not installed (pip install numba)")

@functools.lru_cache(maxsize=None)
def radar_jit(m, xy):
    """dnertsif_single.json's radar at xy (one sensor), p = 1 (the turn
    rate), as numba-compiled fill-in functions (compiled once per module:
    numba takes about a second)."""
    sx, sy = xy

    def f(x, d, u, out):
        w = d[0]
        s, c = math.sin(w), math.cos(w)
        if abs(w) > 1e-12:
            a, b = s / w, (1.0 - c) / w
        else:
            a, b = 1.0, 0.0
        out[0] = x[0] + a * x[1] - b * x[3]
        out[1] = c * x[1] - s * x[3]
        out[2] = x[2] + b * x[1] + a * x[3]
        out[3] = s * x[1] + c * x[3]

    def h(x, d, u, y):
        dx, dy = x[0] - sx, x[2] - sy
        y[0] = math.sqrt(dx * dx + dy * dy)  # numba's hypot is not libm's: other bits
        y[1] = math.atan2(dy, dx)
        y[2] = 10.0 * d[0]

    return f, h, m.jit_model(f, h, n=4, m=3, p=1, angles=[1])


def as_callable(fill, size, dt):
    """The fill-in function called from Python: an NLModel callable."""

    def call(x, d, u):
        out = np.empty(size, dtype=dt)
        fill(x, d, u, out)
        return out

    return call


@pytest.mark.parametrize("kind", ["DNERTSIF", "DNERTSF"])
def test_jit_radar_vector(mod, kind):
    """The golden vector (tests/test_nerts_vectors.c's tolerances) through a
    jit model, and (double) the same bits as the Python model of the same
    functions."""
    m, dt = mod
    v = load_vector("infofusion/dnertsif_single.json")
    one = next(c for c in v["cases"] if c["name"] == "s1_single_node_sensor2")
    md = one["model"]
    Q, R = arr(md["Q"]), arr(md["R"])
    f, h, jm = radar_jit(m, tuple(float(v) for v in md["sensor_xy"]))
    assert jm.native_model and jm.n == 4 and jm.m == 3 and jm.p == 1
    a = run_case(m, dt, kind, one, jm, Q, R, phases=False)
    py = m.NLModel(as_callable(f, 4, dt), as_callable(h, 3, dt), n=4, m=3, p=1, angles=[1])
    assert not py.native_model
    b = run_case(m, dt, kind, one, py, Q, R, phases=False)
    if dt == np.float64:  # in float32, numba computes x[0] - sx in double, numpy in float
        for name in ("x", "Px", "d", "Pd", "Pxd"):
            assert same_bits(getattr(a, name), getattr(b, name)), name


def test_jit_jacobians_equal_the_python_ones():
    """The EKF kinds with jit Jacobians: the same bits as the Python model
    with the same Jacobian functions, on lin_x_sin_d (nertsif.json).
    Double only (the float32 module's jit path is test_jit_radar_vector's;
    numba's compile of these four functions takes seconds)."""
    m, dt = dkf, np.float64
    v = load_vector("infofusion/nertsif.json")
    c = v["cases"][0]
    md = c["model"]
    A, b = np.array(md["A"], dt), np.array(md["b"], dt)
    C, H = np.array(md["C"], dt), np.array(md["H"], dt)
    n, mm, p = A.shape[0], C.shape[0], H.shape[1]

    def f(x, d, u, out):
        for i in range(n):
            s = b[i] * math.sin(d[0])
            for j in range(n):
                s += A[i, j] * x[j]
            out[i] = s

    def h(x, d, u, y):
        for i in range(mm):
            s = H[i, 0] * d[0]
            for j in range(n):
                s += C[i, j] * x[j]
            y[i] = s

    def fj(x, d, u, Fx, Fd):
        Fx[:, :] = A
        for i in range(n):
            Fd[i, 0] = b[i] * math.cos(d[0])

    def hj(x, d, u, Hx, Hd):
        Hx[:, :] = C
        Hd[:, :] = H

    assert p == 1
    jm = m.jit_model(f, h, n=n, m=mm, p=p, f_jac=fj, h_jac=hj)

    def pair(fill, r):
        def call(x, d, u):
            J, Jd = np.empty((r, n), dt), np.empty((r, p), dt)
            fill(x, d, u, J, Jd)
            return J, Jd
        return call

    py = m.NLModel(as_callable(f, n, dt), as_callable(h, mm, dt), n=n, m=mm, p=p,
                   f_jac=pair(fj, n), h_jac=pair(hj, mm))
    Q, R = arr(md["Q"]), arr(md["R"])
    a = run_case(m, dt, "NERTSIF", c, jm, Q, R)
    b_ = run_case(m, dt, "NERTSIF", c, py, Q, R)
    assert same_bits(a.x, b_.x) and same_bits(a.Px, b_.Px) and same_bits(a.d, b_.d)


def cv_model(m, h_rc=0, nan=False):
    """A plain cubature filter's model (p = 0) as ctypes callbacks: constant
    velocity, range and bearing; h returns h_rc (0: success) and writes NaN
    when nan."""
    real = ctypes.c_double if m is dkf else ctypes.c_float
    P = ctypes.POINTER(real)
    FN = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_size_t, P, P, P, P)

    @FN
    def f(ctx, k, x, d, u, out):
        out[0], out[1], out[2], out[3] = x[0] + x[1], x[1], x[2] + x[3], x[3]
        return 0

    @FN
    def h(ctx, k, x, d, u, y):
        y[0] = math.nan if nan else math.hypot(x[0], x[2])
        y[1] = math.atan2(x[2], x[0])
        return h_rc

    return m.NLModel.native(f, h, n=4, m=2, p=0, angles=[1])


def test_native_failure_leaves_the_filter(mod):
    """A native h that returns 7: dkf.ModelError naming it and the value;
    one that writes NaN: dkf.NonFiniteError; both in step() and in
    filter(), and the filter's state the same bits as before."""
    m, dt = mod
    x0, P0 = np.array([10.0, 1.0, 5.0, -0.5]), np.eye(4)
    Q, R = 0.01 * np.eye(4), np.diag([0.1, 0.001])
    good = m.NERTS(cv_model(m), x0, P0, kind="DNERTSF")
    good.step(np.array([11.0, 0.4]), Q=Q, R=R)
    for model, exc, text in ((cv_model(m, h_rc=7), dkf.ModelError, "model.h returned 7"),
                             (cv_model(m, nan=True), dkf.NonFiniteError, "not finite")):
        flt = m.NERTS(model, x0, P0, kind="DNERTSF")
        before = (flt.x.tobytes(), flt.Px.tobytes(), flt.k)
        with pytest.raises(exc, match=text):
            flt.step(np.array([11.0, 0.4]), Q=Q, R=R)
        with pytest.raises(exc, match=text):
            flt.filter(np.tile([11.0, 0.4], (3, 1)), Q=Q, R=R)
        assert (flt.x.tobytes(), flt.Px.tobytes(), flt.k) == before
    # the failure is gone with the error: the model works again afterwards
    ok = m.NERTS(cv_model(m), x0, P0, kind="DNERTSF")
    ok.step(np.array([11.0, 0.4]), Q=Q, R=R)
    assert same_bits(ok.x, good.x)


def test_native_arguments_refused():
    """A missing, zero or non-address function is refused before any C
    call; a jit function numba cannot compile is a TypeError naming it."""
    good = cv_model(dkf)
    with pytest.raises(TypeError, match="an address"):
        dkf.NLModel.native("f", good.h, n=4, m=2, p=0)
    with pytest.raises(ValueError, match="address 0"):
        dkf.NLModel.native(0, good.h, n=4, m=2, p=0)
    with pytest.raises(TypeError, match="h is required"):
        dkf.NLModel.native(good.f, None, n=4, m=2, p=0)
    with pytest.raises(dkf.CapacityError):
        dkf.NLModel.native(good.f, good.h, n=4, m=2, p=0, q=dkf.MAX_DIM + 1)

    def bad(x, d, u, out):
        out[0] = {"a": x}  # not numeric: numba refuses it
    with pytest.raises(TypeError, match="jit_model: f: numba cannot compile"):
        dkf.jit_model(bad, bad, n=1, m=1)


def test_jit_ckf_equals_the_python_ckf():
    """The plain cubature filter (DNERTSF, p = 0) with a jit model and with
    the same functions called from Python: filter() gives the same bits."""

    def f(x, d, u, out):
        out[0], out[1], out[2], out[3] = x[0] + 0.1 * x[1], x[1], x[2] + 0.1 * x[3], x[3]

    def h(x, d, u, y):
        y[0], y[1] = math.sqrt(x[0] * x[0] + x[2] * x[2]), math.atan2(x[2], x[0])

    jm = dkf.jit_model(f, h, n=4, m=2, angles=[1])
    py = dkf.NLModel(as_callable(f, 4, np.float64), as_callable(h, 2, np.float64), n=4, m=2,
                     p=0, angles=[1])
    rng = np.random.default_rng(5)
    Z = np.column_stack([20 + rng.normal(size=50), 0.3 + 0.01 * rng.normal(size=50)])
    x0, P0 = np.array([15.0, 1.0, 5.0, -0.5]), np.eye(4)
    Q, R = 0.01 * np.eye(4), np.diag([0.1, 0.001])
    a = dkf.NERTS(jm, x0, P0, kind="DNERTSF").filter(Z, Q=Q, R=R)
    b = dkf.NERTS(py, x0, P0, kind="DNERTSF").filter(Z, Q=Q, R=R)
    assert all(same_bits(u, v) for u, v in zip(a, b))


def test_one_native_model_in_two_threads():
    """python.md, "Threads": one jit model serves filters in several threads
    at once (filter() without the GIL); each result the same bits as the
    same filter run alone."""
    import threading

    def f(x, d, u, out):
        out[0], out[1], out[2], out[3] = x[0] + 0.1 * x[1], x[1], x[2] + 0.1 * x[3], x[3]

    def h(x, d, u, y):
        y[0], y[1] = math.sqrt(x[0] * x[0] + x[2] * x[2]), math.atan2(x[2], x[0])

    jm = dkf.jit_model(f, h, n=4, m=2, angles=[1])
    rng = np.random.default_rng(9)
    Zs = [np.column_stack([20 + rng.normal(size=3000), 0.3 + 0.01 * rng.normal(size=3000)])
          for _ in range(4)]
    x0, P0 = np.array([15.0, 1.0, 5.0, -0.5]), np.eye(4)
    Q, R = 0.01 * np.eye(4), np.diag([0.1, 0.001])

    def run(Z):
        return dkf.NERTS(jm, x0, P0, kind="DNERTSF").filter(Z, Q=Q, R=R)

    alone = [run(Z) for Z in Zs]
    together = [None] * len(Zs)

    def worker(i):
        together[i] = run(Zs[i])

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(len(Zs))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(alone, together):
        assert all(same_bits(u, v) for u, v in zip(a, b))
