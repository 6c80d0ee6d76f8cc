"""dkf.Error: one subclass per dkf_status_t, messages that name the call,
the step and the matrix, and objects left bit-identical by every failure."""

import re

import numpy as np
import pytest

import dkf
from conftest import ROOT, rand_model, rand_spd


def status_codes():
    """(name, value) of every DKF_ERR_* of include/dkf/status.h."""
    text = (ROOT / "include" / "dkf" / "status.h").read_text(encoding="utf-8")
    return [(n, int(v)) for n, v in re.findall(r"\b(DKF_ERR_[A-Z_]+) = (-\d+)", text)]


def test_one_subclass_per_status():
    codes = status_codes()
    assert len(codes) >= 15
    classes = {c.status: c for c in vars(dkf).values()
               if isinstance(c, type) and issubclass(c, dkf.Error) and c is not dkf.Error}
    assert sorted(classes) == sorted(v for _, v in codes)
    for name, value in codes:
        cls = classes[value]
        assert cls.__doc__.startswith(name + ":"), (cls, name)
        assert issubclass(cls, dkf.Error) and issubclass(cls, Exception)
        assert cls.__name__ in dkf.__all__


def valid_model(seed):
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(1, 7)), int(rng.integers(1, 5))
    return rng, n, m, rand_model(rng, n, m, 8)


def state(kf):
    return (kf.x.tobytes(), kf.P.tobytes(), kf.n, kf.m_max, repr(kf))


def bad_calls(rng, n, m, md, dt):
    """(description, call, expected exception, expected matrix, step) for
    random bad inputs on a filter of this model."""
    F, Q, H, R, y = md["F"][1], md["Q"][1], md["H"][1], md["R"][1], md["Y"][1]

    def poke(a, value):
        a = a.copy()
        a.flat[int(rng.integers(a.size))] = value
        return a

    T = 6
    Ys = md["Y"][:T].copy()
    t_inf = int(rng.integers(T))
    Ys[t_inf, int(rng.integers(m))] = np.inf
    Rs = md["R"][:T].copy()
    t_neg = int(rng.integers(T))
    Rs[t_neg] = -100.0 * np.eye(m)
    Fs, Qs, Hs = md["F"][:T], md["Q"][:T], md["H"][:T]
    return [
        ("NaN in F", lambda kf: kf.predict(F=poke(F, np.nan), Q=Q), dkf.NonFiniteError, "F", None),
        ("Inf in Q", lambda kf: kf.predict(F=F, Q=poke(Q, np.inf)), dkf.NonFiniteError, "Q", None),
        ("indefinite Q", lambda kf: kf.predict(F=F, Q=-1e3 * np.eye(n)), dkf.NotSPDError, "Q", None),
        ("NaN in H", lambda kf: kf.update(y, H=poke(H, np.nan), R=R), dkf.NonFiniteError, "H", None),
        ("NaN in R", lambda kf: kf.update(y, H=H, R=poke(R, np.nan)), dkf.NonFiniteError, "R", None),
        ("Inf in y", lambda kf: kf.update(poke(y, -np.inf), H=H, R=R), dkf.NonFiniteError, "y", None),
        ("indefinite R", lambda kf: kf.update(y, H=H, R=-100.0 * np.eye(m)), dkf.NotSPDError, "R", None),
        ("filter, Inf in Y", lambda kf: kf.filter(Ys, F=Fs, Q=Qs, H=Hs, R=md["R"][:T]),
         dkf.NonFiniteError, "y", t_inf),
        ("filter, indefinite R", lambda kf: kf.filter(md["Y"][:T], F=Fs, Q=Qs, H=Hs, R=Rs),
         dkf.NotSPDError, "R", t_neg),
        ("F wrong shape", lambda kf: kf.predict(F=np.eye(n + 1), Q=Q), ValueError, None, None),
        ("F 3-D in predict", lambda kf: kf.predict(F=md["F"], Q=Q), ValueError, None, None),
        ("y wrong length", lambda kf: kf.update(np.zeros(m + 1), H=H, R=R), ValueError, None, None),
        ("R wrong shape", lambda kf: kf.update(y, H=H, R=np.eye(m + 1)), ValueError, None, None),
        ("H above m_max", lambda kf: kf.update(np.zeros(m + 1), H=np.ones((m + 1, n)),
                                               R=np.eye(m + 1)), ValueError, None, None),
        ("Y wrong columns", lambda kf: kf.filter(np.zeros((3, m + 1)), F=F, Q=Q, H=H, R=R),
         ValueError, None, None),
        ("stack length", lambda kf: kf.filter(np.zeros((3, m)), F=md["F"], Q=Q, H=H, R=R),
         ValueError, None, None),
        ("complex y", lambda kf: kf.update(y + 1j, H=H, R=R), TypeError, None, None),
        ("string F", lambda kf: kf.predict(F="F", Q=Q), TypeError, None, None),
        ("bool H", lambda kf: kf.update(y, H=np.ones((m, n), dtype=bool), R=R), TypeError,
         None, None),
        ("object Y", lambda kf: kf.filter(np.array([[object()] * m]), F=F, Q=Q, H=H, R=R),
         TypeError, None, None),
    ]


