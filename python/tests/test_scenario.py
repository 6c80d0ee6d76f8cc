"""dkf.run_scenario against dkf-run: the same document, number for number.

The C runner is located through the environment variable DKF_RUN (the
path of a built dkf-run; tools/run_tests.sh sets it when the double build
has one); without it the comparisons are skipped with a message. The tests
that need no dkf-run (refusals, the old letters) always run.
"""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

import dkf
import dkf.float32

from conftest import ROOT, VECTORS

# Every canonical-layout file the repository ships.
CANONICAL = sorted((VECTORS / "diffkf").glob("*.json")) + [ROOT / "scenarios" / "demo_cv2d.json"]
FILTERS = list(dkf.SUPPORTED_FILTERS)


def built_exe(var: str, what: str) -> str:
    """The executable environment variable var names; the test is skipped without it."""
    path = os.environ.get(var)
    if not path:
        pytest.skip("%s is not set (the path of %s): no comparison with it" % (var, what))
    if not os.access(path, os.X_OK):
        pytest.fail("%s=%s is not an executable" % (var, path))
    return path


def dkf_run_path() -> str:
    return built_exe("DKF_RUN", "a built dkf-run")


def dkf_run_float_path() -> str:
    return built_exe("DKF_RUN_FLOAT", "a dkf-run built with DKF_REAL=float")


def dkf_run(scenario: str, filt: str, out: Path, *extra: str,
            exe: "str | None" = None) -> "subprocess.CompletedProcess[str]":
    return subprocess.run([exe or dkf_run_path(), "--filter", filt, "--quiet", "--output",
                           str(out), *extra, scenario], capture_output=True, text=True,
                          check=False)


def same(a, b, path: str = "") -> None:
    """a and b equal: the same keys, lists, strings, and every number the
    same double (the sign of a zero too)."""
    if not path and json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True):
        return  # one text: every float's repr, which names its double, is the same
    if isinstance(a, dict):
        assert isinstance(b, dict), path
        assert sorted(a) == sorted(b), "%s: keys %s != %s" % (path, sorted(a), sorted(b))
        for key in a:
            same(a[key], b[key], "%s.%s" % (path, key))
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), "%s: list lengths" % path
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, "%s[%d]" % (path, i))
    elif isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, (int, float)) and isinstance(b, (int, float)), path
        assert float(a).hex() == float(b).hex(), "%s: %r != %r" % (path, a, b)
    else:
        assert a == b and type(a) is type(b), "%s: %r != %r" % (path, a, b)


def rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


