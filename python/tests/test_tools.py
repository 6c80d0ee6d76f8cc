"""The tools of tools/ that run the filters through this package (docs/decisions.md
item 74): each as a user runs it, with the checks its ctest made before."""

from __future__ import annotations

import json
import re
import runpy
import subprocess
import sys

import numpy as np
import pytest

import dkf
from conftest import ROOT

UIF = ROOT / "tools" / "uif_example.py"
TW = ROOT / "tools" / "tw_example.py"
SEED002 = ROOT / "tools" / "seed002_example.py"


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
    """A number as the docs print it (bold allowed; 2.44e-6 too) and half a unit of its
    last digit."""
    t = text.strip().strip("*")
    mant, _, exp = t.lower().partition("e")
    dec = len(mant.split(".")[1]) if "." in mant else 0
    return float(t), 0.5 * 10.0 ** (int(exp or 0) - dec)


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


# ---- tools/tw_example.py ------------------------------------------------------------------

def tw_main():
    return runpy.run_path(str(TW), run_name="tw_example")["main"]


@pytest.fixture(scope="module")
def tw_quick(tmp_path_factory):
    """tools/tw_example.py --quick --no-plots in double: (exit status, stdout, out dir)."""
    out = tmp_path_factory.mktemp("tw-quick")
    res = subprocess.run([sys.executable, str(TW), "--quick", "--no-plots", "--out", str(out)],
                         capture_output=True, text=True, timeout=600)
    return res.returncode, res.stdout, out


def _tw_quick_checks(rc, out, outdir, real, plots):
    """What tw_example.py --quick must show: its own checks passed (finite metrics, the
    communication counts 14 / 18 / 28 eta, the gap to Alg 1 shrinking over the eta sweep,
    and the figures when drawn), its tables, results and run 0's scenario written."""
    assert rc == 0
    assert "CHECKS PASSED" in out and "FAILED" not in out
    assert out.count("check: ") == 4 + (3 if plots else 0)
    res = json.loads((outdir / "results.json").read_text())
    assert (res["real"], res["runs"], res["steps"], res["eta"]) == (real, 2, 60, 10)
    assert (res["N"], res["edges"]) == (200, 732)
    assert sorted(res["gap"], key=int) == ["1", "10", "100", "1000"]
    assert (outdir / "tables.md").read_text().startswith("# Seed-003 example")
    scn = json.loads((outdir / "work" / "run0.json").read_text())
    assert len(scn["steps"]) == 60 and scn["eta"] == 10


@pytest.mark.parametrize("real", ["double", "float"])
def test_tw_example_quick(real, tw_quick, tmp_path, capsys) -> None:
    """tools/tw_example.py --quick (2 runs x 60 steps, the short eta sweeps) passes its own
    checks in both real types, run as a user runs it (double) and through main (float)."""
    if real == "double":
        rc, out, outdir = tw_quick
    else:
        rc, outdir = tw_main()(["--quick", "--no-plots", "--float32", "--out", str(tmp_path)]), \
            tmp_path
        out = capsys.readouterr().out
    _tw_quick_checks(rc, out, outdir, real, plots=False)


