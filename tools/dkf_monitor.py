#!/usr/bin/env python3
"""Follow a live dkf network run over LCM and plot it (docs/guide/network.md).

    dkf_monitor.py [--url URL] [--prefix DKF] [--png dkf_monitor.png]
                   [--every 2] [--duration 0] [--until-done] [--types DIR]

Subscribes to <prefix>_TRUTH, <prefix>_FUSED, <prefix>_NODE_<i> and
<prefix>_STATUS and plots the target track (truth, fused estimate, each
node's local estimate) and the fused error per step. Headless: it never
opens a window; it writes the PNG every --every seconds and at exit
(SIGINT/SIGTERM, --duration, or --until-done when the fusion centre
reports DONE). The URL must be udpm://239.x.y.z...?ttl=0 (or memq://),
like the C programs: the default keeps every packet on this machine.

The message classes (package dkf_lcm) are generated from lcmtypes/*.lcm by
the build (<build>/ports/linux/net/lcmgen/python); --types or
$DKF_LCM_PYTHON names that directory, else they are generated into a
temporary directory with lcm-gen.
"""
import argparse
import glob
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time

DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def check_url(url):
    """The C transport's rule (net.h): memq://, or udpm to 239.0.0.0/8 with ttl=0 once."""
    if url == "memq://":
        return None
    m = re.fullmatch(r"udpm://([0-9.]+)(?::([0-9]+))?(?:\?(.*))?", url)
    if not m:
        return "only udpm:// (ttl=0) and memq:// are allowed"
    parts = m.group(1).split(".")
    if (len(parts) != 4 or any(not re.fullmatch(r"0|[1-9][0-9]{0,2}", p) or int(p) > 255
                               for p in parts) or parts[0] != "239"):
        return "the multicast group must be an address in 239.0.0.0/8"
    if m.group(2) is not None and not (re.fullmatch(r"[1-9][0-9]{0,4}", m.group(2))
                                       and int(m.group(2)) <= 65535):
        return "bad port"
    ttl = [o for o in (m.group(3) or "").split("&") if o.startswith("ttl=")]
    if ttl != ["ttl=0"]:
        return "a udpm URL must say ttl=0 exactly once"
    return None


def import_types(types_dir=None):
    """Imports the generated dkf_lcm package (see the module docstring)."""
    cands = [types_dir, os.environ.get("DKF_LCM_PYTHON")]
    cands += sorted(glob.glob(os.path.join(ROOT, "build*", "ports", "linux", "net", "lcmgen",
                                           "python")))
    for d in cands:
        if d and os.path.isfile(os.path.join(d, "dkf_lcm", "__init__.py")):
            sys.path.insert(0, d)
            break
    else:
        gen = shutil.which("lcm-gen")
        if gen is None:
            sys.exit("dkf_lcm types not found and no lcm-gen on PATH (build dkf, or --types DIR)")
        d = tempfile.mkdtemp(prefix="dkf_lcm_")
        subprocess.run([gen, "-p", "--ppath", d] + sorted(glob.glob(os.path.join(ROOT, "lcmtypes",
                                                                                  "*.lcm"))),
                       check=True)
        sys.path.insert(0, d)
    import dkf_lcm  # noqa: F401
    return sys.modules["dkf_lcm"]


