#!/usr/bin/env python3
"""Run a scenario through the dkf node image on an emulated Cortex-M4F.

    tools/m4_run.py --image ELF --filter dkf --output OUT.json SCENARIO.json

(tools/m4_run.sh finds or builds the image and calls this.) Packs a
canonical-layout scenario (docs/reference/scenario-format.md) into
m4_in.bin, runs `qemu-system-arm -M mps2-an386` on the image
(ports/cortex-m4/qemu_main.c) in a temporary directory with semihosting,
and writes what the image wrote (m4_out.bin) in the layout of
`dkf-run --output` for the same filter: outputs.KF / outputs.DKF for one
sensor; outputs.local[i], outputs.central and, for dkf, outputs.fused,
outputs.messages, outputs.fc_recovered for several. With --stats it also
writes the image's measurements: instructions per filter step (SysTick
under -icount shift=0, calibrated against a loop of known length), the
stack high-water mark.

m4_in.bin (little-endian; reals of the image's type, 4 or 8 bytes):
  u32 magic "DKN1", bytes per real, filter (1 kf, 2 dkf), n, L, N,
  then per sensor u32 m_i and p_i (p_i = 0 for kf);
  x00 (n), P00_central (n x n), and for L > 1 P00_local[i] (n x n each);
  records k = 0 .. N (kf) or N + 1 (dkf): F_k, Q_k, then per sensor H_k,
  R_k, y_k and (dkf) D_k, B_k, Rd_k; a matrix the filter does not use at
  k (y_0, ...) is zeros.
m4_out.bin: u32 "DKO1", bytes per real, N; per step, per filter (single
  or local[0..L-1], central, fused) xp, Pp (kf: after predict), dkf: z,
  dz, J, L, K, then xf, Pf; dkf with L > 1: messages (xf, xp per node),
  fc_recovered (dz, z, K per node). Then u32 "DKS1", calibration ticks,
  its instructions, stack bytes used, stack size, filters, and per filter
  steps, tick sum (2 words), min, max.

Exit status: the image's (0; 2 input refused; 3 a filter call failed;
4 output not written); 2 for a scenario this tool cannot pack.
"""
import argparse
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile

MAGIC_IN, MAGIC_OUT, MAGIC_STATS = 0x314E4B44, 0x314F4B44, 0x31534B44
FILTERS = {"kf": 1, "dkf": 2}
LABELS = {"kf": "KF", "dkf": "DKF"}


class PackError(Exception):
    pass


def flat(m):
    """A row-major nested list (or a flat vector) as a flat list."""
    if isinstance(m, list) and m and isinstance(m[0], list):
        return [float(v) for row in m for v in row]
    return [float(v) for v in m]


def shape(m):
    if isinstance(m, list) and m and isinstance(m[0], list):
        return len(m), len(m[0])
    return len(m), 1


def mat_at(spec, k):
    """Entry k of {"const": M}, {"per_k": [...]} or a bare M; None if absent."""
    if isinstance(spec, dict):
        if "const" in spec:
            return spec["const"]
        lst = spec.get("per_k")
        if lst is None:
            raise PackError("a model matrix has neither const nor per_k")
        return lst[k] if 0 <= k < len(lst) else None
    return spec


