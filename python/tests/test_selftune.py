"""dkf.SelfTuning (dkf/selftune.h) and the self-tuning fusion of seed 002
end to end (dkf.SelfTuning feeding dkf.WeightedFusion), as
tests/test_selftune.c and tests/test_wfusion_selftune.c check them: the
noise autocovariance against its closed form, the model of the true
parameters, convergence to the optimal fusion on a fixed-seed run,
filter() against its loop, and failures that leave the identifier as it
was."""

import numpy as np
import pytest

import dkf
from conftest import same_bits

# The example: (1 - 1.5 q^-1 + 0.56 q^-2) s = (1 + 0.4 q^-1) w(t-1),
# sigma_w^2 = 0.8; (1 - 0.7 q^-1 + 0.5 q^-2) eta = xi(t-1), sigma_xi^2 = 0.3;
# y_i = s + eta + v_i, sigma_vi^2 = 0.1 i, L = 5.
A_TRUE, C_TRUE, SW2, SXI2 = (-1.5, 0.56), 0.4, 0.8, 0.3
P_KNOWN, SV2 = (-0.7, 0.5), (0.1, 0.2, 0.3, 0.4, 0.5)
NX, NL = 4, 5


def identifier(m):
    return m.SelfTuning(L=NL, sigma_v2=SV2, p=P_KNOWN, sigma_xi2=SXI2)


def simulate(seed, T):
    """T steps of the example in float64: the signal s and the sensors' Y (T, L)."""
    rng = np.random.default_rng(seed)
    w, xi = np.sqrt(SW2) * rng.normal(size=T + 2), np.sqrt(SXI2) * rng.normal(size=T + 2)
    v = np.sqrt(np.array(SV2)) * rng.normal(size=(T, NL))
    s, eta = np.zeros(T + 2), np.zeros(T + 2)
    for t in range(2, T + 2):
        s[t] = -A_TRUE[0] * s[t - 1] - A_TRUE[1] * s[t - 2] + w[t - 1] + C_TRUE * w[t - 2]
        eta[t] = -P_KNOWN[0] * eta[t - 1] - P_KNOWN[1] * eta[t - 2] + xi[t - 1]
    return s[2:], (s + eta)[2:, None] + v


def test_noise_autocov_closed_form(mod):
    m, dt = mod
    r = identifier(m).noise_autocov()
    p1, p2 = P_KNOWN
    ref = np.zeros(6)
    ref[0] = (1 + p2) * SXI2 / ((1 - p2) * ((1 + p2) ** 2 - p1 * p1))
    ref[1] = -p1 * ref[0] / (1 + p2)
    for k in range(2, 6):
        ref[k] = -p1 * ref[k - 1] - p2 * ref[k - 2]
    assert r.dtype == dt and r.shape == (6,)
    assert np.max(np.abs(r - ref)) / ref[0] <= (1e-6 if dt == np.float32 else 1e-14)


def test_model_of_the_true_parameters(mod):
    """The seed's Phi and Gamma Qe Gamma^T from the true a, c_1, sigma_w^2."""
    m, dt = mod
    f = m.SelfTuning(L=NL, sigma_v2=SV2, p=P_KNOWN, sigma_xi2=SXI2, a0=A_TRUE, c0=C_TRUE,
                     sigma_w2_0=SW2)
    F, Q = f.model()
    G = np.array([[1, 0], [0.4, 0], [0, 1], [0, 0]])
    Phi = np.array([[1.5, 1, 0, 0], [-0.56, 0, 0, 0], [0, 0, 0.7, 1], [0, 0, -0.5, 0]])
    tol = 1e-6 if dt == np.float32 else 1e-15
    assert F.shape == (NX, NX) and f.n == NX
    assert np.max(np.abs(F - Phi)) <= tol
    assert np.max(np.abs(Q - G @ np.diag([SW2, SXI2]) @ G.T)) <= tol
    e = f.estimate()
    assert e["t"] == 0 and e["t_accepted"] == 0 and not e["ready"] and e["guard"] == 1