@pytest.mark.parametrize("filt", FILTERS)
@pytest.mark.parametrize("scn", CANONICAL, ids=lambda p: p.stem)
def test_equals_dkf_run(scn: Path, filt: str, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(ROOT)
    out = tmp_path / "out.json"
    r = dkf_run(rel(scn), filt, out)
    if r.returncode == 2:  # a refusal of the file for this filter: Python refuses it too
        with pytest.raises(ValueError):
            dkf.run_scenario(rel(scn), filter=filt)
        return
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        expected = json.load(f)
    same(dkf.run_scenario(rel(scn), filter=filt), expected)


LIF = VECTORS / "infofusion" / "lif_central_fusion.json"
WF = VECTORS / "infofusion" / "s2_weighted_fusion.json"


def test_generated_weighted_fusion_case(tmp_path: Path) -> None:
    """A scenario of tools/make_wf_scenario.py (t and y only, 3 sensors): as dkf-run."""
    scn = tmp_path / "wf.json"
    subprocess.run([sys.executable, str(ROOT / "tools" / "make_wf_scenario.py"), "--steps",
                    "40", "--sensors", "3", "--seed", "5", "--out", str(scn)], check=True)
    for filt in ("local_kf", "fusion_steady", "central_kf"):
        r = dkf_run(str(scn), filt, tmp_path / "o.json")
        assert r.returncode == 0, r.stderr
        with open(tmp_path / "o.json", encoding="utf-8") as f:
            same(dkf.run_scenario(str(scn), filter=filt), json.load(f))


def lif_path() -> Path:
    return LIF


@pytest.mark.parametrize("filt", ["local_kf", "fusion_scalar", "fusion_matrix", "fusion_steady",
                                  "central_kf", "kf", "info"])
def test_weighted_fusion_case_equals_dkf_run(filt: str, tmp_path: Path, monkeypatch) -> None:
    """Seed 002's vector with the wfusion filters run from Python (fusion_selftune:
    test_scenario_network.py), and the linear estimators on it."""
    monkeypatch.chdir(ROOT)
    out = tmp_path / "out.json"
    r = dkf_run(rel(WF), filt, out)
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        expected = json.load(f)
    same(dkf.run_scenario(rel(WF), filter=filt), expected)
LIF_CASES = [c.get("name", "") for c in json.loads(LIF.read_text(encoding="utf-8"))["cases"]]


@pytest.mark.parametrize("filt", ["kf", "info"])
@pytest.mark.parametrize("case", range(len(LIF_CASES)))
def test_cases_layout_equals_dkf_run(case: int, filt: str, tmp_path: Path, monkeypatch) -> None:
    """Every case of the cases-layout vector, by index and by name, and in the old letter C."""
    monkeypatch.chdir(ROOT)
    out = tmp_path / "out.json"
    r = dkf_run(rel(LIF), filt, out, "--case", str(case))
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        expected = json.load(f)
    assert "case" in expected
    same(dkf.run_scenario(rel(LIF), filter=filt, case=case), expected)
    if LIF_CASES[case]:
        by_name = dkf.run_scenario(rel(LIF), filter=filt, case=LIF_CASES[case])
        same(by_name, expected)
    doc = json.loads(LIF.read_text(encoding="utf-8"))
    for c in doc["cases"]:
        c["C"] = c.pop("H")
    same(dkf.run_scenario(doc, filter=filt, case=case, name=rel(LIF)), expected)


UIF_FILES = sorted((VECTORS / "uif").glob("s004_*.json"))


@pytest.mark.parametrize("filt", ["rtsf", "nrtsf_df", "nrtsf"])
@pytest.mark.parametrize("scn", UIF_FILES, ids=lambda p: p.stem)
def test_steps_layout_equals_dkf_run(scn: Path, filt: str, tmp_path: Path, monkeypatch) -> None:
    """Every seed-004 vector with every UIF filter: equal where dkf-run runs it, refused
    where it refuses."""
    monkeypatch.chdir(ROOT)
    out = tmp_path / "out.json"
    r = dkf_run(rel(scn), filt, out)
    if r.returncode == 2:
        with pytest.raises(ValueError):
            dkf.run_scenario(rel(scn), filter=filt)
        return
    if r.returncode == 3:  # a filter call failed: the same call fails from Python
        assert "rank condition" in r.stderr
        with pytest.raises(dkf.RankError):
            dkf.run_scenario(rel(scn), filter=filt)
        return
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        same(dkf.run_scenario(rel(scn), filter=filt), json.load(f))


def per_step(doc: dict) -> dict:
    """The seed-004 model written per step: F, G, Q as *_prev (k >= 1), H, D, R at k."""
    tv = copy.deepcopy(doc)
    model = tv.pop("model")
    tv["model"] = None
    for t in tv["steps"]:
        for key in ("H", "D", "R"):
            if key in model:
                t["inputs"][key] = model[key]
        if t["k"] >= 1:
            for key in ("F", "G", "Q"):
                t["inputs"][key + "_prev"] = model[key]
    return tv


def old_steps_letters(doc: dict) -> dict:
    """Seed 004 in the paper's letters: F, H, D written A, C, H."""
    old = copy.deepcopy(doc)
    for obj in [old["model"]] + [t["inputs"] for t in old["steps"]]:
        for new, was in (("F", "A"), ("H", "C"), ("D", "H")):
            for suffix in ("", "_prev"):
                if new + suffix in obj:
                    obj["tmp_" + was + suffix] = obj.pop(new + suffix)
        for key in [k for k in obj if k.startswith("tmp_")]:
            obj[key[4:]] = obj.pop(key)
    return old


@pytest.mark.parametrize("form", ["per_step", "old_letters"])
@pytest.mark.parametrize("name,filt", [("s004_rtsf", "rtsf"), ("s004_nrtsf_df", "nrtsf_df"),
                                       ("s004_nrtsf", "nrtsf")])
def test_steps_layout_forms(name: str, filt: str, form: str, tmp_path: Path) -> None:
    """The model given per step, and the old letters: the constant model's output, as dkf-run
    gives it."""
    with open(VECTORS / "uif" / (name + ".json"), encoding="utf-8") as f:
        doc = json.load(f)
    other = per_step(doc) if form == "per_step" else old_steps_letters(doc)
    path = tmp_path / "tv.json"
    path.write_text(json.dumps(other))
    r = dkf_run(str(path), filt, tmp_path / "o.json")
    assert r.returncode == 0, r.stderr
    with open(tmp_path / "o.json", encoding="utf-8") as f:
        expected = json.load(f)
    got = dkf.run_scenario(str(path), filter=filt)
    same(got, expected)
    same(got["outputs"], dkf.run_scenario(doc, filter=filt)["outputs"])


def test_every_shipped_file_and_filter_compared(monkeypatch, tmp_path: Path) -> None:
    """The comparison above is not vacuous: dkf-run runs most pairs."""
    monkeypatch.chdir(ROOT)
    ran = sum(dkf_run(rel(s), f, tmp_path / "o.json").returncode == 0
              for s in CANONICAL for f in FILTERS)
    assert ran >= 19


def test_dict_and_run_and_options(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.chdir(ROOT)
    scn = rel(VECTORS / "diffkf" / "ex1_single.json")
    with open(scn, encoding="utf-8") as f:
        doc = json.load(f)
    # a dict gives the file's numbers; the name is the caller's
    same(dkf.run_scenario(doc, filter="askf", name=scn), dkf.run_scenario(scn, filter="askf"))
    # --d00 / --Pd00-scale
    r = dkf_run(scn, "otskf", tmp_path / "o.json", "--d00", "0.5,-0.5", "--Pd00-scale", "3")
    assert r.returncode == 0, r.stderr
    with open(tmp_path / "o.json", encoding="utf-8") as f:
        same(dkf.run_scenario(scn, filter="otskf", d00=[0.5, -0.5], Pd00_scale=3.0), json.load(f))
    # a Monte-Carlo file: run 1 of runs
    runs = copy.deepcopy(doc)
    y, truth = runs.pop("y"), runs.pop("truth", None)
    y2 = copy.deepcopy(y)
    y2["values"] = [[v + 0.25 for v in row] for row in y2["values"]]
    runs["runs"] = [{"y": y}, {"y": y2}]
    if truth is not None:
        runs["runs"][0]["truth"] = truth
    path = tmp_path / "runs.json"
    path.write_text(json.dumps(runs))
    r = dkf_run(str(path), "kf", tmp_path / "o.json", "--run", "1")
    assert r.returncode == 0, r.stderr
    with open(tmp_path / "o.json", encoding="utf-8") as f:
        one = json.load(f)
    same(dkf.run_scenario(str(path), filter="kf", run=1), one)
    assert one["outputs"]["KF"]["xf"] != dkf.run_scenario(str(path), filter="kf")["outputs"][
        "KF"]["xf"]


def old_letters(doc: dict) -> dict:
    """The canonical layout in the old letters: D written A."""
    old = copy.deepcopy(doc)
    for obj in [old["model"]] + old["model"].get("sensors", []):
        if "D" in obj:
            obj["A"] = obj.pop("D")
    return old


@pytest.mark.parametrize("name", ["ex1_single", "tv3_multi"])
def test_old_letters_read_as_the_new(name: str) -> None:
    with open(VECTORS / "diffkf" / (name + ".json"), encoding="utf-8") as f:
        doc = json.load(f)
    old = old_letters(doc)
    assert "A" in json.dumps(old["model"]) and '"D"' not in json.dumps(old["model"])
    same(dkf.run_scenario(old, filter="dkf"), dkf.run_scenario(doc, filter="dkf"))
    mixed = copy.deepcopy(doc)
    target = mixed["model"]["sensors"][0] if "sensors" in mixed["model"] else mixed["model"]
    target["A"] = target["D"]
    with pytest.raises(ValueError, match="A and D"):
        dkf.run_scenario(mixed, filter="dkf")


def test_old_letters_equal_dkf_run(tmp_path: Path) -> None:
    with open(VECTORS / "diffkf" / "tv3_multi.json", encoding="utf-8") as f:
        old = old_letters(json.load(f))
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old))
    r = dkf_run(str(path), "dkf", tmp_path / "o.json")
    assert r.returncode == 0 and "deprecated letters" in r.stderr, r.stderr
    with open(tmp_path / "o.json", encoding="utf-8") as f:
        same(dkf.run_scenario(str(path), filter="dkf"), json.load(f))


