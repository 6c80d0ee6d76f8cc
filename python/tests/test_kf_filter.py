"""KalmanFilter.filter(): the same bits as the predict/update loop, its
missing-value rule (a NaN in Y) and its argument checks."""

import threading

import numpy as np
import pytest

from conftest import rand_model, same_bits


def make(dkfm, md, stacked):
    if stacked:
        return dkfm.KalmanFilter(F=md["F"], Q=md["Q"], H=md["H"], R=md["R"],
                                 x0=md["x0"], P0=md["P0"])
    return dkfm.KalmanFilter(F=md["F"][0], Q=md["Q"][0], H=md["H"][0], R=md["R"][0],
                             x0=md["x0"], P0=md["P0"])


def loop(kf, md, Y):
    X, P = [], []
    for t in range(len(Y)):
        kf.predict(F=md["F"][t], Q=md["Q"][t])
        kf.update(Y[t], H=md["H"][t], R=md["R"][t])
        X.append(kf.x)
        P.append(kf.P)
    return np.array(X), np.array(P)


@pytest.mark.parametrize("seed,n,m", [(1, 4, 2), (2, 6, 3), (3, 3, 5), (4, 1, 1)])
def test_filter_equals_loop_bit_for_bit(mod, seed, n, m):
    dkfm, dt = mod
    rng = np.random.default_rng(seed)
    T = 30
    md = rand_model(rng, n, m, T)
    Y = md["Y"].copy()
    Y[5] = np.nan          # no measurement at step 5
    Y[9, 0] = np.nan       # one component missing at step 9
    if m > 1:
        Y[12, 1:] = np.nan  # all but the first missing at step 12
    a = make(dkfm, md, stacked=True)
    b = make(dkfm, md, stacked=False)
    X, P = a.filter(Y)
    Xl, Pl = loop(b, md, Y)
    assert X.dtype == dt
    assert same_bits(X, Xl) and same_bits(P, Pl)
    assert same_bits(a.x, b.x) and same_bits(a.P, b.P)


def test_filter_overrides_equal_constructor_stack(mod):
    dkfm, _ = mod
    md = rand_model(np.random.default_rng(8), 4, 2, 20)
    a = make(dkfm, md, stacked=True)
    b = make(dkfm, md, stacked=False)
    Xa, Pa = a.filter(md["Y"])
    Xb, Pb = b.filter(md["Y"], F=md["F"], Q=md["Q"], H=md["H"], R=md["R"])
    assert same_bits(Xa, Xb) and same_bits(Pa, Pb)


def test_nan_row_is_a_predict_only(mod):
    dkfm, _ = mod
    md = rand_model(np.random.default_rng(9), 4, 2, 3)
    a, b = make(dkfm, md, stacked=False), make(dkfm, md, stacked=False)
    a.update(np.full(2, np.nan), H=md["H"][0], R=md["R"][0])
    assert same_bits(a.x, b.x) and same_bits(a.P, b.P)
    a.predict(F=md["F"][0], Q=md["Q"][0])
    a.update([np.nan, np.nan], H=md["H"][0], R=md["R"][0])
    b.predict(F=md["F"][0], Q=md["Q"][0])
    assert same_bits(a.x, b.x) and same_bits(a.P, b.P)


def test_partly_nan_row_updates_with_the_observed_rows(mod):
    """y = (nan, y1, y2): the update of rows 1, 2 of H and rows and columns
    1, 2 of R (the marginal of the noise), bit for bit."""
    dkfm, _ = mod
    md = rand_model(np.random.default_rng(10), 4, 3, 1)
    a, b = make(dkfm, md, stacked=False), make(dkfm, md, stacked=False)
    y = md["Y"][0].copy()
    y[0] = np.nan
    a.update(y)
    b.update(y[1:], H=md["H"][0][1:], R=md["R"][0][1:, 1:])
    assert same_bits(a.x, b.x) and same_bits(a.P, b.P)
    # and it did update: P shrank
    assert np.trace(a.P) < np.trace(make(dkfm, md, stacked=False).P)


def test_empty_Y(mod):
    dkfm, dt = mod
    md = rand_model(np.random.default_rng(11), 3, 2, 1)
    kf = make(dkfm, md, stacked=False)
    X, P = kf.filter(np.zeros((0, 2)))
    assert X.shape == (0, 3) and P.shape == (0, 3, 3) and X.dtype == dt


def test_stacked_model_needs_filter_or_overrides(mod):
    dkfm, _ = mod
    md = rand_model(np.random.default_rng(12), 3, 2, 5)
    kf = make(dkfm, md, stacked=True)
    with pytest.raises(ValueError, match="KalmanFilter.predict: F was given as a stack"):
        kf.predict()
    with pytest.raises(ValueError, match="KalmanFilter.update: H was given as a stack"):
        kf.update(md["Y"][0])
    with pytest.raises(ValueError, match="stack of 5, Y has T = 4"):
        kf.filter(md["Y"][:4])


def test_filter_leaves_the_inputs_alone(mod):
    dkfm, _ = mod
    md = rand_model(np.random.default_rng(13), 4, 2, 10)
    Y = md["Y"].copy()
    Y[3] = np.nan
    before = {k: v.copy() for k, v in md.items()}
    Yb = Y.copy()
    make(dkfm, md, stacked=True).filter(Y)
    assert same_bits(Y, Yb)
    for k in md:
        assert same_bits(md[k], before[k])


def test_filters_in_threads_give_the_sequential_bits(mod):
    """filter() releases the GIL: four threads, each with its own filter,
    get the bits one thread gets (no timing is asserted)."""
    dkfm, _ = mod
    mds = [rand_model(np.random.default_rng(20 + i), 6, 3, 400) for i in range(4)]
    want = [make(dkfm, md, stacked=True).filter(md["Y"]) for md in mds]
    got = [None] * 4

    def run(i):
        got[i] = make(dkfm, mds[i], stacked=True).filter(mds[i]["Y"])

    threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for w, g in zip(want, got):
        assert same_bits(w[0], g[0]) and same_bits(w[1], g[1])


def test_a_running_filter_refuses_other_threads(mod):
    """While filter() runs without the GIL, a call on the same object from
    another thread raises RuntimeError; a read that gets through sees the
    state before or after the run, never one in between."""
    dkfm, _ = mod
    md = rand_model(np.random.default_rng(30), 12, 6, 6000)
    kf = make(dkfm, md, stacked=True)
    before = kf.x.tobytes()
    want = make(dkfm, md, stacked=True).filter(md["Y"])
    got = []
    t = threading.Thread(target=lambda: got.append(kf.filter(md["Y"])))
    t.start()
    seen = set()
    refused = 0
    while t.is_alive():
        try:
            seen.add(kf.x.tobytes())
        except RuntimeError as e:
            assert "running filter() in another thread" in str(e)
            refused += 1
    t.join()
    after = kf.x.tobytes()
    assert seen <= {before, after}
    assert same_bits(got[0][0], want[0]) and after == want[0][-1].tobytes()
    print(f"{refused} calls refused while filter() ran")
