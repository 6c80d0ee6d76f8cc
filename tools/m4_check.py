#!/usr/bin/env python3
"""Check the emulated-M4 node image against the host (tools/check_firmware.sh).

    tools/m4_check.py --dkf-run build/m4-host-float/ports/linux/dkf-run \\
        --float-image build/m4-float/dkf_m4_qemu.elf \\
        --double-image build/m4-double/dkf_m4_qemu.elf

Prints one "PASS: ..." or "FAIL: ..." line per check, then the table of
docs/results/footprint.md ("The image on an emulated Cortex-M4F"):
  bits      every golden vector (tests/vectors/diffkf/*.json) through
            tools/m4_run.sh on the float image, filters kf and dkf: the
            output equals the host float dkf-run's bit for bit (every
            number of every output array; the same keys and shapes)
  vector    the double image's dkf outputs match each vector at the
            vectors' tolerance (rel 1e-9, tests/vectors/diffkf/README.md)
  refused   a model above the image's capacity (n = 9; 5 sensors) exits 2,
            a filter failure (D = 0: rank) exits 3, as dkf-run's statuses; an
            input file cut short exits 2
  report    instructions per step, stack, flash and RAM of the DKF node
            (ex1_single: n = 4, m = 2, p = 2) and the KF (n = 4, m = 2) in
            float and double
Exit status 1 if any check failed.
"""
import argparse
import glob
import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VECTORS = os.path.join(ROOT, "tests", "vectors", "diffkf")
NODE_VECTOR = os.path.join(VECTORS, "ex1_single.json")

failed = 0


def report(ok, text):
    global failed
    print("%s: %s" % ("PASS" if ok else "FAIL", text))
    failed += 0 if ok else 1


def m4_run(image, real, filt, scenario, out=None, stats=None):
    cmd = [os.path.join(ROOT, "tools", "m4_run.sh"), "--image", image, "--real", real,
           "--filter", filt, "--quiet", scenario]
    if out:
        cmd[-1:-1] = ["--output", out]
    if stats:
        cmd[-1:-1] = ["--stats", stats]
    p = subprocess.run(cmd, capture_output=True, text=True)
    return p.returncode, (p.stdout + p.stderr).strip()


