"""python -m dkf: simulate, run, plot."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import dkf
from dkf.__main__ import main

from test_simulate import TWO


def write(path: Path, doc) -> str:
    path.write_text(json.dumps(doc))
    return str(path)


def test_simulate_run_as_a_module(tmp_path: Path) -> None:
    model = write(tmp_path / "model.json", TWO)
    scn, out = tmp_path / "scn.json", tmp_path / "out.json"
    r = subprocess.run([sys.executable, "-m", "dkf", "simulate", model, "--steps", "12",
                        "--seed", "5", "-o", str(scn)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with open(scn, encoding="utf-8") as f:
        assert json.load(f) == dkf.simulate(TWO, 12, seed=5)  # floats written exactly
    r = subprocess.run([sys.executable, "-m", "dkf", "run", str(scn), "--filter", "dkf", "-o",
                        str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        assert json.load(f) == dkf.run_scenario(str(scn), filter="dkf")


def test_run_errors(tmp_path: Path, capsys) -> None:
    scn = write(tmp_path / "scn.json", dkf.simulate(TWO, 5, seed=1))
    out = str(tmp_path / "out.json")
    assert main(["run", scn, "--filter", "askf", "-o", out]) == 2
    assert "single-sensor" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "none.json"), "--filter", "kf", "-o", out]) == 2
    assert "none.json" in capsys.readouterr().err
    bad = dkf.simulate(TWO, 5, seed=1)
    bad["init"]["P00"] = [[1.0, 2.0], [2.0, 1.0]]  # not SPD: the core refuses it
    assert main(["run", write(tmp_path / "bad.json", bad), "--filter", "kf", "-o", out]) == 3
    assert "SPD" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["run", scn, "--filter", "nope", "-o", out])
    assert e.value.code == 2
    with pytest.raises(SystemExit):
        main(["simulate", scn, "-o", out])  # --steps missing


def test_plot_png(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib", reason="matplotlib is not installed: plot not tested")
    scn = write(tmp_path / "scn.json", dkf.simulate(TWO, 15, seed=2))
    out = str(tmp_path / "out.json")
    assert main(["run", scn, "--filter", "info", "-o", out]) == 0
    png = tmp_path / "x.png"
    assert main(["plot", out, "--scenario", scn, "-o", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10000


def test_plot_without_matplotlib(tmp_path: Path, monkeypatch, capsys) -> None:
    scn = write(tmp_path / "scn.json", dkf.simulate(TWO, 5, seed=2))
    out = str(tmp_path / "out.json")
    assert main(["run", scn, "--filter", "kf", "-o", out]) == 0
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib fails
    assert main(["plot", out, "-o", str(tmp_path / "x.png")]) == 2
    assert "needs matplotlib" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_plot_needs_estimates(tmp_path: Path, capsys) -> None:
    pytest.importorskip("matplotlib", reason="matplotlib is not installed: plot not tested")
    empty = write(tmp_path / "e.json", {"k": [1], "outputs": {}})
    assert main(["plot", empty, "-o", str(tmp_path / "x.png")]) == 2
    assert "no estimates" in capsys.readouterr().err


def test_plot_steps_layout(tmp_path: Path) -> None:
    """A steps-layout output (x, not xf) plots too, and its "k" from 0."""
    pytest.importorskip("matplotlib", reason="matplotlib is not installed: plot not tested")
    from conftest import VECTORS

    out = str(tmp_path / "out.json")
    assert main(["run", str(VECTORS / "uif" / "s004_rtsf.json"), "--filter", "rtsf", "-o",
                 out]) == 0
    png = tmp_path / "x.png"
    assert main(["plot", out, "-o", str(png)]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    # with the steps file's own truth (per step) beside the estimate
    from test_simulate import WITH_G

    scn = write(tmp_path / "g.json", dkf.simulate(WITH_G, 20, seed=1))
    assert main(["run", scn, "--filter", "nrtsf_df", "-o", out]) == 0
    assert main(["plot", out, "--scenario", scn, "-o", str(tmp_path / "g.png")]) == 0
    from dkf.__main__ import _truth

    t = _truth(json.loads(Path(scn).read_text()))
    assert t["k"] == list(range(0, 20)) and len(t["x"]) == 20
    assert _truth(dkf.simulate(TWO, 4, seed=1))["k"] == list(range(0, 6))


def test_run_options(tmp_path: Path) -> None:
    """--case, --d00, --Pd00-scale, --eta and --metrics-only reach run_scenario (dkf-run's
    options of those names)."""
    from conftest import VECTORS

    out = tmp_path / "o.json"
    ex1 = str(VECTORS / "diffkf" / "ex1_single.json")
    assert main(["run", ex1, "--filter", "askf", "--d00", "0.5,-0.5", "--Pd00-scale", "3",
                 "-o", str(out)]) == 0
    assert json.loads(out.read_text()) == dkf.run_scenario(ex1, filter="askf", d00=[0.5, -0.5],
                                                           Pd00_scale=3.0)
    assert json.loads(out.read_text()) != dkf.run_scenario(ex1, filter="askf")
    lif = str(VECTORS / "infofusion" / "lif_central_fusion.json")
    assert main(["run", lif, "--filter", "info", "--case", "0", "-o", str(out)]) == 0
    assert json.loads(out.read_text()) == dkf.run_scenario(lif, filter="info", case="0")

    six = str(VECTORS / "uif" / "s003_6node.json")
    assert main(["run", six, "--filter", "tw3", "--eta", "3", "--metrics-only", "-o",
                 str(out)]) == 0
    assert json.loads(out.read_text()) == dkf.run_scenario(six, filter="tw3", eta=3,
                                                           metrics_only=True)
    assert json.loads(out.read_text())["eta"] == 3
