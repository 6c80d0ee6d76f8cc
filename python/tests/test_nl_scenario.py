"""dkf.run_scenario over seed 001's nonlinear cases against dkf-run.

Built-in model families run dkf-run's own C model code (dkf.builtin_model),
so every shipped vector file gives dkf-run's document bit for bit, in double
(DKF_RUN) and in float (DKF_RUN_FLOAT). Expression models run through
dkf.expr_model (sympy and numpy, not muparser): they agree with dkf-run to
the tolerance of docs/decisions.md item 75, not bit for bit. Without the
environment variables the comparisons are skipped with a message.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any, Dict, List, Tuple

import numpy as np
import pytest

import dkf
import dkf.float32

from conftest import ROOT, VECTORS
from test_scenario import dkf_run, dkf_run_float_path, rel, same

NL_FILTERS = ["nertsf", "nertsif", "dnertsf", "dnertsif", "cf_dnertsf", "df_dnertsif", "df_ckf",
              "df_dnertsif_joint"]
BUILTIN = [VECTORS / "infofusion" / name
           for name in ("nertsif.json", "dnertsif_single.json", "df_dnertsif.json")]
EXPR = sorted((ROOT / "scenarios").glob("nl_*.json"))
# Expression models against dkf-run (decision 75): every number within RTOL
# times the largest magnitude of its output key over the run.
RTOL = {"double": 1e-8, "float": 1e-3}


def cases(path: Path) -> List[Tuple[Path, int]]:
    with open(path, encoding="utf-8") as f:
        return [(path, c) for c in range(len(json.load(f)["cases"]))]


BUILTIN_CASES = [pc for p in BUILTIN for pc in cases(p)]
EXPR_CASES = [pc for p in EXPR for pc in cases(p)]


def arg(scn: Path) -> str:
    """A shipped file relative to the root (the tests run there), another as it is."""
    return rel(scn) if ROOT in scn.parents else str(scn)


def compare(mod: Any, scn: Path, case: int, filt: str, out: Path, exe: "str | None") -> Any:
    """dkf-run's document, or None after checking that Python refuses what dkf-run refuses."""
    r = dkf_run(arg(scn), filt, out, "--case", str(case), exe=exe)
    if r.returncode == 2:
        with pytest.raises(ValueError):
            mod.run_scenario(arg(scn), filter=filt, case=case)
        return None
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        return json.load(f)


@pytest.mark.parametrize("filt", NL_FILTERS)
@pytest.mark.parametrize("scn,case", BUILTIN_CASES, ids=lambda v: getattr(v, "stem", str(v)))
def test_builtin_families_equal_dkf_run(scn: Path, case: int, filt: str, tmp_path: Path,
                                        monkeypatch) -> None:
    monkeypatch.chdir(ROOT)
    expected = compare(dkf, scn, case, filt, tmp_path / "o.json", None)
    if expected is not None:
        same(dkf.run_scenario(rel(scn), filter=filt, case=case), expected)


FLOAT_CASES = [(VECTORS / "infofusion" / "nertsif.json", 0, f) for f in NL_FILTERS[:5]] + [
    (VECTORS / "infofusion" / "dnertsif_single.json", 1, "cf_dnertsf"),
    (VECTORS / "infofusion" / "df_dnertsif.json", 0, "df_dnertsif"),
    (VECTORS / "infofusion" / "df_dnertsif.json", 3, "df_dnertsif_joint"),
    (VECTORS / "infofusion" / "df_dnertsif.json", 3, "cf_dnertsf"),
    (VECTORS / "infofusion" / "df_dnertsif.json", 4, "df_ckf")]


@pytest.mark.parametrize("scn,case,filt", FLOAT_CASES,
                         ids=["%s-%d-%s" % (p.stem, c, f) for p, c, f in FLOAT_CASES])