def test_tw_example_plots(tmp_path, capsys) -> None:
    pytest.importorskip("matplotlib", reason="matplotlib is not installed: the plots not tested")
    rc = tw_main()(["--quick", "--out", str(tmp_path)])
    _tw_quick_checks(rc, capsys.readouterr().out, tmp_path, "double", plots=True)
    for name in ("fig_tw_gap_eta.png", "fig_tw_rmse_time.png", "fig_tw_eta_rmse.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:4] == b"\x89PNG" and len(data) > 1000


def test_tw_example_numbers_are_run_scenarios(tw_quick) -> None:
    """The tool's gap and communication are dkf.run_scenario's (metrics_only) on the vector
    file and on the run-0 file it writes."""
    _, _, outdir = tw_quick
    res = json.loads((outdir / "results.json").read_text())
    graph = ROOT / "tests" / "vectors" / "uif" / "s003_200node_alg1.json"
    out = dkf.run_scenario(graph, filter="tw3", eta=100, metrics_only=True)["outputs"]["alg3"]
    assert res["gap"]["100"]["vec_rule_max"] == max(out["gap_x_vec_rule"])
    assert res["gap"]["100"]["rel_norm_max"] == max(out["gap_x_rel_max"])
    for filt in ("tw1", "tw2", "tw3"):
        doc = dkf.run_scenario(outdir / "work" / "run0.json", filter=filt, metrics_only=True)
        assert res["communication"]["alg" + filt[-1]] == doc["communication"]


def test_graph_results_gap_table_is_the_tools_output(tw_quick) -> None:
    """docs/results/graph-results.md's gap table (Alg 3 -> Alg 1 on the vector file's 10
    steps, which do not depend on the run count) is the tool's output as printed, at the
    etas of --quick's sweep."""
    _, _, outdir = tw_quick
    gap = json.loads((outdir / "results.json").read_text())["gap"]
    doc = (ROOT / "docs" / "results" / "graph-results.md").read_text(encoding="utf-8")
    table = doc.split("## 2. Algorithm 3", 1)[1].split("\n\n¹", 1)[0]
    rows = {r[0]: r[1:4] for r in ([c.strip() for c in ln.strip("|").split("|")]
                                   for ln in table.splitlines() if ln.startswith("| "))}
    for eta in ("1", "10", "100", "1000"):
        g = gap[eta]
        for cell, v in zip(rows[eta], (g["vec_rule_max"], g["rel_norm_max"], g["rms"])):
            want, tol = _printed(cell)
            assert abs(v - want) <= tol * (1 + 1e-9), (eta, cell, v)


def test_tw_example_simulation_needs_no_package(tmp_path) -> None:
    """The network tests import tw_example's simulation with the system python3, which has
    no package: it imports without dkf and makes the scenario; main says it needs dkf."""
    code = (
        "import json, sys\n"
        "sys.modules['dkf'] = None  # import dkf fails\n"
        "sys.path.insert(0, sys.argv[1])\n"
        "import tw_example\n"
        "base = json.load(open(tw_example.DEFAULT_GRAPH))\n"
        "x, y, z = tw_example.simulate(base, 5, 3)\n"
        "scn = tw_example.scenario(base, x, y, z, 5, 10)\n"
        "assert len(scn['steps']) == 5 and len(scn['steps'][0]['inputs']['y']) == 200\n"
        "sys.exit(tw_example.main(['--quick', '--out', sys.argv[2]]))\n")
    res = subprocess.run([sys.executable, "-c", code, str(ROOT / "tools"), str(tmp_path)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "needs the Python package dkf" in res.stderr


# ---- tools/seed002_example.py -------------------------------------------------------------

SEED002_SMOKE = ["--runs", "4", "--steps", "10", "--long", "400", "--st-steps", "300"]


def seed002_main():
    return runpy.run_path(str(SEED002), run_name="seed002_example")["main"]


@pytest.mark.parametrize("real", ["double", "float"])
def test_seed002_example_smoke(real, tmp_path, capsys) -> None:
    """tools/seed002_example.py small (4 runs, a 400-step and a 300-step run), every
    filter: the steady values are judged (they do not depend on the run count) and agree
    with the paper's to 5 digits (the weights to 4) in both real types; the Monte-Carlo
    verdicts are not (--no-verdict); seed002.json holds every part."""
    args = SEED002_SMOKE + ["--no-verdict", "--no-plots", "--out-dir", str(tmp_path)] + (
        ["--float32"] if real == "float" else [])
    assert seed002_main()(args) == 0
    out = capsys.readouterr().out
    assert re.search(r"central +0\.48630 +0\.48630 +yes", out)
    for key in ("P_Sii", "w", "P_S0", "matrix", "central"):
        assert re.search(r"\n  %s .* yes\n" % key, out), key
    res = json.loads((tmp_path / "seed002.json").read_text())
    assert sorted(res) == ["long_run", "monte_carlo", "paper", "selftune", "steady"]
    assert (res["monte_carlo"]["runs"], res["long_run"]["steps"], res["selftune"]["steps"]) \
        == (4, 400, 300)
    assert len(res["monte_carlo"]["series"]["centralized"]["empirical"]) == 10


def test_seed002_example_plots(tmp_path, capsys) -> None:
    pytest.importorskip("matplotlib", reason="matplotlib is not installed: the plots not tested")
    assert seed002_main()(SEED002_SMOKE + ["--no-verdict", "--out-dir", str(tmp_path)]) == 0
    assert re.search(r"central +0\.48630 +0\.48630 +yes.*plots:", capsys.readouterr().out,
                     re.S)
    for name in ("seed002_variance.png", "seed002_selftune_params.png",
                 "seed002_selftune_gap.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:4] == b"\x89PNG" and len(data) > 1000


def test_seed002_example_exit_follows_the_verdicts(tmp_path, capsys) -> None:
    """Without --no-verdict a failed verdict is exit 1: 300 self-tuning steps are too few."""
    assert seed002_main()(SEED002_SMOKE + ["--no-plots", "--out-dir", str(tmp_path)]) == 1
    assert "FAILED: self-tuning gap shrinks" in capsys.readouterr().out


def test_weighted_fusion_steady_table_is_the_tools_output(tmp_path, capsys) -> None:
    """docs/design/weighted-fusion.md's steady-state rows (which do not depend on the run
    count) are the tool's values as printed."""
    assert seed002_main()(SEED002_SMOKE + ["--no-verdict", "--no-plots",
                                           "--out-dir", str(tmp_path)]) == 0
    capsys.readouterr()
    st = json.loads((tmp_path / "seed002.json").read_text())["steady"]
    doc = (ROOT / "docs" / "design" / "weighted-fusion.md").read_text(encoding="utf-8")
    table = doc.split("## The paper's example, reproduced", 1)[1].split("\n## ", 1)[0]
    rows = {r[0]: r[1].split() for r in ([c.strip() for c in ln.strip("|").split("|")]
                                         for ln in table.splitlines() if ln.startswith("| "))}
    for label, key in (("steady local P_Sii", "P_Sii"), ("steady scalar weights", "w"),
                       ("P_S0 (scalar-fused)", "P_S0"), ("H_s P0 H_sᵀ (matrix-fused)", "matrix"),
                       ("centralized KF (`central_kf`)", "central")):
        values = np.atleast_1d(st[key])
        assert len(rows[label]) == len(values), label
        for cell, v in zip(rows[label], values):
            want, tol = _printed(cell)
            assert abs(v - want) <= tol * (1 + 1e-9), (label, cell, v)