class Run:
    """What has been seen of one run: truth, fused and local estimates by step."""

    def __init__(self, types, prefix):
        self.t, self.prefix = types, prefix
        self.truth, self.fused, self.degraded, self.local = {}, {}, set(), {}
        self.revision = {}  # k -> revision of the fused message held
        self.status, self.done = {}, False

    def handle(self, channel, data):
        p = self.prefix + "_"
        if not channel.startswith(p):
            return
        what = channel[len(p):]
        try:
            if what == "TRUTH":
                m = self.t.truth_t.decode(data)
                self.truth[m.k] = list(m.x)
            elif what == "FUSED":
                m = self.t.fused_t.decode(data)
                # the newest revision of step k stands (docs/guide/network.md: the
                # fusion centre publishes every step it recomputes); a
                # complete revision clears a degraded first publication
                if m.revision < self.revision.get(m.k, -1):
                    return
                self.revision[m.k] = m.revision
                self.fused[m.k] = list(m.xf)
                if m.status == self.t.fused_t.DEGRADED:
                    self.degraded.add(m.k)
                else:
                    self.degraded.discard(m.k)
            elif what.startswith("NODE_"):
                m = self.t.node_msg_t.decode(data)
                self.local.setdefault(m.node, {})[m.k] = list(m.xf)
            elif what == "STATUS":
                m = self.t.status_t.decode(data)
                self.status[(m.role, m.id)] = m
                if m.role == self.t.status_t.ROLE_FUSION and m.state == self.t.status_t.DONE:
                    self.done = True
        except (ValueError, IndexError, Exception) as e:  # a malformed message is skipped
            print(f"dkf_monitor: {channel}: undecodable message ({e})", file=sys.stderr)

    def plot(self, png, title):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
        fig, (ax, ae) = plt.subplots(1, 2, figsize=(12, 5))

        def xy(d):
            ks = sorted(d)
            a = np.array([d[k] for k in ks]) if ks else np.zeros((0, 1))
            if a.shape[1] >= 3:  # (px, vx, py, vy): positions
                return a[:, 0], a[:, 2], "x[0]", "x[2]"
            return np.array(ks), a[:, 0], "k", "x[0]"

        for node, d in sorted(self.local.items()):
            x, y, _, _ = xy(d)
            ax.plot(x, y, lw=0.6, alpha=0.4, label=f"node {node} local" if node < 6 else None)
        if self.truth:
            x, y, lx, ly = xy(self.truth)
            ax.plot(x, y, "k-", lw=1.5, label="truth")
        if self.fused:
            x, y, lx, ly = xy(self.fused)
            ax.plot(x, y, "r.-", lw=1, ms=3, label="fused")
            ax.set_xlabel(lx)
            ax.set_ylabel(ly)
        ax.set_title(title)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="best")
        ax.grid(True, alpha=0.3)
        ks = [k for k in sorted(self.fused) if k in self.truth]
        if ks:
            err = [np.linalg.norm(np.array(self.fused[k]) - np.array(self.truth[k])) for k in ks]
            ae.semilogy(ks, err, "r.-", ms=3, label="|fused x_{k|k} - x_k|")
            bad = [k for k in ks if k in self.degraded]
            if bad:
                ae.semilogy(bad, [err[ks.index(k)] for k in bad], "kx", label="degraded step")
            for node, d in sorted(self.local.items())[:6]:
                kk = [k for k in ks if k in d]
                ae.semilogy(kk, [np.linalg.norm(np.array(d[k]) - np.array(self.truth[k]))
                                 for k in kk], lw=0.6, alpha=0.4)
            ae.legend(fontsize=8)
        else:
            ae.text(0.5, 0.5, "waiting for fused estimates and truth", ha="center",
                    transform=ae.transAxes)
        ae.set_xlabel("k")
        ae.set_title(f"fused steps: {len(self.fused)}, degraded: {len(self.degraded)}")
        ae.grid(True, alpha=0.3)
        fig.tight_layout()
        tmp = png + ".tmp.png"
        fig.savefig(tmp, dpi=90)
        plt.close(fig)
        os.replace(tmp, png)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--url", default=DEFAULT_URL)
    ap.add_argument("--prefix", default="DKF")
    ap.add_argument("--png", default="dkf_monitor.png")
    ap.add_argument("--every", type=float, default=2.0, help="seconds between PNG updates")
    ap.add_argument("--duration", type=float, default=0.0, help="stop after S seconds (0: never)")
    ap.add_argument("--until-done", action="store_true",
                    help="stop when the fusion centre reports DONE")
    ap.add_argument("--types", help="directory holding the generated dkf_lcm package")
    a = ap.parse_args()
    why = check_url(a.url)
    if why:
        print(f"dkf_monitor: {a.url}: refused: {why}", file=sys.stderr)
        return 2
    types = import_types(a.types)
    import lcm
    run = Run(types, a.prefix)
    lc = lcm.LCM(a.url)
    sub = lc.subscribe(re.escape(a.prefix) + "_.*", run.handle)
    # LCM queues 30 messages per subscription by default and drops the rest
    # while a plot is drawn; every node message of a step must be kept.
    sub.set_queue_capacity(100000)
    stop = []
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    t0 = last = time.monotonic()
    fd = lc.fileno()
    while not stop:
        r, _, _ = select.select([fd], [], [], 0.1)
        while r:  # drain what is queued before drawing
            lc.handle()
            r, _, _ = select.select([fd], [], [], 0)
        now = time.monotonic()
        if now - last >= a.every:
            run.plot(a.png, f"live: {a.prefix} on {a.url}")
            last = now
        if (a.duration > 0 and now - t0 >= a.duration) or (a.until_done and run.done):
            break
    run.plot(a.png, f"live: {a.prefix} on {a.url}")
    print(f"dkf_monitor: {len(run.fused)} fused steps ({len(run.degraded)} degraded), "
          f"{len(run.truth)} truth, {len(run.local)} nodes seen; wrote {a.png}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
