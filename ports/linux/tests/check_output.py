#!/usr/bin/env python3
"""dkf-run --output streams (docs/decisions.md item 50): what it writes and
what it holds.

    check_output.py DKF_RUN VECTOR_DIR OUTDIR

* --every N keeps steps k_first, k_first + N, ...: "k" and every per-step
  list of the JSON document are the full run's entries at those steps, the
  one-off keys (tw3's eta, communication) unchanged;
* --format csv: a header "k,<path>..." and one line per step whose numbers
  are the JSON document's, flattened in order (a several-sensor dkf run:
  local[i], central, fused, the node messages);
* a run that fails leaves no output file;
* memory does not grow with the steps: 10^5 steps of a Kalman filter with
  --output (JSON, then CSV) take less than 100 MB in all and at most 16 MB
  more than the same run without --output (the scenario itself is most of
  it), measured as the child's peak RSS (getrusage).
"""
import json
import os
import subprocess
import sys

STEPS = 100000


def run(dkf_run, args):
    p = subprocess.run([dkf_run, "--quiet"] + args, stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True)
    return p.returncode, p.stderr


def flatten(v):
    if isinstance(v, list):
        for e in v:
            yield from flatten(e)
    elif isinstance(v, dict):
        for e in v.values():
            yield from flatten(e)
    else:
        yield v


def series(doc, path=""):
    """(path, list) of every per-step list under outputs (lists of one entry per step)."""
    for key, v in doc.items():
        p = path + "." + key if path else key
        if isinstance(v, dict):
            yield from series(v, p)
        elif key != "local" and isinstance(v, list):
            yield p, v
        elif key == "local":
            for i, e in enumerate(v):
                yield from series(e, "%s[%d]" % (p, i))


def outputs(dkf_run, scn, flt, runs, bad):
    """dkf-run --output PATH EXTRA... for every (PATH, EXTRA) of runs; False if one fails."""
    for path, extra in runs:
        rc, err = run(dkf_run, ["--filter", flt, "--output", path] + extra + [scn])
        if rc != 0:
            bad("%s %s: exit %d: %s" % (flt, extra, rc, err))
            return False
    return True


def check_every(dkf_run, scn, flt, out, bad):
    full, dec = os.path.join(out, "full.json"), os.path.join(out, "every3.json")
    if not outputs(dkf_run, scn, flt, ((full, []), (dec, ["--every", "3"])), bad):
        return 1
    a, b = json.load(open(full)), json.load(open(dec))
    if b["k"] != a["k"][::3]:
        return bad("%s --every 3: k = %s, expected %s" % (flt, b["k"][:5], a["k"][::3][:5]))
    la, lb = dict(series(a["outputs"])), dict(series(b["outputs"]))
    if sorted(la) != sorted(lb) or not la:
        return bad("%s --every 3: lists %s, expected %s" % (flt, sorted(lb), sorted(la)))
    for key in la:
        if lb[key] != la[key][::3]:
            return bad("%s --every 3: %s is not every third entry of the full run" % (flt, key))
    for key in a:
        if key not in ("k", "outputs") and a[key] != b[key]:
            return bad("%s --every 3: one-off key %s changed" % (flt, key))
    print("ok: %s --every 3 (%d of %d steps, %d lists)" % (flt, len(b["k"]), len(a["k"]), len(la)))
    return 0


def check_csv(dkf_run, scn, flt, out, bad):
    js, cs = os.path.join(out, "csv_ref.json"), os.path.join(out, "out.csv")
    if not outputs(dkf_run, scn, flt, ((js, []), (cs, ["--format", "csv"])), bad):
        return 1
    doc = json.load(open(js))
    lines = open(cs).read().splitlines()
    header = lines[0].split(",")
    rows = [[float(v) for v in line.split(",")] for line in lines[1:]]
    if header[0] != "k" or len(rows) != len(doc["k"]):
        return bad("csv: header %s..., %d rows for %d steps" % (header[:3], len(rows),
                                                                len(doc["k"])))
    lists = list(series(doc["outputs"]))
    for j, row in enumerate(rows):
        want = [doc["k"][j]] + [float(x) for _, v in lists for x in flatten(v[j])]
        if len(row) != len(header) or row != want:
            return bad("csv: step %d differs from the JSON document" % doc["k"][j])
    print("ok: %s --format csv (%d rows x %d columns, equal to the JSON numbers)" %
          (flt, len(rows), len(header)))
    return 0


