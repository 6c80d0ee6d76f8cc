"""bench/python_speed.py runs (its smoke mode, --quick) and reports every
row and ratio that docs/results/bench.md's "Python" table quotes. Timings
are printed, never asserted."""

import re
import subprocess
import sys

from conftest import ROOT

ROWS = ("filter", "loop", "C", "filterpy", "ckf_jit", "ckf_python", "ckf_filterpy")


def test_python_speed_quick():
    out = subprocess.run([sys.executable, str(ROOT / "bench" / "python_speed.py"), "--quick"],
                         capture_output=True, text=True, timeout=600, check=True).stdout
    for row in ROWS:
        assert re.search(rf"^{row} +(-|[0-9.]+) ns/step$", out, re.M), (row, out)
    for ratio in ("filter / C", "loop / C", "filterpy / filter", "ckf_filterpy / ckf_jit",
                  "ckf_python / ckf_jit"):
        assert re.search(rf"^{re.escape(ratio)}: (-|[0-9.]+)$", out, re.M), (ratio, out)
