"""The guide's Python example runs as written (docs/guide/python.md)."""

import re

import numpy as np

from conftest import ROOT


def test_guide_example_runs():
    text = (ROOT / "docs" / "guide" / "python.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1
    env = {}
    exec(compile(blocks[0], "docs/guide/python.md", "exec"), env)
    assert env["X"].shape == (100, 2) and env["P"].shape == (100, 2, 2)
    # 101 steps of a constant-velocity track: the velocity estimate is near 1
    assert abs(env["X"][-1][1] - 1.0) < 0.2
    assert np.all(np.isfinite(env["P"]))
