"""dkf.run_scenario's graph filters (tw1, tw2, tw3 over the seed-003 network
layout) and the self-tuning fusion (fusion_selftune over seed 002's
weighted-fusion cases) against dkf-run: the same document, number for
number (DKF_RUN, DKF_RUN_FLOAT as in test_scenario.py; skipped without).

Every shipped network file is run whole (the 6-node vector's 30 steps, the
200-node vectors' 10 and 3). The self-tuning filter runs on seed 002's
vector (30 steps: the identifier, t_min = 50, keeps its guesses) and on
the first 120 of the 4000 steps ports/linux/tests/make_wf_cases.py
simulates (it accepts from t = 50 on and its guards change).
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import dkf
import dkf.float32

from conftest import ROOT, VECTORS
from test_scenario import dkf_run, dkf_run_float_path, rel, same

NETWORK = sorted((VECTORS / "uif").glob("s003_*.json"))
TW = ["tw1", "tw2", "tw3"]
SIX = VECTORS / "uif" / "s003_6node.json"
WF = VECTORS / "infofusion" / "s2_weighted_fusion.json"
LABEL = {"tw1": "alg1", "tw2": "alg2", "tw3": "alg3"}


def expected_of(scn: str, filt: str, out: Path, *extra: str, exe=None) -> dict:
    r = dkf_run(scn, filt, out, *extra, exe=exe)
    assert r.returncode == 0, r.stderr
    with open(out, encoding="utf-8") as f:
        return json.load(f)


def load(path: Path) -> dict:
    with open(path, encoding="utf-8") as f:
        return json.load(f)


@pytest.mark.parametrize("filt", TW)
@pytest.mark.parametrize("scn", NETWORK, ids=lambda p: p.stem)
def test_network_equals_dkf_run(scn: Path, filt: str, tmp_path: Path, monkeypatch) -> None:
    """Every shipped seed-003 file with every graph filter (the 200-node alg1 file has no
    weights: the library's uniform alpha and Metropolis W)."""
    monkeypatch.chdir(ROOT)
    expected = expected_of(rel(scn), filt, tmp_path / "o.json")
    got = dkf.run_scenario(rel(scn), filter=filt)
    same(got, expected)
    assert "communication" in got and ("eta" in got) == (filt == "tw3")
    assert "nees" in got["outputs"][LABEL[filt]]  # the files have truth: the metrics ran


def time_varying(doc: dict) -> dict:
    """Every matrix per step: F_prev, G_prev, Q_prev and the per-node H, R; model null."""
    tv = copy.deepcopy(doc)
    model = tv.pop("model")
    tv["model"] = None
    for t in tv["steps"]:
        t["inputs"].update({key + "_prev": model[key] for key in ("F", "G", "Q")})
        t["inputs"].update({key: model[key] for key in ("H", "R")})
    return tv


def sparse(doc: dict) -> dict:
    """The dense weights as [i, j, value] triplets."""
    sp = copy.deepcopy(doc)
    for key in ("W_consensus", "alpha_diffusion"):
        w = sp.pop(key)
        sp[key + "_sparse"] = [[i, j, v] for i, row in enumerate(w) for j, v in enumerate(row)
                               if v != 0.0]
    return sp


def old_letters(doc: dict) -> dict:
    """Seed 003's own letters: F, G, Q, R written A, B, Sv, Sw."""
    old = copy.deepcopy(doc)
    for obj in [old["model"]] + [t["inputs"] for t in old["steps"]]:
        for new, was in (("F", "A"), ("G", "B"), ("Q", "Sv"), ("R", "Sw")):
            if new in obj:
                obj[was] = obj.pop(new)
    return old


def default_weights(doc: dict) -> dict:
    d = copy.deepcopy(doc)
    del d["W_consensus"], d["alpha_diffusion"]
    return d


def max_degree_weights(doc: dict) -> dict:
    """Other weights than the file's: the max-degree ones for both alpha and W."""
    d = copy.deepcopy(doc)
    A = np.zeros((len(d["model"]["H"]),) * 2)
    for i, j in d["graph"]["edges"]:
        A[i, j] = A[j, i] = 1.0
    d["W_consensus"] = d["alpha_diffusion"] = dkf.graph_weights_max_degree(A).tolist()
    return d


FORMS = {"time_varying": time_varying, "sparse": sparse, "old_letters": old_letters,
         "default_weights": default_weights, "max_degree_weights": max_degree_weights}


@pytest.mark.parametrize("filt", TW)
@pytest.mark.parametrize("form", sorted(FORMS))
def test_network_forms(form: str, filt: str, tmp_path: Path) -> None:
    """The 6-node vector per step, with sparse weights, in the old letters, without weights
    (the library's uniform alpha and Metropolis W, which are the file's to the bit): the
    file's numbers; with other weights other numbers; each as dkf-run gives it."""
    doc = load(SIX)
    other = FORMS[form](doc)
    path = tmp_path / "net.json"
    path.write_text(json.dumps(other))
    expected = expected_of(str(path), filt, tmp_path / "o.json")
    got = dkf.run_scenario(str(path), filter=filt)
    same(got, expected)
    original = dkf.run_scenario(doc, filter=filt)["outputs"]
    if form == "max_degree_weights" and filt != "tw1":
        assert got["outputs"][LABEL[filt]]["x"] != original[LABEL[filt]]["x"]
    else:
        same(got["outputs"], original)


def test_network_options(tmp_path: Path, monkeypatch) -> None:
    """eta and metrics_only: dkf-run's --eta and --metrics-only."""
    monkeypatch.chdir(ROOT)
    six = rel(SIX)
    three = dkf.run_scenario(six, filter="tw3", eta=3)
    same(three, expected_of(six, "tw3", tmp_path / "o.json", "--eta", "3"))
    assert three["eta"] == 3
    assert three["outputs"]["alg3"]["x"] != dkf.run_scenario(six, filter="tw3")["outputs"][
        "alg3"]["x"]
    no_truth = load(SIX)
    for t in no_truth["steps"]:
        del t["truth"]
    path = tmp_path / "no_truth.json"
    path.write_text(json.dumps(no_truth))
    for filt in TW:
        got = dkf.run_scenario(six, filter=filt, metrics_only=True)
        same(got, expected_of(six, filt, tmp_path / "o.json", "--metrics-only"))
        assert "x" not in got["outputs"][LABEL[filt]] and "mse_x" in got["outputs"][LABEL[filt]]
        # without truth: the gaps (tw2, tw3) or nothing at all (tw1)
        got = dkf.run_scenario(str(path), filter=filt, metrics_only=True)
        same(got, expected_of(str(path), filt, tmp_path / "o.json", "--metrics-only"))
        assert ("outputs" in got) == (filt != "tw1")


def test_network_refusals() -> None:
    """What dkf-run refuses before it runs (tests/cases' bad_tw_* files, made here), and the
    options of other filters; these need no dkf-run."""
    doc = load(SIX)
    ex1 = VECTORS / "diffkf" / "ex1_single.json"
    s004 = VECTORS / "uif" / "s004_rtsf.json"
    for scn, kw, match in ((s004, {"filter": "tw2"}, "graph: missing key .filter tw2 needs"),
                           (ex1, {"filter": "tw3"}, "steps: missing key .filter tw3 reads"),
                           (SIX, {"filter": "tw2", "eta": 3}, "eta 3: only for tw3"),
                           (ex1, {"filter": "kf", "metrics_only": True}, "metrics_only")):
        with pytest.raises(ValueError, match=match):
            dkf.run_scenario(scn, **kw)

    def refused(edit, match: str, filters=TW) -> None:
        d = copy.deepcopy(doc)
        edit(d)
        for filt in filters:
            with pytest.raises(ValueError, match=match):
                dkf.run_scenario(d, filter=filt)

    refused(lambda d: d.pop("eta"), "eta: missing key", ["tw3"])
    refused(lambda d: d["graph"]["edges"].__setitem__(3, [2, 9]),
            r"graph.edges\[3\]: node index out of range")
    refused(lambda d: d["graph"]["edges"].__setitem__(3, [2, 2]), "not a simple undirected")
    refused(lambda d: d["W_consensus"][0].__setitem__(3, 0.1),
            r"W_consensus: entry \(0, 3\) is not a link")
    # not doubly stochastic: refused for every filter, as dkf-run binds both weights
    refused(lambda d: d["W_consensus"][0].__setitem__(0, d["W_consensus"][0][0] + 0.25),
            "W_consensus: not doubly stochastic")
    refused(lambda d: d["alpha_diffusion"][1].__setitem__(1, d["alpha_diffusion"][1][1] - 0.5),
            "alpha_diffusion: not row-stochastic")
    refused(lambda d: d.__setitem__("W_consensus_sparse", [[0, 0, 1.0]]),
            "not allowed together with W_consensus")
    refused(lambda d: d["model"].__setitem__("R", d["model"]["R"][:5]),
            r"model.R: expected a list of 6 matrices")
    refused(lambda d: d["steps"][1]["inputs"]["y"].pop(), r"steps\[1\].inputs.y")
    refused(lambda d: d["steps"][0]["inputs"].__setitem__("H", d["model"]["H"]),
            r"steps\[0\].inputs.H: also given as model.H")
    refused(lambda d: d["model"].pop("H"), "model.H: missing key")
    refused(lambda d: d["model"].__setitem__("A", d["model"]["F"]), "old letters beside")


def test_network_bad_files_as_dkf_run(tmp_path: Path) -> None:
    """ports/linux/tests/make_steps_cases.py's seed-003 inputs with tw3 (it reads all a
    network file has: the graph, both weights, eta): run where dkf-run runs them (the same
    numbers), refused where it refuses them before it runs (but a covariance's symmetry,
    which this runner leaves to the core's SPD checks)."""
    gen = tmp_path / "gen"
    subprocess.run([sys.executable, str(ROOT / "ports" / "linux" / "tests" /
                                        "make_steps_cases.py"), str(VECTORS / "uif"), str(gen)],
                   check=True, capture_output=True)
    files = sorted(p for p in gen.glob("*.json") if "tw" in p.name)
    assert len(files) >= 15
    ran = 0
    for path in files:
        r = dkf_run(str(path), "tw3", tmp_path / "o.json")
        if r.returncode == 2 and "not symmetric" not in r.stderr:
            with pytest.raises(ValueError):
                dkf.run_scenario(str(path), filter="tw3")
        elif r.returncode == 0:
            same(dkf.run_scenario(str(path), filter="tw3"), load(tmp_path / "o.json"))
            ran += 1
        else:
            assert r.returncode == 2, r.stderr
    assert ran >= 3


@pytest.fixture(scope="module")
def wf_long(tmp_path_factory) -> Path:
    """The first 120 steps of make_wf_cases.py's simulated seed-002 run, and its case of the
    wrong form."""
    out = tmp_path_factory.mktemp("wf")
    subprocess.run([sys.executable, str(ROOT / "ports" / "linux" / "tests" / "make_wf_cases.py"),
                    str(VECTORS), str(out)], check=True, capture_output=True)
    doc = load(out / "wf_long.json")
    c = doc["cases"][0]
    c["steps"], c["x_true"] = c["steps"][:120], c["x_true"][:121]
    (out / "wf_120.json").write_text(json.dumps(doc))
    return out


def test_selftune_equals_dkf_run(wf_long: Path, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(ROOT)
    same(dkf.run_scenario(rel(WF), filter="fusion_selftune"),
         expected_of(rel(WF), "fusion_selftune", tmp_path / "o.json"))
    path = str(wf_long / "wf_120.json")
    got = dkf.run_scenario(path, filter="fusion_selftune")
    same(got, expected_of(path, "fusion_selftune", tmp_path / "o.json"))
    ser = got["outputs"]["FUSION_SELFTUNE"]
    assert ser["a_hat"][0] == [0.0, 0.0] and ser["a_hat"][-1] != [0.0, 0.0]  # accepted
    assert len(set(ser["guard"])) > 1
    bad = str(wf_long / "bad_wf_selftune_form.json")
    assert dkf_run(bad, "fusion_selftune", tmp_path / "o.json").returncode == 2
    with pytest.raises(ValueError, match="observer form"):
        dkf.run_scenario(bad, filter="fusion_selftune")
    doc = load(WF)
    doc["cases"][0]["H"][2] = [[1.0, 1.0, 0.0, 0.0]]
    with pytest.raises(ValueError, match=r"H\[2\]: filter fusion_selftune needs every H_i"):
        dkf.run_scenario(doc, filter="fusion_selftune")


FLOAT_CASES = [(p, f) for p in NETWORK for f in TW] + [(WF, "fusion_selftune")]


@pytest.mark.parametrize("scn,filt", FLOAT_CASES,
                         ids=["%s-%s" % (c[0].stem, c[1]) for c in FLOAT_CASES])
def test_float32_equals_float_dkf_run(scn: Path, filt: str, tmp_path: Path,
                                      monkeypatch) -> None:
    exe = dkf_run_float_path()
    monkeypatch.chdir(ROOT)
    expected = expected_of(rel(scn), filt, tmp_path / "o.json", exe=exe)
    assert expected["real"] == "float"
    same(dkf.float32.run_scenario(rel(scn), filter=filt), expected)


def test_float32_selftune_long_and_options(wf_long: Path, tmp_path: Path, monkeypatch) -> None:
    exe = dkf_run_float_path()
    path = str(wf_long / "wf_120.json")
    same(dkf.float32.run_scenario(path, filter="fusion_selftune"),
         expected_of(path, "fusion_selftune", tmp_path / "o.json", exe=exe))
    monkeypatch.chdir(ROOT)
    six = rel(SIX)
    same(dkf.float32.run_scenario(six, filter="tw3", eta=4, metrics_only=True),
         expected_of(six, "tw3", tmp_path / "o.json", "--eta", "4", "--metrics-only", exe=exe))


def test_default_weights_are_the_librarys(mod) -> None:
    """graph_weights_uniform / _metropolis: the defaults dkf-run takes, by their formulas."""
    m, dt = mod
    A = np.zeros((4, 4))
    for i, j in ((0, 1), (1, 2), (2, 3), (1, 3)):
        A[i, j] = A[j, i] = 1.0
    deg = A.sum(axis=1)
    U = m.graph_weights_uniform(A)
    M = m.graph_weights_metropolis(A)
    assert U.dtype == dt and U.shape == (4, 4)
    for i in range(4):
        for j in range(4):
            link = i == j or A[i, j]
            assert U[i, j] == (dt(1) / dt(deg[i] + 1) if link else 0)
            if i != j:
                assert M[i, j] == (dt(1) / dt(1 + max(deg[i], deg[j])) if link else 0)
    np.testing.assert_allclose(M.sum(axis=0), 1, rtol=0, atol=4 * np.finfo(dt).eps)
    np.testing.assert_allclose(M.sum(axis=1), 1, rtol=0, atol=4 * np.finfo(dt).eps)
    assert (M == M.T).all()
    D = m.graph_weights_max_degree(A)
    assert D[0, 1] == dt(1) / dt(4) and D[0, 0] == dt(1) - dt(1) / dt(4)
    with pytest.raises(dkf.GraphError):
        m.graph_weights_metropolis(np.triu(A))  # not symmetric
