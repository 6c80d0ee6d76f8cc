"""python/examples/two_sensors.py: its checks hold and the guide's table is its output."""

from __future__ import annotations

import re
import runpy

from conftest import ROOT

SCRIPT = ROOT / "python" / "examples" / "two_sensors.py"


def load():
    return runpy.run_path(str(SCRIPT), run_name="two_sensors")


def test_checks_hold_and_exit_status(capsys) -> None:
    ex = load()
    assert ex["main"](["--no-plot"]) == 0
    out = capsys.readouterr().out
    assert "NO" not in out and out.count(": yes") == 3


def test_guide_table_is_the_scripts_output() -> None:
    ex = load()
    r = ex["run"](200, 4)
    text = (ROOT / "docs" / "guide" / "python.md").read_text(encoding="utf-8")
    section = text.split("## Worked example: two biased sensors", 1)[1].split("\n## ", 1)[0]
    rows = dict(re.findall(r"^\| ((?:KF|DKF)[^|]*?) \| ([0-9.]+) \|$", section, re.M))
    assert set(rows) == set(r["rmse"])
    for name, value in r["rmse"].items():
        assert rows[name] == "%.3f" % value, name
    assert all(holds for _, holds in ex["check"](r))


def test_a_failing_claim_exits_1(monkeypatch) -> None:
    """The exit status follows the checks: a claim made false fails the script."""
    ex = load()
    main = ex["main"]
    monkeypatch.setitem(main.__globals__, "check", lambda r: [("forced", False)])
    assert main(["--no-plot", "--steps", "20"]) == 1


def test_plots_written(tmp_path) -> None:
    import pytest

    pytest.importorskip("matplotlib", reason="matplotlib is not installed: the plots not tested")
    ex = load()
    assert ex["main"](["--steps", "30", "--out-dir", str(tmp_path)]) == 0
    for name in ("two_sensors_error.png", "two_sensors_bias.png"):
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG"
