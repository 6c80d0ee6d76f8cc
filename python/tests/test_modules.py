"""The two builds of the core in one process: dkf (double) and dkf.float32
(float) are separate extension modules that export no dkf_* symbol, and
both can be used side by side."""

import shutil
import subprocess

import numpy as np
import pytest

import dkf
import dkf.float32
from conftest import ROOT, rand_model


def test_two_modules_two_real_types():
    assert dkf.dtype == "float64" and dkf.float32.dtype == "float32"
    assert dkf.KalmanFilter is not dkf.float32.KalmanFilter
    assert dkf._dkf_double.__file__ != dkf._dkf_float.__file__
    assert dkf.MAX_DIM == dkf.float32.MAX_DIM == 48


@pytest.mark.parametrize("name", ["_dkf_double", "_dkf_float"])
def test_no_core_symbol_is_exported(name):
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("nm (binutils) is not installed: the symbol check is skipped")
    import importlib

    path = importlib.import_module(f"dkf.{name}").__file__
    out = subprocess.run([nm, "-D", "--defined-only", path], check=True,
                         capture_output=True, text=True).stdout
    names = [line.split()[-1] for line in out.splitlines() if line.strip()]
    assert f"PyInit_{name}" in names
    leaked = [s for s in names if s.startswith("dkf_") or s.startswith("dkf__")]
    assert leaked == []


def test_interleaved_use_in_one_process():
    """Steps of a float64 and a float32 filter interleaved: each gives what
    it gives alone, and they agree to float precision (|d| <= 1e-4: the
    float32 filter's rounding, ~1e-7 relative per step on this stable
    model, with room for 50 steps)."""
    md = rand_model(np.random.default_rng(6), 4, 2, 50)
    args = {k: md[k] for k in ("F", "Q", "H", "R", "x0", "P0")}
    d, f = dkf.KalmanFilter(**args), dkf.float32.KalmanFilter(**args)
    Xd, Pd = dkf.KalmanFilter(**args).filter(md["Y"])
    Xf, Pf = dkf.float32.KalmanFilter(**args).filter(md["Y"])
    for t in range(50):
        for kf in (d, f):
            kf.predict(F=md["F"][t], Q=md["Q"][t])
            kf.update(md["Y"][t], H=md["H"][t], R=md["R"][t])
        assert d.x.tobytes() == Xd[t].tobytes() and f.x.tobytes() == Xf[t].tobytes()
        assert d.P.tobytes() == Pd[t].tobytes() and f.P.tobytes() == Pf[t].tobytes()
    assert Xf.dtype == np.float32 and Xd.dtype == np.float64
    assert np.max(np.abs(Xf - Xd)) <= 1e-4 and np.max(np.abs(Pf - Pd)) <= 1e-4


def test_properties_are_copies(mod):
    dkfm, dt = mod
    md = rand_model(np.random.default_rng(7), 3, 1, 1)
    kf = dkfm.KalmanFilter(F=md["F"][0], Q=md["Q"][0], H=md["H"][0], R=md["R"][0],
                           x0=md["x0"], P0=md["P0"])
    x, P = kf.x, kf.P
    assert x.shape == (3,) and P.shape == (3, 3) and x.dtype == dt and P.dtype == dt
    x[:] = 99.0
    P[:] = 99.0
    assert not np.any(kf.x == 99.0) and not np.any(kf.P == 99.0)
    assert kf.n == 3 and kf.m_max == 1


def test_version_is_the_headers():
    """dkf.__version__ is the version dkf/version.h states (pyproject.toml reads it there)."""
    import re
    text = (ROOT / "include" / "dkf" / "version.h").read_text()
    parts = [re.search(r"#define DKF_VERSION_%s (\d+)" % k, text).group(1)
             for k in ("MAJOR", "MINOR", "PATCH")]
    assert dkf.__version__ == ".".join(parts)
