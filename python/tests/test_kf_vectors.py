"""dkf.KalmanFilter through Python on the golden vector the C test uses
(tests/test_kf.c, test_kf_matches_ex1_vector): seed 000 Example 1, "KF".

Tolerances, relative to max(1, max|expected|) per array, are the C test's
(its comment gives the reasons): float64 1e-9 (the vectors are exact to
~1e-15 and the filter is a contraction, rounding does not accumulate);
float32 1e-5 ~ 84 eps (each step loses O(n cond(S)) eps, n = 4, cond(S) ~
10, bounded because the filter forgets). So the float32 module is held to
exactly what the C float build is held to on the same vector.
"""

import numpy as np

from conftest import load_vector, model_at, rel_err

TOL = {np.float64: 1e-9, np.float32: 1e-5}


def ex1():
    v = load_vector("diffkf/ex1_single.json")
    N = len(v["k"])
    assert N == 50
    model = v["model"]
    steps = []
    for j in range(N):
        k = j + 1
        steps.append(dict(
            F=model_at(model, "F", k - 1), Q=model_at(model, "Q", k - 1),
            H=model_at(model, "H", k), R=model_at(model, "R", k),
            y=np.array(v["y"]["values"][j], dtype=np.float64).reshape(-1),
        ))
    out = v["outputs"]["KF"]
    x0 = np.array(v["init"]["x00"], dtype=np.float64).reshape(-1)
    P0 = np.atleast_2d(np.array(v["init"]["P00"], dtype=np.float64))
    return steps, out, x0, P0


def test_step_by_step_matches_ex1_vector(mod):
    m, dt = mod
    steps, out, x0, P0 = ex1()
    s0 = steps[0]
    kf = m.KalmanFilter(F=s0["F"], Q=s0["Q"], H=s0["H"], R=s0["R"], x0=x0, P0=P0)
    worst = 0.0
    for j, s in enumerate(steps):
        kf.predict(F=s["F"], Q=s["Q"])
        for name, got in (("xp", kf.x), ("Pp", kf.P)):
            assert got.dtype == dt
            e = rel_err(got.reshape(-1), np.array(out[name][j]).reshape(-1))
            assert e <= TOL[dt], (name, j, e)
            worst = max(worst, e)
        kf.update(s["y"], H=s["H"], R=s["R"])
        for name, got in (("xf", kf.x), ("Pf", kf.P)):
            e = rel_err(got.reshape(-1), np.array(out[name][j]).reshape(-1))
            assert e <= TOL[dt], (name, j, e)
            worst = max(worst, e)
    print(f"worst relative error {worst:.3e}")


def test_filter_matches_ex1_vector(mod):
    m, dt = mod
    steps, out, x0, P0 = ex1()
    stack = {key: np.stack([s[key] for s in steps]) for key in ("F", "Q", "H", "R")}
    Y = np.stack([s["y"] for s in steps])
    kf = m.KalmanFilter(x0=x0, P0=P0, **stack)
    X, P = kf.filter(Y)
    assert X.dtype == dt and P.dtype == dt
    assert X.shape == (50, x0.size) and P.shape == (50, x0.size, x0.size)
    for j in range(50):
        assert rel_err(X[j], np.array(out["xf"][j]).reshape(-1)) <= TOL[dt], j
        assert rel_err(P[j].reshape(-1), np.array(out["Pf"][j]).reshape(-1)) <= TOL[dt], j