def check_failed_run(dkf_run, out, bad):
    path = os.path.join(out, "failed.json")
    scn = os.path.join(out, "failing.json")
    doc = {"N": 2, "model": {"F": {"const": [[1]]}, "Q": {"const": [[1]]},
                             "H": {"const": [[1]]}, "R": {"const": [[1]]}},
           "init": {"x00": [0], "P00": [[1]]},
           "y": {"k": [1, 2], "values": [[1.0], [1e308]]}}
    json.dump(doc, open(scn, "w"))
    rc, err = run(dkf_run, ["--filter", "kf", "--output", path, scn])
    if rc != 3 or os.path.exists(path):
        return bad("a failed run: exit %d (want 3), output %s" %
                   (rc, "left behind" if os.path.exists(path) else "absent"))
    print("ok: a failed run leaves no output")
    return 0


def peak_rss_mb(cmd):
    """Peak RSS of cmd (MB), in a fresh process so that earlier children do not count."""
    probe = ("import resource, subprocess, sys; "
             "rc = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode; "
             "print(rc, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    got = subprocess.run([sys.executable, "-c", probe] + cmd, stdout=subprocess.PIPE, text=True,
                         check=True).stdout.split()
    return int(got[0]), int(got[1]) / 1024.0


def check_memory(dkf_run, out, bad):
    scn = os.path.join(out, "long.json")
    ys = [[round(0.001 * k + 0.5 * ((k * 7919) % 13 - 6) / 6.0, 6)] for k in range(1, STEPS + 1)]
    doc = {"N": STEPS,
           "model": {"F": {"const": [[1, 1], [0, 1]]}, "Q": {"const": [[1e-4, 0], [0, 1e-4]]},
                     "H": {"const": [[1, 0]]}, "R": {"const": [[1]]}},
           "init": {"x00": [0, 0], "P00": [[1, 0], [0, 1]]},
           "y": {"k": list(range(1, STEPS + 1)), "values": ys}}
    json.dump(doc, open(scn, "w"))
    rc0, base = peak_rss_mb([dkf_run, "--quiet", "--filter", "kf", scn])
    if rc0 != 0:
        return bad("long run without --output: exit %d" % rc0)
    for fmt in ("json", "csv"):
        path = os.path.join(out, "long_out." + fmt)
        rc, rss = peak_rss_mb([dkf_run, "--quiet", "--filter", "kf", "--format", fmt,
                               "--output", path, scn])
        size = os.path.getsize(path) / 1e6 if os.path.exists(path) else 0
        print("%d steps, --format %s: peak RSS %.1f MB (without --output %.1f MB), output "
              "%.1f MB" % (STEPS, fmt, rss, base, size))
        if rc != 0 or rss > 100 or rss > base + 16:
            return bad("%s: exit %d, peak RSS %.1f MB (limit 100 MB and %.1f + 16 MB)" %
                       (fmt, rc, rss, base))
        os.remove(path)
    return 0


def main():
    dkf_run, vdir, out = sys.argv[1:4]
    os.makedirs(out, exist_ok=True)
    failures = []

    def bad(msg):
        failures.append(msg)
        print("FAIL: " + msg)
        return 1

    ex3 = os.path.join(vdir, "diffkf", "ex3_multi.json")
    six = os.path.join(vdir, "uif", "s003_6node.json")
    check_every(dkf_run, ex3, "dkf", out, bad)
    check_every(dkf_run, six, "tw3", out, bad)
    check_csv(dkf_run, ex3, "dkf", out, bad)
    check_csv(dkf_run, six, "tw2", out, bad)
    check_failed_run(dkf_run, out, bad)
    check_memory(dkf_run, out, bad)
    print("FAIL" if failures else "PASS")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
