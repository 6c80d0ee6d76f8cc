"""What the example scripts (seed001_table1.py, seed002_example.py,
tw_example.py, uif_example.py) share: the options of the seed examples,
finding dkf-run or the Python package, a progress line, saving a figure,
and the closing list of checks."""
import argparse
import os
import sys
import time


def find_dkf_run(root):
    """The dkf-run of the usual build trees under root, or None."""
    for b in ("build/double", "build", "build/ci-double"):
        p = os.path.join(root, b, "ports/linux/dkf-run")
        if os.access(p, os.X_OK):
            return p
    return None


def seed_parser(doc, root, out_name, own, verdict_help, dkf_run=True):
    """The seed examples' parser: the script's own integer options (own: (name,
    default) pairs), then --jobs and --dkf-run (only with dkf_run: a script
    that starts dkf-run processes), --out-dir (root/build/out_name), --no-plots
    and --no-verdict."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    for name, default in own:
        ap.add_argument(name, type=int, default=default)
    if dkf_run:
        ap.add_argument("--jobs", type=int, default=2)
        ap.add_argument("--dkf-run", default=None)
    ap.add_argument("--out-dir", default=os.path.join(root, "build", out_name))
    ap.add_argument("--no-plots", action="store_true")
    ap.add_argument("--no-verdict", action="store_true", help=verdict_help)
    return ap


def seed_dkf_run(a, root, prog):
    """The dkf-run to use (--dkf-run, else find_dkf_run; exits if none), with
    --out-dir created."""
    exe = a.dkf_run or find_dkf_run(root)
    if exe is None:
        sys.exit(f"{prog}: no dkf-run found; build first (tools/run_tests.sh) or give --dkf-run")
    os.makedirs(a.out_dir, exist_ok=True)
    return exe


def package(prog):
    """The Python package dkf, its dkf.float32 imported; None, saying so on
    stderr, where it is not installed."""
    try:
        import dkf
        import dkf.float32  # noqa: F401
    except ImportError:
        print(f"{prog}: needs the Python package dkf (pip install .; docs/guide/python.md)",
              file=sys.stderr)
        return None
    return dkf


class Progress:
    """A progress line on stderr: done / total, elapsed and estimated seconds left."""

    def __init__(self, total, what):
        self.total, self.done, self.what, self.t0 = total, 0, what, time.time()

    def step(self):
        self.done += 1
        w = 30
        f = int(w * self.done / self.total)
        el = time.time() - self.t0
        eta = el / self.done * (self.total - self.done)
        sys.stderr.write(f"\r{self.what} [{'#' * f}{'.' * (w - f)}] {self.done}/{self.total} "
                         f"{el:5.0f} s, ~{eta:4.0f} s left")
        if self.done == self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def save_figure(plt, fig, outdir, name):
    """Lays fig out, writes outdir/name at 72 dpi and closes it."""
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, name), dpi=72)
    plt.close(fig)


def wrote_checks(outdir, names):
    """One check per figure: outdir/name was written (more than 1000 bytes)."""
    return [("wrote " + f, os.path.getsize(os.path.join(outdir, f)) > 1000) for f in names]


def print_checks(checks, width):
    for c, ok in checks:
        print("check: %-*s %s" % (width, c, "ok" if ok else "FAILED"))


def verdict(checks):
    """Prints CHECKS PASSED or CHECKS FAILED with the failed ones; the exit status."""
    bad = [c for c, ok in checks if not ok]
    if bad:
        print("CHECKS FAILED: " + "; ".join(bad))
        return 1
    print("CHECKS PASSED")
    return 0
