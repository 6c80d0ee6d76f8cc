"""What the example scripts (seed001_table1.py, seed002_example.py,
tw_example.py, uif_example.py) share: their options, finding the Python
package, a progress line, saving a figure, and the closing list of checks."""
import argparse
import os
import sys
import time


def package_options(ap):
    """The options of every example that runs the filters through the Python
    package: --float32 (the filters of dkf.float32) and --no-plots."""
    ap.add_argument("--float32", action="store_true", help="the filters of dkf.float32")
    ap.add_argument("--no-plots", action="store_true", help="no figures (no matplotlib needed)")


def seed_parser(doc, root, out_name, own, verdict_help):
    """The seed examples' parser: the script's own integer options (own: (name,
    default) pairs), then --out-dir (root/build/out_name), package_options'
    --float32 and --no-plots, and --no-verdict."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    for name, default in own:
        ap.add_argument(name, type=int, default=default)
    ap.add_argument("--out-dir", default=os.path.join(root, "build", out_name))
    package_options(ap)
    ap.add_argument("--no-verdict", action="store_true", help=verdict_help)
    return ap


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


def package_module(a, prog):
    """The module whose filters the example runs: dkf.float32 with --float32
    (package_options), else dkf; None, saying so on stderr, without the package."""
    dkf = package(prog)
    return None if dkf is None else dkf.float32 if a.float32 else dkf


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
