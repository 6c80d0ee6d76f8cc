#!/usr/bin/env python3
"""Plot a finished dkf network run from an LCM log (lcm-logger) as a PNG.

    dkf_logplot.py run.lcmlog [--png run.png] [--prefix DKF] [--types DIR]

Reads the log with the Python `lcm` package (no network), decodes the
<prefix>_TRUTH, <prefix>_FUSED, <prefix>_NODE_<i> and <prefix>_STATUS
messages (message classes as in dkf_monitor.py) and draws the same figure
as dkf_monitor.py: target track (truth, fused, local estimates) and the
fused error per step, degraded steps marked.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dkf_monitor import Run, import_types  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("log")
    ap.add_argument("--png")
    ap.add_argument("--prefix", default="DKF")
    ap.add_argument("--types", help="directory holding the generated dkf_lcm package")
    a = ap.parse_args()
    types = import_types(a.types)
    import lcm
    try:
        log = lcm.EventLog(a.log, "r")
    except (IOError, OSError, ValueError) as e:
        print(f"dkf_logplot: {a.log}: cannot read the log ({e})", file=sys.stderr)
        return 2
    run = Run(types, a.prefix)
    events = 0
    for ev in log:
        run.handle(ev.channel, ev.data)
        events += 1
    png = a.png or os.path.splitext(a.log)[0] + ".png"
    if not run.fused and not run.truth:
        print(f"dkf_logplot: {a.log}: no {a.prefix}_FUSED or {a.prefix}_TRUTH message in "
              f"{events} events", file=sys.stderr)
        return 1
    run.plot(png, f"{os.path.basename(a.log)}: {len(run.local)} nodes")
    print(f"dkf_logplot: {events} events, {len(run.fused)} fused steps "
          f"({len(run.degraded)} degraded); wrote {png}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