def test_refusals() -> None:
    ex1 = VECTORS / "diffkf" / "ex1_single.json"
    with pytest.raises(ValueError, match="cases: missing key .filter nertsif reads seed 001"):
        dkf.run_scenario(ex1, filter="nertsif")
    with pytest.raises(ValueError, match="steps: missing key .filter tw1 reads the seed-003"):
        dkf.run_scenario(ex1, filter="tw1")
    with pytest.raises(ValueError, match="steps: filter kf reads the canonical or the cases"):
        dkf.run_scenario(VECTORS / "uif" / "s004_rtsf.json", filter="kf")
    with pytest.raises(ValueError, match="steps: missing key .filter rtsf"):
        dkf.run_scenario(ex1, filter="rtsf")
    with pytest.raises(ValueError, match="graph: filter rtsf needs a seed-004 file"):
        dkf.run_scenario(VECTORS / "uif" / "s003_6node.json", filter="rtsf")
    with pytest.raises(ValueError, match="a nonlinear case"):
        dkf.run_scenario(VECTORS / "infofusion" / "nertsif.json", filter="info")
    wf = VECTORS / "infofusion" / "s2_weighted_fusion.json"
    with pytest.raises(ValueError, match="not this weighted-fusion case"):
        dkf.run_scenario(wf, filter="dkf")
    with pytest.raises(ValueError, match="filter fusion_scalar reads a weighted-fusion case"):
        dkf.run_scenario(lif_path(), filter="fusion_scalar")
    with pytest.raises(ValueError, match="filter fusion_selftune reads a weighted-fusion case"):
        dkf.run_scenario(lif_path(), filter="fusion_selftune")
    lif = VECTORS / "infofusion" / "lif_central_fusion.json"
    with pytest.raises(ValueError, match="no case named 'nope'"):
        dkf.run_scenario(lif, filter="info", case="nope")
    with pytest.raises(ValueError, match=r"model.sensors\[0\].D: missing key"):
        dkf.run_scenario(lif, filter="dkf")
    with pytest.raises(ValueError, match="case given but the file has no cases"):
        dkf.run_scenario(ex1, filter="kf", case=0)
    with pytest.raises(ValueError, match="single-sensor"):
        dkf.run_scenario(VECTORS / "diffkf" / "tv3_multi.json", filter="askf")
    with pytest.raises(ValueError, match="only for askf and otskf"):
        dkf.run_scenario(ex1, filter="kf", d00=[0.0])
    with pytest.raises(ValueError, match="run 2"):
        dkf.run_scenario(ex1, filter="kf", run=2)
    with open(ex1, encoding="utf-8") as f:
        doc = json.load(f)
    doc["model"]["Fx"] = doc["model"]["F"]
    with pytest.raises(ValueError, match="model.Fx: unknown key"):
        dkf.run_scenario(doc, filter="kf")
    doc = json.loads(ex1.read_text())
    doc["init"]["P00"] = [[1.0, 2.0], [2.0, 1.0]] if len(doc["init"]["x00"]) == 2 else [[-1.0]]
    with pytest.raises((dkf.Error, ValueError)):
        dkf.run_scenario(doc, filter="kf")