def test_float32_builtin_families_equal_float_dkf_run(scn: Path, case: int, filt: str,
                                                      tmp_path: Path, monkeypatch) -> None:
    exe = dkf_run_float_path()
    monkeypatch.chdir(ROOT)
    expected = compare(dkf.float32, scn, case, filt, tmp_path / "o.json", exe)
    assert expected is not None and expected["real"] == "float"
    same(dkf.float32.run_scenario(rel(scn), filter=filt, case=case), expected)


def close(got: Any, exp: Any, rtol: float) -> int:
    """got and exp alike (keys, lengths, strings, integers the same), every
    number of an output key within rtol times that key's largest magnitude;
    the count of numbers compared."""
    nums: Dict[str, List[Tuple[float, float]]] = {}

    def walk(a: Any, b: Any, path: str, key: str) -> None:
        if isinstance(a, dict):
            assert isinstance(b, dict) and sorted(a) == sorted(b), path
            for k in a:
                walk(a[k], b[k], "%s.%s" % (path, k), k)
        elif isinstance(a, list):
            assert isinstance(b, list) and len(a) == len(b), path
            for x, y in zip(a, b):
                walk(x, y, path, key)
        elif isinstance(a, float) or isinstance(b, float):
            nums.setdefault(path, []).append((float(a), float(b)))
        else:
            assert a == b and type(a) is type(b), "%s: %r != %r" % (path, a, b)

    walk(got, exp, "", "")
    for path, pairs in nums.items():
        v = np.array(pairs)
        assert np.all(np.isfinite(v)), path
        scale = max(float(np.max(np.abs(v[:, 1]))), 1e-300)
        err = float(np.max(np.abs(v[:, 0] - v[:, 1])))
        assert err <= rtol * scale, "%s: %.3g > %g x %.3g" % (path, err, rtol, scale)
    return sum(len(p) for p in nums.values())


@pytest.mark.parametrize("scn,case", EXPR_CASES, ids=lambda v: getattr(v, "stem", str(v)))
def test_expression_models_agree_with_dkf_run(scn: Path, case: int, tmp_path: Path,
                                              monkeypatch) -> None:
    """Not bit for bit (muparser and numpy round differently): within RTOL."""
    monkeypatch.chdir(ROOT)
    ran = 0
    for filt in NL_FILTERS:
        expected = compare(dkf, scn, case, filt, tmp_path / "o.json", None)
        if expected is not None:
            assert close(dkf.run_scenario(rel(scn), filter=filt, case=case), expected,
                         RTOL["double"]) > 100
            ran += 1
    assert ran >= 2


@pytest.mark.parametrize("scn,case,filt", [(EXPR[0], 0, "nertsif"), (EXPR[1], 1, "df_dnertsif"),
                                           (EXPR[1], 3, "df_ckf"), (EXPR[2], 0, "dnertsif")],
                         ids=["lin-nertsif", "mixed-df", "mixed-ckf", "radar-dnertsif"])
def test_float32_expression_models_agree_with_float_dkf_run(scn: Path, case: int, filt: str,
                                                            tmp_path: Path, monkeypatch) -> None:
    exe = dkf_run_float_path()
    monkeypatch.chdir(ROOT)
    expected = compare(dkf.float32, scn, case, filt, tmp_path / "o.json", exe)
    assert expected is not None
    close(dkf.float32.run_scenario(rel(scn), filter=filt, case=case), expected, RTOL["float"])


def test_tolerance_check_is_strict() -> None:
    """close() fails past the tolerance, and on any difference of structure."""
    assert close({"a": [1.0, 2.0]}, {"a": [1.0, 2.0 + 1e-9]}, 1e-8) == 2
    with pytest.raises(AssertionError):
        close({"a": [1.0, 2.0]}, {"a": [1.0, 2.0 + 1e-7]}, 1e-8)
    with pytest.raises(AssertionError):
        close({"a": [1.0]}, {"a": [1.0, 2.0]}, 1e-8)
    with pytest.raises(AssertionError):
        close({"case": "x"}, {"case": "y"}, 1e-8)


