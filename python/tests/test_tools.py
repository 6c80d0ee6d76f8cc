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


# ---- tools/seed001_table1.py: seed 001's Table 1 (the ctest seed001_table1_smoke before) ----

SEED001 = ROOT / "tools" / "seed001_table1.py"
SEED001_ROWS = ["CF-DNERTSF", "DF-DNERTSIF literal s=1", "DF-DNERTSIF N-scaled s=N",
                "DF-CKF literal s=1", "DF-CKF N-scaled s=N"]


def seed001_globals():
    return runpy.run_path(str(SEED001), run_name="seed001_table1")


def seed001_rows(out: str):
    """The table's rows as printed: the algorithm's name, then the values."""
    return [ln for ln in out.splitlines() if ln.split("  ")[0].strip() in SEED001_ROWS]


@pytest.mark.parametrize("real", ["double", "float"])
def test_seed001_table1_smoke(real, tmp_path, capsys) -> None:
    """tools/seed001_table1.py --runs 2 --tp 3 as a user runs it: every filter, the table
    printed (values not judged at 2 runs) and table1.json written, in both real types."""
    args = ["--runs", "2", "--tp", "3", "--no-verdict", "--no-plots", "--out-dir",
            str(tmp_path)] + (["--float32"] if real == "float" else [])
    assert seed001_globals()["main"](args) == 0
    out = capsys.readouterr().out
    assert "dkf's C filters in %s" % real in out
    rows = seed001_rows(out)
    assert [r.split("  ")[0].strip() for r in rows] == SEED001_ROWS
    res = json.loads((tmp_path / "table1.json").read_text())
    assert (res["runs"], res["tp"], res["real"]) == (2, 3, real)
    assert list(res["table"]) == SEED001_ROWS
    for t in res["table"].values():
        for key in ("ARMSE_pos", "ARMSE_vel", "DRMSE_pos", "DRMSE_vel", "se_ARMSE_pos",
                    "se_ARMSE_vel"):
            assert np.isfinite(t[key]) and t[key] > 0, key
        assert t["agrees_with_note"] in (True, False)


def test_seed001_table1_plots(tmp_path, capsys) -> None:
    """The ctest's pass condition: the last row, then the plots written."""
    pytest.importorskip("matplotlib", reason="matplotlib is not installed: the plots not tested")
    args = ["--runs", "2", "--tp", "3", "--no-verdict", "--out-dir", str(tmp_path)]
    assert seed001_globals()["main"](args) == 0
    assert re.search(r"DF-CKF N-scaled s=N.*plots:", capsys.readouterr().out, re.S)
    for name in ("seed001_rmse.png", "seed001_turn_rate.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:4] == b"\x89PNG" and len(data) > 1000


def test_seed001_table1_verdict(tmp_path, capsys) -> None:
    """Without --no-verdict the exit status follows the comparison with the reference:
    2 runs at T_p = 3 are far from the 50-run values at T_p = 45."""
    args = ["--runs", "2", "--tp", "3", "--no-plots", "--out-dir", str(tmp_path)]
    assert seed001_globals()["main"](args) == 1
    assert any(r.endswith("NO") for r in seed001_rows(capsys.readouterr().out))
    res = json.loads((tmp_path / "table1.json").read_text())
    assert not all(t["agrees_with_note"] for t in res["table"].values())


def test_seed001_table1_estimates_are_dkf_runs(tmp_path) -> None:
    """The tool's estimates of run 0 (T_p = 3) are dkf-run's on the same scenario, bit for
    bit: every filter's x and d."""
    from test_scenario import dkf_run, same

    g = seed001_globals()
    sm = g["sm"]
    est, _ = g["run_one"](dkf, 0, 3)
    x_hat0, X, Z = sm.draw_run(0)
    for name, flt, s, per_node in g["ALGS"]:
        case = sm.network_case("c", x_hat0, X, Z, 3, s, ckf=flt == "df_ckf")
        scn = tmp_path / "scn.json"
        scn.write_text(json.dumps(sm.scenario_file([case], "test")))
        p = dkf_run(str(scn), flt, tmp_path / "out.json")
        assert p.returncode == 0, p.stderr
        ref = json.loads((tmp_path / "out.json").read_text())["outputs"][flt.upper()]
        x, d = est[name]
        same((x if per_node else x[:, 0]).tolist(), ref["x"], name + ".x")
        if d is not None:
            same((d if per_node else d[:, 0]).tolist(), ref["d"], name + ".d")


def test_seed001_table1_is_the_designs_table(tmp_path, capsys) -> None:
    """docs/design/infofusion.md's Table 1 (50 runs, T_p = 45, double) is the tool's
    output as printed, and every row agrees with the reference."""
    assert seed001_globals()["main"](["--no-plots", "--out-dir", str(tmp_path)]) == 0
    capsys.readouterr()
    res = json.loads((tmp_path / "table1.json").read_text())
    doc = (ROOT / "docs" / "design" / "infofusion.md").read_text(encoding="utf-8")
    text = doc.split("## Seed 001's Table 1, reproduced", 1)[1].split("\n## ", 1)[0]
    rows = [[c.strip() for c in ln.strip("|").split("|")] for ln in text.splitlines()
            if ln.startswith("| DF-") or ln.startswith("| CF-")]
    assert len(rows) == len(SEED001_ROWS)
    for row, name in zip(rows, SEED001_ROWS):
        t = res["table"][name]
        assert t["agrees_with_note"], name
        cells = [c for pm in row[1:3] for c in pm.split("±")] + row[3:5]
        values = [t["ARMSE_pos"], t["se_ARMSE_pos"], t["ARMSE_vel"], t["se_ARMSE_vel"],
                  t["DRMSE_pos"], t["DRMSE_vel"]]
        for cell, v in zip(cells, values):
            want, tol = _printed(cell)
            assert abs(v - want) <= tol + 1e-12, (name, cell, v)
    spread = re.search(r"spread in ARMSE pos is at most ([0-9.]+)e-4", " ".join(text.split()))
    want, tol = _printed(spread.group(1))
    assert abs(max(t["node_spread_ARMSE_pos"] for t in res["table"].values()) * 1e4 - want) <= tol