def test_floats_compare_exactly() -> None:
    """same() is strict: one ulp, or a zero's sign, is a difference."""
    with pytest.raises(AssertionError):
        same({"a": [1.0]}, {"a": [math.nextafter(1.0, 2.0)]})
    with pytest.raises(AssertionError):
        same([0.0], [-0.0])
    with pytest.raises(AssertionError):
        same({"a": 1}, {"b": 1})


FLOAT_CASES = ([(p, f, ()) for p in CANONICAL for f in ("kf", "info", "dkf", "askf", "otskf")]
               + [(LIF, f, ()) for f in ("kf", "info")]
               + [(p, f, ()) for p in UIF_FILES for f in ("rtsf", "nrtsf_df", "nrtsf")]
               + [(WF, f, ()) for f in ("local_kf", "fusion_scalar", "fusion_matrix",
                                        "fusion_steady", "central_kf", "kf")])


@pytest.mark.parametrize("scn,filt,extra", FLOAT_CASES,
                         ids=["%s-%s" % (c[0].stem, c[1]) for c in FLOAT_CASES])
def test_float32_equals_float_dkf_run(scn: Path, filt: str, extra, tmp_path: Path,
                                      monkeypatch) -> None:
    """dkf.float32.run_scenario: the float build's dkf-run, number for number."""
    exe = dkf_run_float_path()
    monkeypatch.chdir(ROOT)
    out = tmp_path / "out.json"
    r = dkf_run(rel(scn), filt, out, *extra, exe=exe)
    if r.returncode == 2:
        with pytest.raises(ValueError):
            dkf.float32.run_scenario(rel(scn), filter=filt)
        return
    if r.returncode == 3:
        with pytest.raises(dkf.Error):
            dkf.float32.run_scenario(rel(scn), filter=filt)
        return
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        expected = json.load(f)
    assert expected["real"] == "float"
    same(dkf.float32.run_scenario(rel(scn), filter=filt), expected)

