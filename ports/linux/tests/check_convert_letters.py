#!/usr/bin/env python3
"""tools/convert_letters.py on an old file of every linear layout.

    check_convert_letters.py DKF_RUN VECTOR_DIR CASES_DIR OUTDIR

The old files are written here from the shipped vectors (in the library's
letters) with the letters of docs/reference/scenario-format.md's "Letters" table put
back, one layout each, and a time-varying seed-004 file (`A_prev`, ...), and
tests/cases/old_letter_A.json as it is. For each, the converter's output
must be
* byte for byte the shipped vector it came from (the shipped files are the
  converter's output: keys in place, numbers and strings as they were), the
  same bytes again from a second conversion;
* read by dkf-run with no notice on stderr, where the old file has one;
* run by dkf-run to the same output file, bit for bit, as the old file;
* left as it is by a conversion in place.
--indent 2 writes the same document indented. A file mixing the two
conventions is refused (exit 1) and nothing is written.
"""
import copy
import json
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "..", "tools"))
from convert_letters import layout, matrix_objects, rename  # noqa: E402
from make_steps_cases import time_varying_s004  # noqa: E402

CONVERT = os.path.join(HERE, "..", "..", "..", "tools", "convert_letters.py")

# The library's letter -> the old one, per layout, applied in this order
# (seed 004: H -> C before D -> H); each with its _prev form.
OLD = {
    "canonical": (("D", "A"),),
    "cases": (("H", "C"),),
    "steps": (("F", "A"), ("H", "C"), ("D", "H")),
    "network": (("F", "A"), ("G", "B"), ("Q", "Sv"), ("R", "Sw")),
}

# vector, dkf-run's options (each old letter of its layout read by the filter)
RUNS = [
    ("diffkf/ex1_single.json", ["--filter", "otskf"]),
    ("diffkf/ex3_multi.json", ["--filter", "dkf"]),
    ("infofusion/lif_central_fusion.json", ["--filter", "info", "--case", "cv4_3sensors"]),
    ("uif/s004_rtsf.json", ["--filter", "rtsf"]),
    ("uif/s003_6node.json", ["--filter", "tw1"]),
]


def compact(doc):
    return json.dumps(doc, separators=(",", ":")).encode()


def write_old(doc, path):
    """doc (in the library's letters) written to path in the old letters."""
    doc = copy.deepcopy(doc)
    rename(matrix_objects(doc, layout(doc)), OLD[layout(doc)])
    os.makedirs(os.path.dirname(path))
    with open(path, "wb") as f:
        f.write(compact(doc))


def read(path):
    with open(path, "rb") as f:
        return f.read()


def convert(*paths):
    return subprocess.run([sys.executable, CONVERT] + list(paths), capture_output=True, text=True)


def run(dkf_run, opts, directory, name):
    """dkf-run in directory on name (the output names the file as given):
    (output bytes, stderr)."""
    p = subprocess.run([dkf_run, "--quiet", "--output", "out.json"] + opts + [name],
                       cwd=directory, capture_output=True, text=True)
    assert p.returncode == 0, (directory, name, p.returncode, p.stderr)
    return read(os.path.join(directory, "out.json")), p.stderr


def check(dkf_run, out, tag, old_path, opts, expected=None):
    """Converts old_path; checks the bytes (expected: what the conversion
    must write), the notice and dkf-run's output."""
    olddir, newdir = os.path.join(out, tag, "old"), os.path.join(out, tag, "new")
    for d in (olddir, newdir):
        os.makedirs(d, exist_ok=True)
    name = os.path.basename(old_path)
    if not os.path.exists(os.path.join(olddir, name)):
        shutil.copy(old_path, olddir)
    new_path = os.path.join(newdir, name)
    p = convert(os.path.join(olddir, name), new_path)
    assert p.returncode == 0, (tag, p.returncode, p.stderr)
    if expected is not None:
        assert read(new_path) == expected, "%s: not the expected bytes" % tag
    again = os.path.join(out, tag, "again.json")
    assert convert(os.path.join(olddir, name), again).returncode == 0
    assert read(again) == read(new_path), "%s: a second conversion gave other bytes" % tag
    stamp = os.stat(new_path).st_mtime_ns
    assert convert(new_path).returncode == 0
    assert os.stat(new_path).st_mtime_ns == stamp, "%s: a converted file rewritten" % tag
    out_old, err_old = run(dkf_run, opts, olddir, name)
    out_new, err_new = run(dkf_run, opts, newdir, name)
    assert "deprecated letters" in err_old, (tag, err_old)
    assert err_new == "", (tag, err_new)
    assert out_old == out_new, "%s: dkf-run's output differs after the conversion" % tag
    print("%s: converted, %d output bytes identical, no notice" % (tag, len(out_new)))


def main():
    dkf_run, vdir, cases, out = sys.argv[1:5]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    for rel, opts in RUNS:
        shipped = read(os.path.join(vdir, rel))
        tag = os.path.splitext(os.path.basename(rel))[0]
        old = os.path.join(out, tag, "old", os.path.basename(rel))
        write_old(json.loads(shipped), old)
        check(dkf_run, out, tag, old, opts, shipped)
    with open(os.path.join(vdir, "uif", "s004_nrtsf_df.json")) as f:
        tv = time_varying_s004(json.load(f))
    old = os.path.join(out, "tv_nrtsf_df", "old", "tv.json")
    write_old(tv, old)
    check(dkf_run, out, "tv_nrtsf_df", old, ["--filter", "nrtsf_df"], compact(tv))
    check(dkf_run, out, "old_letter_A", os.path.join(cases, "old_letter_A.json"),
          ["--filter", "dkf"])
    indented = os.path.join(out, "indented.json")
    p = subprocess.run([sys.executable, CONVERT, "--indent", "2",
                        os.path.join(cases, "old_letter_A.json"), indented])
    converted = read(os.path.join(out, "old_letter_A", "new", "old_letter_A.json"))
    assert p.returncode == 0 and b'\n  "' in read(indented)
    assert json.loads(read(indented)) == json.loads(converted), "--indent changed the content"
    print("old_letter_A.json --indent 2: the same document, indented")
    mixed = os.path.join(out, "mixed.json")
    p = convert(os.path.join(cases, "mixed_letters.json"), mixed)
    assert p.returncode == 1 and "mixed" in p.stderr, (p.returncode, p.stderr)
    assert not os.path.exists(mixed)
    print("mixed_letters.json: refused (%s)" % p.stderr.strip())


if __name__ == "__main__":
    main()