@pytest.mark.parametrize("seed", range(12))
def test_failures_leave_the_filter_bit_identical(mod, seed):
    """Random valid models (fixed seeds), a few valid steps, then random bad
    inputs in a random order: each raises what it should, and after each the
    filter is bit for bit its twin that never saw a bad input, and goes on
    to compute the same bits."""
    dkfm, dt = mod
    rng, n, m, md = valid_model(seed)
    args = dict(F=md["F"][0], Q=md["Q"][0], H=md["H"][0], R=md["R"][0], x0=md["x0"], P0=md["P0"])
    kf, twin = dkfm.KalmanFilter(**args), dkfm.KalmanFilter(**args)
    for f in (kf, twin):
        for t in range(3):
            f.predict(F=md["F"][t], Q=md["Q"][t])
            f.update(md["Y"][t], H=md["H"][t], R=md["R"][t])
    want = state(twin)
    calls = bad_calls(rng, n, m, md, dt)
    for i in rng.permutation(len(calls)):
        what, call, exc, matrix, step = calls[i]
        with pytest.raises(exc) as info:
            call(kf)
        if issubclass(exc, dkf.Error):
            e = info.value
            assert e.status == exc.status and e.matrix == matrix and e.step == step, what
            assert e.call in str(e) and e.call.startswith("KalmanFilter."), what
            if step is not None:
                assert f"step {step}" in str(e), what
        assert state(kf) == want, what
    for t in range(3, 8):
        for f in (kf, twin):
            f.predict(F=md["F"][t], Q=md["Q"][t])
            f.update(md["Y"][t], H=md["H"][t], R=md["R"][t])
        assert state(kf) == state(twin)


def test_init_errors_name_the_matrix(mod):
    dkfm, _ = mod
    md = rand_model(np.random.default_rng(3), 3, 2, 1)
    args = dict(F=md["F"][0], Q=md["Q"][0], H=md["H"][0], R=md["R"][0], x0=md["x0"], P0=md["P0"])
    with pytest.raises(dkf.NotSPDError, match=r"^KalmanFilter: .*P0 not SPD") as info:
        dkfm.KalmanFilter(**{**args, "P0": -md["P0"]})
    assert info.value.matrix == "P0" and info.value.status == -5 and info.value.step is None
    with pytest.raises(dkf.NonFiniteError, match="x0 not finite"):
        dkfm.KalmanFilter(**{**args, "x0": np.array([0.0, np.nan, 0.0])})
    with pytest.raises(dkf.CapacityError, match="DKF_MAX_DIM"):
        n = dkfm.MAX_DIM + 1
        dkfm.KalmanFilter(F=np.eye(n), Q=np.eye(n), H=np.ones((1, n)), R=np.eye(1),
                          x0=np.zeros(n), P0=np.eye(n))
    with pytest.raises(ValueError, match="KalmanFilter: P0 must be"):
        dkfm.KalmanFilter(**{**args, "P0": np.eye(4)})
    with pytest.raises(ValueError, match="KalmanFilter: R must be"):
        dkfm.KalmanFilter(**{**args, "R": np.eye(3)})
    with pytest.raises(ValueError, match="differ in length"):
        dkfm.KalmanFilter(**{**args, "F": md["F"], "Q": np.stack([md["Q"][0]] * 2)})
    with pytest.raises(TypeError, match="x0 must be an array of real numbers"):
        dkfm.KalmanFilter(**{**args, "x0": ["a", "b", "c"]})


def test_error_message_names_the_step_and_phase():
    md = rand_model(np.random.default_rng(4), 2, 1, 5)
    kf = dkf.KalmanFilter(F=md["F"], Q=md["Q"], H=md["H"], R=md["R"], x0=md["x0"], P0=md["P0"])
    Y = md["Y"].copy()
    Y[3, 0] = np.inf
    with pytest.raises(dkf.NonFiniteError) as info:
        kf.filter(Y)
    msg = str(info.value)
    assert msg.startswith("KalmanFilter.filter, step 3: ")
    assert dkf._dkf_double._status_str(-4) in msg and "update: y not finite" in msg


def test_converted_inputs(mod):
    """Other real dtypes and sequences are converted; results equal those
    from arrays of the module's dtype."""
    dkfm, dt = mod
    md = rand_model(np.random.default_rng(5), 2, 1, 1)
    args = {k: md[k][0] if k in "FQHR" else md[k] for k in ("F", "Q", "H", "R", "x0", "P0")}
    a = dkfm.KalmanFilter(**{k: v.astype(dt) for k, v in args.items()})
    b = dkfm.KalmanFilter(**{k: v.astype(dt).astype(np.longdouble).tolist() for k, v in args.items()})
    a.update(np.array([2.0], dtype=dt))
    b.update([2])
    assert a.x.tobytes() == b.x.tobytes() and a.P.tobytes() == b.P.tobytes()
    c = dkfm.KalmanFilter(**{k: np.asfortranarray(v.astype(dt)) for k, v in args.items()})
    c.update(np.array([[2.0]], dtype=np.float16))  # (m, 1) is accepted too
    assert a.x.tobytes() == c.x.tobytes()
