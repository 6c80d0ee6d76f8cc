"""dkf.simulate: scenarios that dkf-run and dkf.run_scenario read, reproducible by seed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import dkf

from test_scenario import dkf_run, same

# Two position/velocity sensors, each with a drifting bias on its position
# channel (a random walk: B = 1), and a constant-velocity state.
TWO = {
    "model": {
        "F": [[1.0, 1.0], [0.0, 1.0]],
        "Q": [[0.01, 0.0], [0.0, 0.01]],
        "B": [[1.0]],
        "Rd": [[0.001]],
        "sensors": [
            {"H": [[1.0, 0.0], [0.0, 1.0]], "R": [[0.5, 0.0], [0.0, 0.2]],
             "D": [[1.0], [0.0]]},
            {"H": [[1.0, 0.0], [0.0, 1.0]], "R": [[0.3, 0.05], [0.05, 0.4]],
             "D": [[1.0], [0.0]]},
        ],
    },
    "init": {"x00": [0.0, 1.0], "P00": [[1.0, 0.0], [0.0, 1.0]]},
}

ONE = {
    "model": {
        "F": {"const": [[1.0, 1.0], [0.0, 1.0]]},
        "Q": {"per_k": [[[0.01 * (1 + k % 3), 0.0], [0.0, 0.01]] for k in range(12)]},
        "H": [[1.0, 0.0], [0.0, 1.0]],
        "R": [[0.5, 0.0], [0.0, 0.2]],
        "D": [[1.0], [0.5]],
        "B": [[0.9]],
        "Rd": [[0.01]],
    },
    "init": {"x00": [0.0, 1.0], "P00": [[1.0, 0.0], [0.0, 1.0]], "d00": [0.3],
             "Pd00": [[0.1]]},
}


def test_shape_and_seed() -> None:
    s = dkf.simulate(TWO, 20, seed=7)
    assert s["N"] == 20 and s["seed"] == 7
    assert len(s["y"]) == 2 and s["y"][0]["k"] == list(range(1, 22))
    assert np.array(s["y"][1]["values"]).shape == (21, 2)
    assert s["truth"]["k"] == list(range(0, 22))
    assert np.array(s["truth"]["x"]).shape == (22, 2)
    assert np.array(s["truth"]["d_stacked"]).shape == (22, 2)
    assert s["model"] == TWO["model"] and s["init"] == TWO["init"]
    assert dkf.simulate(TWO, 20, seed=7) == s
    assert dkf.simulate(TWO, 20, seed=8)["y"] != s["y"]
    # the truth follows the model: x_k - F x_{k-1} is the process noise, small here
    x = np.array(s["truth"]["x"])
    F = np.array(TWO["model"]["F"])
    assert np.abs(x[1:] - x[:-1] @ F.T).max() < 1.0
    # sensor 0's position channel carries its bias: y - H x - D d is the noise
    d = np.array(s["truth"]["d_stacked"])[1:, 0]
    y0 = np.array(s["y"][0]["values"])
    resid = y0[:, 0] - x[1:, 0] - d
    assert abs(resid.mean()) < 0.5 and 0.2 < resid.var() < 1.2


def test_refusals() -> None:
    with pytest.raises(ValueError, match="steps"):
        dkf.simulate(TWO, 0)
    with pytest.raises(ValueError, match="model"):
        dkf.simulate({"init": TWO["init"]}, 5)
    bad = json.loads(json.dumps(TWO))
    del bad["model"]["sensors"][0]["H"]
    with pytest.raises(ValueError, match=r"model.sensors\[0\].H: missing key"):
        dkf.simulate(bad, 5)
    short = json.loads(json.dumps(ONE))
    with pytest.raises(ValueError, match="Q.per_k.*k = 12"):
        dkf.simulate(short, 12)  # needs Q_0..Q_12


@pytest.mark.parametrize("model,filters", [(TWO, ["kf", "info", "dkf"]),
                                           (ONE, ["kf", "info", "dkf", "askf", "otskf"])],
                         ids=["two_sensors", "one_sensor"])
def test_loads_in_dkf_run_and_run_scenario(model, filters, tmp_path: Path) -> None:
    scn = tmp_path / "scn.json"
    scn.write_text(json.dumps(dkf.simulate(model, 10, seed=3)))
    for filt in filters:
        out = tmp_path / ("%s.json" % filt)
        r = dkf_run(str(scn), filt, out)
        assert r.returncode == 0, r.stderr
        with open(out, encoding="utf-8") as f:
            same(dkf.run_scenario(str(scn), filter=filt), json.load(f))


def test_model_from_a_file(tmp_path: Path) -> None:
    path = tmp_path / "model.json"
    path.write_text(json.dumps(ONE))
    assert dkf.simulate(str(path), 5, seed=1) == dkf.simulate(ONE, 5, seed=1)
    assert "d" in dkf.simulate(ONE, 5, seed=1)["truth"]


# An unknown input entering the state (G) and the measurement (D): seed 004's model.
WITH_G = {
    "model": {
        "F": [[0.9, 0.1], [0.0, 0.95]],
        "G": [[1.0], [0.5]],
        "Q": [[0.01, 0.0], [0.0, 0.01]],
        "H": [[1.0, 0.0], [0.0, 1.0]],
        "D": [[0.5], [1.0]],
        "R": [[0.04, 0.0], [0.0, 0.09]],
        "B": [[0.8]],
        "Rd": [[0.2]],
    },
    "init": {"x00": [1.0, -1.0], "P00": [[0.5, 0.0], [0.0, 0.5]]},
}


@pytest.mark.parametrize("feedthrough,filters", [(True, ["rtsf", "nrtsf_df"]),
                                                 (False, ["nrtsf"])],
                         ids=["with_D", "without_D"])
def test_with_G_is_a_steps_scenario(feedthrough, filters, tmp_path: Path) -> None:
    model = json.loads(json.dumps(WITH_G))
    if not feedthrough:
        del model["model"]["D"]
    s = dkf.simulate(model, 15, seed=11)
    assert [t["k"] for t in s["steps"]] == (list(range(0, 15)) if feedthrough
                                             else list(range(1, 16)))
    assert set(s["model"]) == ({"F", "G", "Q", "H", "D", "R"} if feedthrough
                               else {"F", "G", "Q", "H", "R"})
    assert set(s["steps"][3]["truth"]) == ({"x", "d"} if feedthrough else {"x", "d_prev"})
    scn = tmp_path / "scn.json"
    scn.write_text(json.dumps(s))
    for filt in filters:
        out = tmp_path / ("%s.json" % filt)
        r = dkf_run(str(scn), filt, out)
        assert r.returncode == 0, r.stderr
        with open(out, encoding="utf-8") as f:
            expected = json.load(f)
        same(dkf.run_scenario(str(scn), filter=filt), expected)


def test_with_G_the_input_estimate_tracks_the_truth() -> None:
    """The RTSF's input estimate follows the simulated input (the simulation means what it
    says): its error is well below the input's own spread."""
    s = dkf.simulate(WITH_G, 200, seed=3)
    out = dkf.run_scenario(s, filter="rtsf")["outputs"]["RTSF"]
    d_hat = np.array(out["d"]).reshape(-1)
    d = np.array([t["truth"]["d"] for t in s["steps"]]).reshape(-1)
    assert np.sqrt(np.mean((d_hat - d) ** 2)) < 0.5 * np.std(d)


