"""The guide's Python example runs as written (docs/guide/python.md)."""

import re

import numpy as np
import pytest

from conftest import ROOT


def test_guide_example_runs():
    text = (ROOT / "docs" / "guide" / "python.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 3
    env = {}
    exec(compile(blocks[0], "docs/guide/python.md", "exec"), env)
    assert env["X"].shape == (100, 2) and env["P"].shape == (100, 2, 2)
    # 101 steps of a constant-velocity track: the velocity estimate is near 1
    assert abs(env["X"][-1][1] - 1.0) < 0.2
    assert np.all(np.isfinite(env["P"]))


def test_guide_simulate_example_runs():
    """The five lines of "simulate": a model of one's own, simulated and filtered."""
    text = (ROOT / "docs" / "guide" / "python.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    env = {}
    exec(compile(blocks[2], "docs/guide/python.md", "exec"), env)
    xf = np.array(env["out"]["outputs"]["KF"]["xf"])
    truth = np.array(env["scn"]["truth"]["x"])[1:51]
    assert xf.shape == (50, 2)
    # the filter tracks the simulated truth: its position error is below the sensor's noise
    assert np.sqrt(np.mean((xf[:, 0] - truth[:, 0]) ** 2)) < np.sqrt(0.5)



def test_guide_native_model_example_runs():
    """"Native models": the jit model's plain CKF follows the noiseless track
    (x_50 = [60, 1, -20, -0.5]), and computes no Jacobian of h (Hx stays 0)."""
    pytest.importorskip("numba", reason="numba is not installed (pip install numba)")
    text = (ROOT / "docs" / "guide" / "python.md").read_text(encoding="utf-8")
    env = {}
    exec(compile(re.findall(r"```python\n(.*?)```", text, re.S)[1], "docs/guide/python.md",
                 "exec"), env)
    assert env["model"].native_model and env["X"].shape == (50, 4)
    assert np.abs(env["X"][-1] - [60.0, 1.0, -20.0, -0.5]).max() < 1e-2
    assert not env["ckf"].Hx.any()