class Scenario:
    def __init__(self, path, run):
        with open(path) as f:
            doc = json.load(f)
        if "cases" in doc or "steps" in doc:
            raise PackError("only the canonical layout (tests/vectors/diffkf, scenarios/) is packed")
        model, init = doc["model"], doc["init"]
        if "N" in doc:
            self.N = int(doc["N"])
        elif "k" in doc:
            self.N = len(doc["k"])
        else:
            raise PackError("N or k: missing key (the image needs the number of steps)")
        self.multi = "sensors" in model
        sensors = model["sensors"] if self.multi else [model]
        if "runs" in doc:
            ys = doc["runs"][run]["y"]
        else:
            ys = doc["y"]
        if not self.multi:
            ys = [ys]
        self.F, self.Q = model["F"], model["Q"]
        self.n = shape(mat_at(self.F, 0))[0]
        self.sensors = []
        for i, s in enumerate(sensors):
            get = lambda key, s=s: s.get(key, model.get(key))
            sens = {key: get(key) for key in ("H", "R", "D", "B", "Rd")}
            sens["m"] = shape(mat_at(sens["H"], 1 if mat_at(sens["H"], 0) is None else 0))[0]
            sens["p"] = 0
            if sens["D"] is not None:
                d = mat_at(sens["D"], 1) or mat_at(sens["D"], 0)
                sens["p"] = shape(d)[1]
            sens["y"] = {int(k): v for k, v in zip(ys[i]["k"], ys[i]["values"])}
            self.sensors.append(sens)
        self.x00 = flat(init["x00"])
        self.P00c = flat(init.get("P00_central", init.get("P00")))
        if self.multi:
            pl = init.get("P00_local")
            self.P00l = [flat(pl[i]) if pl is not None else flat(init["P00"])
                         for i in range(len(sensors))]


def pack(sc, filt, real_fmt):
    """The bytes of m4_in.bin for filter filt ('kf' or 'dkf')."""
    dkf = filt == "dkf"
    n, L, N = sc.n, len(sc.sensors), sc.N
    out = bytearray()
    words = [MAGIC_IN, struct.calcsize(real_fmt), FILTERS[filt], n, L, N]
    for s in sc.sensors:
        if dkf and s["D"] is None:
            raise PackError("model.D: missing key (filter dkf needs D, B, Rd)")
        words += [s["m"], s["p"] if dkf else 0]
    out += struct.pack("<%dI" % len(words), *words)

    def reals(vals, count, what):
        if len(vals) != count:
            raise PackError("%s: expected %d values, got %d" % (what, count, len(vals)))
        try:
            out.extend(struct.pack("<%d%s" % (count, real_fmt), *vals))
        except (OverflowError, struct.error) as e:
            raise PackError("%s: %s" % (what, e))

    def at(spec, k, count, needed, what):
        m = mat_at(spec, k) if spec is not None else None
        if m is None:
            if needed:
                raise PackError("%s: no value for k = %d" % (what, k))
            return [0.0] * count
        return flat(m)

    reals(sc.x00, n, "init.x00")
    reals(sc.P00c, n * n, "init.P00")
    if L > 1:
        for i in range(L):
            reals(sc.P00l[i], n * n, "init.P00_local[%d]" % i)
    last = N + 1 if dkf else N
    for k in range(last + 1):
        dyn = k <= N if dkf else k <= N - 1  # F, Q, B, Rd at k
        meas = k >= 1  # H, R, D, y at k
        reals(at(sc.F, k, n * n, dyn, "model.F"), n * n, "model.F")
        reals(at(sc.Q, k, n * n, dyn, "model.Q"), n * n, "model.Q")
        for i, s in enumerate(sc.sensors):
            m, p = s["m"], s["p"]
            name = "sensor %d " % i
            reals(at(s["H"], k, m * n, meas, name + "H"), m * n, name + "H")
            reals(at(s["R"], k, m * m, meas, name + "R"), m * m, name + "R")
            y = s["y"].get(k)
            if y is None and meas:
                raise PackError("y: no measurement of sensor %d for k = %d" % (i, k))
            reals(flat(y) if y is not None else [0.0] * m, m, name + "y")
            if dkf:
                reals(at(s["D"], k, m * p, meas, name + "D"), m * p, name + "D")
                reals(at(s["B"], k, p * p, dyn, name + "B"), p * p, name + "B")
                reals(at(s["Rd"], k, p * p, dyn, name + "Rd"), p * p, name + "Rd")
    return bytes(out)