def test_expected_values_of_the_vectors() -> None:
    """Without dkf-run: the built-in families reproduce the vector file's
    own expected values (tests/vectors/infofusion/nertsif.json, its tolerance)."""
    path = VECTORS / "infofusion" / "nertsif.json"
    with open(path, encoding="utf-8") as f:
        doc = json.load(f)
    got = dkf.run_scenario(path, filter="nertsif")
    series = got["outputs"]["NERTSIF"]
    steps = doc["cases"][0]["steps"]
    compared = 0
    for j, t in enumerate(steps):
        for key, want in t.get("expected", {}).items():
            if key in series:
                np.testing.assert_allclose(np.array(series[key][j], dtype=float),
                                           np.array(want, dtype=float), rtol=1e-8, atol=1e-10)
                compared += 1
    assert compared >= len(steps) * 5


def test_builtin_model_is_dkf_runs_c_model() -> None:
    """builtin_model: a native model of the family's C code; the model keeps
    its C parameters alive; the same values as the family's equations."""
    xy = [-10.0, 25.0]
    md = dkf.builtin_model("s1_radar", sensor_xy=xy)
    assert md.native_model and (md.n, md.m, md.p, md.angles) == (4, 3, 1, [1])
    with open(VECTORS / "infofusion" / "dnertsif_single.json", encoding="utf-8") as f:
        case = json.load(f)["cases"][0]
    x0 = np.array(case["init"]["x0"], dtype=float)
    d0 = np.array(case["init"]["d0"], dtype=float)
    f = dkf.NERTS(md, x0, np.eye(4), kind="NERTSIF", d0=d0, Pd0=np.eye(1))
    del md  # the filter holds the model, the model its C parameters
    z = [np.hypot(x0[0] - xy[0], x0[2] - xy[1]), np.arctan2(x0[2] - xy[1], x0[0] - xy[0]),
         10 * d0[0]]
    f.step(z, Q=0.01 * np.eye(4), R=np.diag([0.04, 2e-4, 1e-6]))
    w = d0[0]
    F = np.array([[1, np.sin(w) / w, 0, -(1 - np.cos(w)) / w], [0, np.cos(w), 0, -np.sin(w)],
                  [0, (1 - np.cos(w)) / w, 1, np.sin(w) / w], [0, np.sin(w), 0, np.cos(w)]])
    np.testing.assert_allclose(f.x_pred, F @ x0, rtol=1e-12)
    lin = dkf.float32.builtin_model("lin_x_sin_d", A=np.eye(2), b=[1.0, 0.5], C=[[1.0, 0.0]],
                                    H=[[1.0]])
    assert (lin.n, lin.m, lin.p, lin.angles) == (2, 1, 1, [])
    stacked = dkf.builtin_model("s1_radar_stacked", sensor_xy=[[0.0, 0.0], [5.0, 5.0]])
    assert (stacked.m, stacked.angles) == (6, [1, 4])
    ckf = dkf.builtin_model("s1_ckf", sensor_xy=xy, omega_fixed=0.1, angles=[])
    assert (ckf.p, ckf.m, ckf.angles) == (0, 2, [])


