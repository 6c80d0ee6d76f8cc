"""The tools of tools/ that run the filters through this package (docs/decisions.md
item 74): each as a user runs it, with the checks its ctest made before."""

from __future__ import annotations

import json
import re
import runpy

import numpy as np
import pytest

import dkf
from conftest import ROOT

UIF = ROOT / "tools" / "uif_example.py"


def uif_main():
    return runpy.run_path(str(UIF), run_name="uif_example")["main"]


@pytest.mark.parametrize("real", ["double", "float"])
def test_uif_example_quick(real, tmp_path, capsys) -> None:
    """tools/uif_example.py --quick (10 runs) passes its own checks, the ones that do
    not depend on luck (estimability masks, exact zeros, bias flags, the RTSF refusal,
    finite values), in both real types; it writes its tables and run 0's scenarios."""
    args = ["--quick", "--no-plots", "--out", str(tmp_path)] + (
        ["--float32"] if real == "float" else [])
    assert uif_main()(args) == 0
    out = capsys.readouterr().out
    assert "CHECKS PASSED" in out and "FAILED" not in out
    assert out.count("check: ") == 7
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["runs"] == 10
    assert sorted(res["cases"]) == ["nrtsf", "nrtsf_df_sin", "nrtsf_df_zero", "rtsf_full"]
    for key in ("nrtsf_df_sin", "nrtsf", "rtsf_full", "rtsf_paper"):
        scn = json.loads((tmp_path / "work" / (key + ".json")).read_text())
        assert len(scn["steps"]) == (99 if key == "nrtsf" else 100)


def test_uif_example_refusal_is_the_documented_one(tmp_path, capsys) -> None:
    """The RTSF refusal that docs/results/uif-results.md quotes is the tool's."""
    assert uif_main()(["--runs", "1", "--no-plots", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    row = [ln for ln in (tmp_path / "tables.md").read_text().splitlines()
           if "| rtsf | 2 | refused |" in ln]
    assert len(row) == 1
    msg = re.search(r"dkf\.RankError: `([^`]+)`", row[0]).group(1)
    assert "rank" in msg
    doc = (ROOT / "docs" / "results" / "uif-results.md").read_text(encoding="utf-8")
    assert "`%s`" % msg in doc


def test_uif_example_estimates_are_run_scenarios(tmp_path, capsys) -> None:
    """The tool's numbers are dkf.run_scenario's on the files it writes (run 0)."""
    assert uif_main()(["--runs", "1", "--no-plots", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    res = json.loads((tmp_path / "results.json").read_text())
    scn = str(tmp_path / "work" / "rtsf_full.json")
    out = dkf.run_scenario(scn, filter="rtsf")["outputs"]["RTSF"]
    assert res["cases"]["rtsf_full"]["estimable"] == out["estimable"][0] == [2, 2, 2]
    with pytest.raises(dkf.RankError, match="rank"):
        dkf.run_scenario(str(tmp_path / "work" / "rtsf_paper.json"), filter="rtsf")


def test_uif_example_plots(tmp_path, capsys) -> None:
    pytest.importorskip("matplotlib", reason="matplotlib is not installed: the plots not tested")
    assert uif_main()(["--runs", "1", "--out", str(tmp_path)]) == 0
    assert "CHECKS PASSED" in capsys.readouterr().out
    for name in ("fig_uif_inputs.png", "fig_uif_states.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:4] == b"\x89PNG" and len(data) > 1000


def test_uif_example_fails_when_rtsf_is_not_refused(tmp_path, monkeypatch, capsys) -> None:
    """The exit status follows the refusal: an RTSF that ran on the paper's H fails."""
    main = uif_main()
    real = main.__globals__["run_filter"]
    ok = json.loads(json.dumps(real(dkf, "nrtsf_df", _first_scenario(main, "rtsf_paper"))))
    monkeypatch.setitem(main.__globals__, "run_filter",
                        lambda mod, filt, scn: ok if scn["name"] == "rtsf_paper"
                        else real(mod, filt, scn))
    assert main(["--runs", "1", "--no-plots", "--out", str(tmp_path)]) == 1
    assert "expected a refusal" in capsys.readouterr().err


def _first_scenario(main, key):
    g = main.__globals__
    case = [c for c in g["CASES"] if c[0] == key][0]
    d = g["inputs"](case[3])
    x, y = g["simulate"](np.random.default_rng(4), d, case[4])
    return g["scenario"](key, x, y, d, case[4], case[5])


def _printed(text: str):
    """A number as the docs print it (bold allowed) and half a unit of its last digit."""
    t = text.strip().strip("*")
    dec = len(t.split(".")[1]) if "." in t else 0
    return float(t), 0.5 * 10.0 ** -dec


def test_uif_results_page_is_the_tools_output(tmp_path, capsys) -> None:
    """docs/results/uif-results.md's accuracy table (200 runs) is the tool's output as
    printed: RMSE, the filter's sqrt(P) and NEES_x/n of every case."""
    assert uif_main()(["--no-plots", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    res = json.loads((tmp_path / "results.json").read_text())["cases"]
    doc = (ROOT / "docs" / "results" / "uif-results.md").read_text(encoding="utf-8")
    table = doc.split("## 2. Accuracy (200 runs", 1)[1].split("\n## ", 1)[0]
    rows = [[c.strip() for c in ln.strip("|").split("|")] for ln in table.splitlines()
            if ln.startswith("| ") and ("| RMSE |" in ln or "| filter √P |" in ln)]
    order = ["nrtsf_df_sin", "nrtsf_df_zero", "nrtsf", "rtsf_full"]
    assert len(rows) == 2 * len(order)
    for i, key in enumerate(order):
        c = res[key]
        for row, values in ((rows[2 * i], c["rmse_x"] + c["rmse_d"] + [c["nees_x_over_n"]]),
                            (rows[2 * i + 1], c["sqrtP_x"] + c["sqrtPd"])):
            assert len(row) >= 2 + len(values) and row[2 + len(values):] in ([], [""])
            for cell, v in zip(row[2:], values):
                want, tol = _printed(cell)
                assert abs(v - want) <= tol + 1e-12, (key, row[1], cell, v)