class Reader:
    def __init__(self, data, real_fmt):
        self.data, self.pos, self.fmt = data, 0, real_fmt
        self.size = struct.calcsize(real_fmt)

    def words(self, count):
        v = struct.unpack_from("<%dI" % count, self.data, self.pos)
        self.pos += 4 * count
        return list(v)

    def vec(self, count):
        v = struct.unpack_from("<%d%s" % (count, self.fmt), self.data, self.pos)
        self.pos += self.size * count
        return list(v)

    def mat(self, rows, cols):
        v = self.vec(rows * cols)
        return [v[r * cols:(r + 1) * cols] for r in range(rows)]


def slot_names(sc, filt):
    L = len(sc.sensors)
    if L == 1:
        return [LABELS[filt]]
    names = ["local[%d]" % i for i in range(L)] + ["central"]
    return names + (["fused"] if filt == "dkf" else [])


def unpack(data, sc, filt, real_fmt):
    """(outputs, stats) from the bytes of m4_out.bin."""
    rd = Reader(data, real_fmt)
    magic, size, N = rd.words(3)
    if magic != MAGIC_OUT or size != rd.size or N != sc.N:
        raise PackError("m4_out.bin: unexpected header %s" % [hex(magic), size, N])
    n, L = sc.n, len(sc.sensors)
    names = slot_names(sc, filt)
    ps = [s["p"] for s in sc.sensors]
    p_of = ps + [sum(ps), sum(ps)] if L > 1 else [ps[0]]
    keys = ["xp", "Pp"] + (["z", "dz", "J", "L", "K"] if filt == "dkf" else []) + ["xf", "Pf"]
    series = [{key: [] for key in keys} for _ in names]
    messages, recovered = [], []
    for _ in range(N):
        for j in range(len(names)):
            ser = series[j]
            ser["xp"].append(rd.vec(n))
            ser["Pp"].append(rd.mat(n, n))
            if filt == "dkf":
                p = p_of[j]
                ser["z"].append(rd.vec(p))
                ser["dz"].append(rd.vec(p))
                ser["J"].append(rd.mat(n, p))
                ser["L"].append(rd.mat(p, p))
                ser["K"].append(rd.mat(n, p))
            ser["xf"].append(rd.vec(n))
            ser["Pf"].append(rd.mat(n, n))
        if filt == "dkf" and L > 1:
            messages.append([{"xf": rd.vec(n), "xp": rd.vec(n)} for _ in range(L)])
            rec = []
            for i in range(L):
                p = ps[i]
                rec.append({"dz": rd.vec(p), "z": rd.vec(p), "K": rd.mat(n, p)})
            recovered.append(rec)
    magic, calib, calib_insns, stack_used, stack_size, nslots = rd.words(6)
    if magic != MAGIC_STATS or nslots != len(names):
        raise PackError("m4_out.bin: unexpected statistics block")
    per = calib_insns / calib if calib else float("nan")
    stats = {"insns_per_tick": per, "calibration_ticks": calib,
             "calibration_insns": calib_insns, "stack_bytes": stack_used,
             "stack_size": stack_size, "filters": {}}
    for name in names:
        steps, lo, hi, tmin, tmax = rd.words(5)
        total = lo + (hi << 32)
        stats["filters"][name] = {
            "steps": steps, "ticks": total,
            "insns_per_step": round(total * per / steps) if steps else None,
            "insns_min": round(tmin * per), "insns_max": round(tmax * per)}
    if rd.pos != len(data):
        raise PackError("m4_out.bin: %d bytes left over" % (len(data) - rd.pos))
    outputs = {}
    if L == 1:
        outputs[names[0]] = series[0]
    else:
        outputs["local"] = series[:L]
        outputs["central"] = series[L]
        if filt == "dkf":
            outputs["fused"] = series[L + 1]
            outputs["messages"] = messages
            outputs["fc_recovered"] = recovered
    return outputs, stats