def numbers_equal(a, b, path, diffs):
    """Walks two JSON values; every number equal (==, so bit for bit for
    finite floats), every list the same length, every key in both."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            diffs.append("%s: keys %s vs %s" % (path, sorted(a), sorted(b)))
            return
        for k in a:
            numbers_equal(a[k], b[k], "%s.%s" % (path, k), diffs)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            diffs.append("%s: %d vs %d entries" % (path, len(a), len(b)))
            return
        for i, (x, y) in enumerate(zip(a, b)):
            numbers_equal(x, y, "%s[%d]" % (path, i), diffs)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)):
        if not (a == b and math.copysign(1, a) == math.copysign(1, b)):
            diffs.append("%s: %r vs %r" % (path, a, b))
    elif a != b:
        diffs.append("%s: %r vs %r" % (path, a, b))


def check_bits(dkf_run, image, tmp):
    for vec in sorted(glob.glob(os.path.join(VECTORS, "*.json"))):
        name = os.path.basename(vec)
        for filt in ("kf", "dkf"):
            mine, host = os.path.join(tmp, "m4.json"), os.path.join(tmp, "host.json")
            rc, err = m4_run(image, "float", filt, vec, out=mine)
            if rc != 0:
                report(False, "m4 float %s %s: m4_run.sh exited %d: %s" % (filt, name, rc, err))
                continue
            p = subprocess.run([dkf_run, "--filter", filt, "--quiet", "--output", host, vec],
                               capture_output=True, text=True)
            if p.returncode != 0:
                report(False, "host float dkf-run %s %s: exit %d: %s"
                       % (filt, name, p.returncode, p.stderr.strip()))
                continue
            with open(mine) as f:
                a = json.load(f)["outputs"]
            with open(host) as f:
                b = json.load(f)["outputs"]
            diffs = []
            numbers_equal(a, b, "outputs", diffs)
            count = count_numbers(b)
            report(not diffs and count > 0,
                   "m4 float %s %s equals the host float dkf-run bit for bit (%d numbers)%s"
                   % (filt, name, count, "" if not diffs else ": %d differ, first %s"
                      % (len(diffs), diffs[0])))


def count_numbers(v):
    if isinstance(v, dict):
        return sum(count_numbers(x) for x in v.values())
    if isinstance(v, list):
        return sum(count_numbers(x) for x in v)
    return 1 if isinstance(v, (int, float)) else 0


def check_vectors(image, tmp):
    for vec in sorted(glob.glob(os.path.join(VECTORS, "*.json"))):
        name = os.path.basename(vec)
        out = os.path.join(tmp, "m4d.json")
        rc, err = m4_run(image, "double", "dkf", vec, out=out)
        if rc != 0:
            report(False, "m4 double dkf %s: m4_run.sh exited %d: %s" % (name, rc, err))
            continue
        with open(out) as f:
            keys = sorted(json.load(f)["outputs"])
        # under outputs, key by key: a key the vector lacks fails
        ok = True
        for key in keys:
            p = subprocess.run([sys.executable, os.path.join(ROOT, "tools", "dkf_compare.py"),
                                "--quiet", "--require-all", "--rel", "1e-9",
                                "--keys", "outputs." + key, out, vec],
                               capture_output=True, text=True)
            ok = ok and p.returncode == 0
        report(ok, "m4 double dkf %s matches the vector (rel 1e-9; %s)"
               % (name, " ".join(keys)))


def write_json(path, doc):
    with open(path, "w") as f:
        json.dump(doc, f)


def check_refused(image, tmp):
    with open(NODE_VECTOR) as f:
        base = json.load(f)
    # n = 9: one above the image's capacity (QM_MAX_N = 8)
    n = 9
    eye = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    big = {"N": 2,
           "model": {"F": eye, "Q": eye, "H": [eye[0], eye[1]], "R": [[1.0, 0.0], [0.0, 1.0]],
                     "D": [[1.0], [0.0]], "B": [[1.0]], "Rd": [[1.0]]},
           "init": {"x00": [0.0] * n, "P00": eye},
           "y": {"k": [1, 2, 3], "values": [[0.0, 0.0]] * 3}}
    sensors = dict(base)
    sensors["model"] = {"F": base["model"]["F"], "Q": base["model"]["Q"],
                        "sensors": [{k: base["model"][k] for k in ("H", "D", "R", "B", "Rd")}
                                    for _ in range(5)]}
    sensors["y"] = [base["y"]] * 5
    dzero = os.path.join(ROOT, "ports", "linux", "tests", "cases", "d_zero.json")
    cases = [("n = 9 above the capacity 8", big, "dkf", 2),
             ("n = 9 above the capacity 8 (kf)", big, "kf", 2),
             ("5 sensors above the capacity 4", sensors, "dkf", 2),
             ("D = 0 (dkf_diffkf_start: rank)", dzero, "dkf", 3)]
    for what, doc, filt, want in cases:
        path = doc
        if not isinstance(doc, str):
            path = os.path.join(tmp, "refused.json")
            write_json(path, doc)
        out = os.path.join(tmp, "refused.out.json")
        if os.path.exists(out):
            os.remove(out)
        rc, err = m4_run(image, "float", filt, path, out=out)
        # the image's own message ("m4: what: got V") and m4_run's
        report(rc == want and not os.path.exists(out) and "m4: " in err,
               "m4 refuses a failing run, m4_run.sh exits %d (want %d, no output): %s%s"
               % (rc, want, what, "" if not err else " [%s]" % err.splitlines()[0]))


def check_truncated(image, tmp):
    """The image refuses an input file that ends early (every read is checked)."""
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    import m4_run
    data = m4_run.pack(m4_run.Scenario(NODE_VECTOR, 0), "dkf", "f")
    work = os.path.join(tmp, "truncated")
    os.makedirs(work, exist_ok=True)
    for what, blob in (("a record cut short", data[:len(data) - 4]),
                       ("the header cut short", data[:10])):
        with open(os.path.join(work, "m4_in.bin"), "wb") as f:
            f.write(blob)
        rc = m4_run.run_qemu("qemu-system-arm", image, work, 120, quiet=True)
        report(rc == 2, "m4 refuses an input file with %s: exit %d (want 2)" % (what, rc))


def size_of(image):
    p = subprocess.run(["arm-none-eabi-size", image], capture_output=True, text=True)
    text, data, bss = (int(x) for x in p.stdout.splitlines()[1].split()[:3])
    return text + data, data + bss


def node_report(images, tmp):
    rows = []
    for real, image in images:
        flash, ram = size_of(image)
        for filt, label in (("dkf", "DKF node (n = 4, m = 2, p = 2)"),
                            ("kf", "KF (n = 4, m = 2)")):
            st = os.path.join(tmp, "stats.json")
            rc, err = m4_run(image, real, filt, NODE_VECTOR, stats=st)
            if rc != 0:
                report(False, "m4 %s %s report: exit %d: %s" % (real, filt, rc, err))
                continue
            with open(st) as f:
                s = json.load(f)
            one = list(s["filters"].values())[0]
            ok = one["steps"] == 50 and one["insns_per_step"] > 0 and s["insns_per_tick"] > 0
            report(ok, "m4 %s %s: %d steps timed, stack high-water %d B"
                   % (real, filt, one["steps"], s["stack_bytes"]))
            rows.append((label, real, one["insns_per_step"], one["insns_min"],
                         one["insns_max"], s["stack_bytes"], flash, ram, s["insns_per_tick"]))
    print("-- emulated Cortex-M4F (qemu-system-arm -M mps2-an386 -icount shift=0), "
          "tests/vectors/diffkf/ex1_single.json, 50 steps")
    print("| filter | real | instructions per step (mean; min, max) | stack high-water "
          "| image flash | image RAM |")
    print("|---|---|---|---|---|---|")
    for label, real, mean, lo, hi, stack, flash, ram, per in rows:
        print("| %s | %s | %d (%d, %d) | %d B | %d B | %d B |"
              % (label, real, mean, lo, hi, stack, flash, ram))
    if rows:
        print("(SysTick at the processor clock: %g instructions per tick, the resolution of "
              "min and max)" % rows[0][-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dkf-run", required=True, help="the host float build's dkf-run")
    ap.add_argument("--float-image", required=True)
    ap.add_argument("--double-image")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="m4_check.") as tmp:
        check_bits(a.dkf_run, a.float_image, tmp)
        if a.double_image:
            check_vectors(a.double_image, tmp)
        check_refused(a.float_image, tmp)
        check_truncated(a.float_image, tmp)
        images = [("float", a.float_image)]
        if a.double_image:
            images.append(("double", a.double_image))
        node_report(images, tmp)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