def test_self_tuning_fusion_converges(mod):
    """tests/test_wfusion_selftune.c's run in Python: per step the
    identifier takes the five measurements, its accepted model drives the
    local filters and the scalar-weight fusion, beside the optimal fusion on
    the true model. Its bounds: the gap's RMS over t in [3000, 4000] below
    0.05 and a fifth of its RMS over [50, 500]; the MSE over [1000, 4000]
    within 5 % of the optimal; the weights within 0.005 at the end."""
    m, dt = mod
    T = 4000
    s, Y = simulate(2003, T)
    ident = identifier(m)
    F_true, Q_true = m.SelfTuning(L=NL, sigma_v2=SV2, p=P_KNOWN, sigma_xi2=SXI2, a0=A_TRUE,
                                  c0=C_TRUE, sigma_w2_0=SW2).model()
    H, Hs = np.array([[1.0, 0.0, 1.0, 0.0]]), np.array([1.0, 0.0, 0.0, 0.0])
    Hl, Rl = [H] * NL, [np.array([[v]]) for v in SV2]
    opt = m.WeightedFusion(np.zeros(NX), 10 * np.eye(NX), Hs, m=[1] * NL)
    st = m.WeightedFusion(np.zeros(NX), 10 * np.eye(NX), Hs, m=[1] * NL)
    gap, e_opt, e_st = np.zeros(T), np.zeros(T), np.zeros(T)
    for t in range(T):
        y = list(Y[t, :, None])
        ident.update(Y[t])
        F, Q = ident.model()
        opt.step(F_true, Q_true, Hl, Rl, y=y)
        st.step(F, Q, Hl, Rl, y=y)
        s_opt, s_st = opt.fuse_scalar()[0], st.fuse_scalar()[0]
        gap[t], e_opt[t], e_st[t] = s_st - s_opt, s_opt - s[t], s_st - s[t]
    rms = lambda a: float(np.sqrt(np.mean(a * a)))  # noqa: E731
    early, late = rms(gap[49:500]), rms(gap[2999:])
    mse_opt, mse_st = np.mean(e_opt[999:] ** 2), np.mean(e_st[999:] ** 2)
    assert late < 0.05 and late < early / 5, (early, late)
    assert abs(mse_st - mse_opt) < 0.05 * mse_opt, (mse_st, mse_opt)
    assert np.max(np.abs(st.w - opt.w)) < 0.005
    e = ident.estimate()
    assert e["t"] == T and e["t_accepted"] > 0
    assert np.max(np.abs(e["a"] - np.array(A_TRUE))) < 0.1


def test_filter_equals_its_loop(mod):
    m, dt = mod
    _, Y = simulate(7, 300)
    a, b = identifier(m), identifier(m)
    A, C, S = a.filter(Y)
    assert A.shape == (300, 2) and C.shape == (300,) and S.dtype == dt
    for t in range(300):
        b.update(Y[t])
        e = b.estimate()
        assert same_bits(A[t], e["a"]) and C[t] == e["c1"] and S[t] == e["sigma_w2"], t
    assert same_bits(a.autocov(), b.autocov()) and a.estimate()["t"] == 300


def test_failures_leave_the_identifier_as_it_was(mod):
    m, _ = mod
    _, Y = simulate(8, 80)
    f = identifier(m)
    f.filter(Y[:60])
    state = lambda: (f.autocov().tobytes(), repr(f.estimate()))  # noqa: E731
    want = state()
    bad_y = Y[60].copy()
    bad_y[2] = np.nan
    with pytest.raises(dkf.NonFiniteError, match=r"^SelfTuning.update: .*y not finite") as info:
        f.update(bad_y)
    assert info.value.matrix == "y" and state() == want
    Yb = Y[60:].copy()
    Yb[5, 1] = np.inf
    with pytest.raises(dkf.NonFiniteError, match=r"^SelfTuning.filter, step 5: ") as info:
        f.filter(Yb)
    assert info.value.step == 5 and state() == want
    with pytest.raises(ValueError):
        f.update(Y[60][:3])
    assert state() == want
    with pytest.raises(dkf.ArgError, match="outside the limits"):
        m.SelfTuning(L=NL, sigma_v2=SV2, na=5)
    with pytest.raises(dkf.ArgError):
        m.SelfTuning(L=NL, sigma_v2=SV2, p=(-2.5, 1.6))  # an unstable P