def run_qemu(qemu, image, workdir, timeout, quiet=False):
    """The image's exit status; its console lines discarded if quiet."""
    cmd = [qemu, "-M", "mps2-an386", "-display", "none", "-monitor", "none", "-serial", "none",
           "-icount", "shift=0", "-semihosting-config", "enable=on,target=native",
           "-kernel", os.path.abspath(image)]
    out = subprocess.DEVNULL if quiet else None
    try:
        return subprocess.run(cmd, cwd=workdir, timeout=timeout, stdout=out,
                              stderr=out).returncode
    except subprocess.TimeoutExpired:
        print("m4_run: %s did not finish in %d s" % (image, timeout), file=sys.stderr)
        return 124


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--image", required=True, help="dkf_m4_qemu.elf")
    ap.add_argument("--real", choices=("float", "double"), default="float",
                    help="the image's real type (default float)")
    ap.add_argument("--filter", choices=sorted(FILTERS), required=True)
    ap.add_argument("--output", "-o", help="write the estimates (dkf-run's layout)")
    ap.add_argument("--stats", help="write the image's measurements (JSON)")
    ap.add_argument("--run", type=int, default=0, help="run of a Monte-Carlo file (default 0)")
    ap.add_argument("--qemu", default=shutil.which("qemu-system-arm") or "qemu-system-arm")
    ap.add_argument("--timeout", type=int, default=300)
    ap.add_argument("--keep", help="keep m4_in.bin and m4_out.bin in this directory")
    ap.add_argument("--quiet", "-q", action="store_true")
    ap.add_argument("scenario")
    a = ap.parse_args()
    real_fmt = "f" if a.real == "float" else "d"
    try:
        sc = Scenario(a.scenario, a.run)
        data_in = pack(sc, a.filter, real_fmt)
    except (PackError, KeyError, IndexError, TypeError, ValueError, OSError) as e:
        print("m4_run: %s: %s" % (a.scenario, e), file=sys.stderr)
        return 2
    workdir = a.keep or tempfile.mkdtemp(prefix="m4_run.")
    os.makedirs(workdir, exist_ok=True)
    try:
        with open(os.path.join(workdir, "m4_in.bin"), "wb") as f:
            f.write(data_in)
        rc = run_qemu(a.qemu, a.image, workdir, a.timeout)
        if rc != 0:
            print("m4_run: %s: the image exited with status %d" % (a.scenario, rc),
                  file=sys.stderr)
            return rc
        with open(os.path.join(workdir, "m4_out.bin"), "rb") as f:
            data_out = f.read()
    finally:
        if not a.keep:
            shutil.rmtree(workdir, ignore_errors=True)
    try:
        outputs, stats = unpack(data_out, sc, a.filter, real_fmt)
    except (PackError, struct.error) as e:
        print("m4_run: %s: %s" % (a.scenario, e), file=sys.stderr)
        return 4
    doc = {"scenario": a.scenario, "filter": a.filter, "real": a.real,
           "k": list(range(1, sc.N + 1)), "outputs": outputs}
    if a.output:
        with open(a.output, "w") as f:
            json.dump(doc, f, separators=(",", ":"))
    stats.update({"scenario": a.scenario, "filter": a.filter, "real": a.real, "n": sc.n,
                  "m": [s["m"] for s in sc.sensors],
                  "p": [s["p"] if a.filter == "dkf" else 0 for s in sc.sensors]})
    if a.stats:
        with open(a.stats, "w") as f:
            json.dump(stats, f, indent=1)
    if not a.quiet:
        print("m4: %s, filter %s (%s), n = %d, %d sensor(s), %d steps; stack %d of %d bytes"
              % (a.scenario, a.filter, a.real, sc.n, len(sc.sensors), sc.N,
                 stats["stack_bytes"], stats["stack_size"]))
        for name, f in stats["filters"].items():
            print("  %-10s %9d instructions per step (min %d, max %d)"
                  % (name, f["insns_per_step"], f["insns_min"], f["insns_max"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