def test_with_G_refusals() -> None:
    bad = json.loads(json.dumps(WITH_G))
    del bad["model"]["B"]
    with pytest.raises(ValueError, match="model.B: missing key"):
        dkf.simulate(bad, 5)
    bad = json.loads(json.dumps(WITH_G))
    bad["model"]["F"] = {"per_k": [WITH_G["model"]["F"]] * 10}
    with pytest.raises(ValueError, match="constant in time"):
        dkf.simulate(bad, 5)


def nl_model() -> dict:
    """The expression model of scenarios/nl_lin_x_sin_d_expr.json (seed 001's lin_x_sin_d),
    its input a random walk."""
    from conftest import ROOT

    case = json.loads((ROOT / "scenarios" / "nl_lin_x_sin_d_expr.json").read_text())["cases"][0]
    model = dict(case["model"], B=[[1.0]], Rd=[[0.01]])
    return {"model": model, "init": case["init"]}


def test_expression_model_runs_in_dkf_run(tmp_path: Path) -> None:
    s = dkf.simulate(nl_model(), 300, seed=9)
    case = s["cases"][0]
    assert [t["k"] for t in case["steps"]] == list(range(1, 301))
    assert "B" not in case["model"] and "Rd" not in case["model"]
    # x_k - f(x_{k-1}, d_{k-1}) is the process noise: its covariance is Q
    x, d = np.array(case["x_true"]), np.array(case["d_true"])
    f = np.stack([x[:-1, 0] + 0.1 * x[:-1, 1],
                  0.95 * x[:-1, 1] + 0.1 * x[:-1, 2] + 0.1 * np.sin(d[:-1, 0]),
                  0.9 * x[:-1, 2] + 0.05 * np.sin(d[:-1, 0])], axis=1)
    cov = np.cov((x[1:] - f).T)
    Q = np.array(case["model"]["Q"])
    assert np.allclose(np.diag(cov), np.diag(Q), rtol=0.3)
    scn = tmp_path / "nl.json"
    scn.write_text(json.dumps(s))
    r = dkf_run(str(scn), "nertsif", tmp_path / "o.json")
    assert r.returncode == 0, r.stderr
    out = json.loads((tmp_path / "o.json").read_text())
    xf = np.array(out["outputs"]["NERTSIF"]["x"])
    assert np.sqrt(np.mean((xf - x) ** 2)) < np.sqrt(np.mean(x ** 2))  # it tracks the truth


def test_expression_refusals() -> None:
    m = nl_model()
    m["model"]["expr"] = dict(m["model"]["expr"], g=["x1", "x3 + 0.5*d2", "x1 + x2 + d1"])
    with pytest.raises(ValueError, match=r"model.expr.g\[1\].*unknown variable or function 'd2'"):
        dkf.simulate(m, 5)
    m = nl_model()
    m["model"]["expr"] = dict(m["model"]["expr"], f=["x1 > 0 ? 1 : 0", "x2", "x3"])
    with pytest.raises(ValueError, match="arithmetic expressions only"):
        dkf.simulate(m, 5)
    m = nl_model()
    m["model"]["expr"] = dict(m["model"]["expr"], f=["__import__('os')", "x2", "x3"])
    with pytest.raises(ValueError, match="unknown"):
        dkf.simulate(m, 5)