@pytest.mark.parametrize("family,kwargs,match", [
    ("s2_radar", {}, "unknown family"),
    ("s1_radar", {}, "sensor_xy: missing"),
    ("s1_radar", {"sensor_xy": [1.0, 2.0], "n": 3}, "n = 4"),
    ("s1_ckf", {"sensor_xy": [1.0, 2.0]}, "omega_fixed: missing"),
    ("s1_radar", {"sensor_xy": [1.0, 2.0], "T": float("nan")}, "finite"),
    ("lin_x_sin_d", {"A": np.eye(2), "b": [1.0, 2.0], "C": [[1.0, 0.0]]}, "H: missing"),
    ("lin_x_sin_d", {"A": np.eye(2), "b": [1.0, 2.0, 3.0], "C": [[1.0, 0.0]], "H": [[1.0]]},
     "b: expected shape"),
    ("lin_x_sin_d", {"A": np.eye(2), "b": [1.0, 2.0], "C": [[1.0, 0.0]], "H": [[1.0]],
                     "angles": [1]}, "angles"),
])
def test_builtin_model_refusals(family: str, kwargs: Dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        dkf.builtin_model(family, **kwargs)


def test_model_failure_is_a_model_error() -> None:
    """A state at the radar (bearing undefined): the C callback fails, the
    step raises dkf.ModelError and leaves the filter untouched."""
    md = dkf.builtin_model("s1_radar", sensor_xy=[0.0, 0.0])
    f = dkf.NERTS(md, np.zeros(4), np.eye(4), kind="NERTSIF", d0=[0.1], Pd0=np.eye(1))
    x = f.x
    with pytest.raises(dkf.ModelError, match=r"model.h(_jac)? returned"):
        f.step([1.0, 0.0, 1.0], Q=np.eye(4), R=np.eye(3))
    np.testing.assert_array_equal(f.x, x)


def test_refusals(monkeypatch) -> None:
    monkeypatch.chdir(ROOT)
    single = rel(VECTORS / "infofusion" / "nertsif.json")
    with pytest.raises(ValueError, match="filter kf reads"):
        dkf.run_scenario(single, filter="kf")
    with pytest.raises(ValueError, match="needs a network case"):
        dkf.run_scenario(single, filter="df_dnertsif")
    with pytest.raises(ValueError, match="reads seed 001's nonlinear cases"):
        dkf.run_scenario(rel(VECTORS / "diffkf" / "ex1_single.json"), filter="nertsif")
    with pytest.raises(ValueError, match="filter df_ckf has no unknown input"):
        dkf.run_scenario(rel(VECTORS / "infofusion" / "df_dnertsif.json"), filter="df_ckf")
    with open(VECTORS / "infofusion" / "nertsif.json", encoding="utf-8") as f:
        doc = json.load(f)
    bad = copy.deepcopy(doc)
    bad["cases"][0]["model"]["family"] = "s1_radr"
    with pytest.raises(ValueError, match="unknown family"):
        dkf.run_scenario(bad, filter="nertsif")
    bad = copy.deepcopy(doc)
    bad["cases"][0]["model"]["Qx"] = [[1.0]]
    with pytest.raises(ValueError, match=r"model.Qx: unknown key"):
        dkf.run_scenario(bad, filter="nertsif")
    bad = copy.deepcopy(doc)
    bad["cases"][0]["steps"][1]["k"] = 5
    with pytest.raises(ValueError, match=r"steps\[1\].k"):
        dkf.run_scenario(bad, filter="nertsif")
    for filt in NL_FILTERS:
        assert filt in dkf.SUPPORTED_FILTERS


def test_sparse_weights_and_the_graph_of_w_equal_dkf_run(tmp_path: Path, monkeypatch) -> None:
    """A network case with W_sparse and no edges (the graph of W's links), and
    one with W dense and no edges: as dkf-run reads them."""
    with open(VECTORS / "infofusion" / "df_dnertsif.json", encoding="utf-8") as f:
        doc = json.load(f)
    case = doc["cases"][0]
    case["steps"] = case["steps"][:3]
    W = case["W"]
    sparse = copy.deepcopy(case)
    del sparse["W"], sparse["edges"]
    sparse["W_sparse"] = [[i, j, v] for i, row in enumerate(W) for j, v in enumerate(row) if v]
    dense = copy.deepcopy(case)
    del dense["edges"]
    for variant in (sparse, dense):
        scn = tmp_path / "net.json"
        scn.write_text(json.dumps({"cases": [variant]}))
        expected = compare(dkf, scn, 0, "df_dnertsif", tmp_path / "o.json", None)
        assert expected is not None
        got = dkf.run_scenario(str(scn), filter="df_dnertsif")
        same(got, expected)
        assert got["communication"]["edges"] == len(case["edges"])
