"""python -m dkf: simulate a scenario, run a filter over it, plot the result.

    python -m dkf simulate MODEL.json --steps N [--seed S] -o SCN.json
    python -m dkf run SCN.json --filter NAME [--run R] [--case C] [--d00 ..] [--eta N]
                      [--metrics-only] -o OUT.json
    python -m dkf plot OUT.json [--scenario SCN.json] [-o PNG]

`simulate` is dkf.simulate, `run` dkf.run_scenario (the document dkf-run
--output writes), `plot` draws x_{k|k} of every estimator of OUT.json, one
panel per state component, with the truth of SCN.json if given (matplotlib,
imported by `plot` alone). Exit status: 0 ok, 2 bad arguments or input, 3 a
filter call failed.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any, Dict, List, Optional, Sequence, Tuple

from ._errors import Error
from ._scenario import SUPPORTED_FILTERS, run_scenario
from ._simulate import simulate


def _write(doc: Dict[str, Any], path: str) -> None:
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, separators=(",", ":"))  # repr of a float: read back exactly
        fh.write("\n")


def _xf(ser: Any) -> Optional[List[List[float]]]:
    """x_{k|k} of one estimator's series: `xf` (canonical layout) or `x` (cases, steps)."""
    if not isinstance(ser, dict):
        return None
    return ser.get("xf", ser.get("x"))


def _estimates(out: Dict[str, Any]) -> List[Tuple[str, List[List[float]]]]:
    """(label, x_{k|k} per step) of every estimator of a run_scenario document."""
    found = []
    for label, ser in out.get("outputs", {}).items():
        if label == "local":
            found += [("local[%d]" % i, _xf(s)) for i, s in enumerate(ser) if _xf(s)]
        elif _xf(ser):
            found.append((label, _xf(ser)))
    return found


def _truth(scn: Dict[str, Any]) -> Optional[Dict[str, Any]]:
    """A scenario's true states {k, x}: its `truth`, or the steps layout's per step."""
    if "truth" in scn:
        return scn["truth"]
    per = [(t["k"], t["truth"]["x"]) for t in scn.get("steps", [])
           if isinstance(t, dict) and "x" in t.get("truth", {})]
    return {"k": [k for k, _ in per], "x": [x for _, x in per]} if per else None


def _plot(args: argparse.Namespace) -> int:
    try:
        import matplotlib

        if args.output:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("python -m dkf plot: needs matplotlib, which is not installed "
              "(pip install matplotlib)", file=sys.stderr)
        return 2
    with open(args.out_json, encoding="utf-8") as fh:
        out = json.load(fh)
    est = _estimates(out)
    if not est:
        print("python -m dkf plot: %s: no estimates (outputs.*.xf or .x) to plot" % args.out_json,
              file=sys.stderr)
        return 2
    truth = None
    if args.scenario:
        with open(args.scenario, encoding="utf-8") as fh:
            truth = _truth(json.load(fh))
    ks = out["k"]
    n = len(est[0][1][0])
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.2 * n), sharex=True, squeeze=False)
    for j in range(n):
        ax = axes[j][0]
        if truth is not None:
            tk = truth.get("k", list(range(len(truth["x"]))))
            pts = [(k, x[j]) for k, x in zip(tk, truth["x"]) if ks[0] <= k <= ks[-1]]
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "k-", lw=2, label="truth")
        for label, xf in est:
            ax.plot(ks, [x[j] for x in xf], lw=1, label=label)
        ax.set_ylabel("x[%d]" % j)
    axes[0][0].legend(fontsize="small", ncol=3)
    axes[-1][0].set_xlabel("k")
    axes[0][0].set_title("%s: filter %s, x_{k|k}" % (out.get("scenario", ""), out.get("filter")))
    fig.tight_layout()
    if args.output:
        fig.savefig(args.output, dpi=100)
    else:
        plt.show()
    return 0


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m dkf", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("simulate", help="draw a scenario from a model (dkf.simulate)")
    s.add_argument("model", help="MODEL.json: the scenario keys model and init")
    s.add_argument("--steps", type=int, required=True, help="N, the steps (>= 1)")
    s.add_argument("--seed", type=int, default=None, help="numpy default_rng seed")
    s.add_argument("-o", "--output", required=True, help="SCN.json to write")
    r = sub.add_parser("run", help="run a filter over a scenario (dkf.run_scenario)")
    r.add_argument("scenario", help="SCN.json (a layout of dkf.SUPPORTED_FILTERS' filters)")
    r.add_argument("--filter", "-f", required=True, choices=SUPPORTED_FILTERS)
    r.add_argument("--run", "-r", type=int, default=0, help="Monte-Carlo run (default 0)")
    r.add_argument("--case", "-c", help="cases layout: the case, a name or an index (default 0)")
    r.add_argument("--d00", help="askf/otskf: d_{0|0} instead of init.d00, A,B,...")
    r.add_argument("--Pd00-scale", type=float, help="askf/otskf: P_{d0|0} = S * init.Pd00")
    r.add_argument("--eta", type=int, help="tw3: consensus iterations per ACF (overrides the "
                   "file's eta)")
    r.add_argument("--metrics-only", action="store_true",
                   help="tw1-3: record only the per-step metrics")
    r.add_argument("-o", "--output", required=True, help="OUT.json to write")
    g = sub.add_parser("plot", help="plot x_{k|k} of every estimator of OUT.json")
    g.add_argument("out_json", metavar="OUT.json")
    g.add_argument("--scenario", "-s", help="SCN.json: also plot its truth")
    g.add_argument("-o", "--output", help="PNG to write (default: a window)")
    return p


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command == "simulate":
            _write(simulate(args.model, args.steps, seed=args.seed), args.output)
        elif args.command == "run":
            d00 = [float(v) for v in args.d00.split(",")] if args.d00 is not None else None
            _write(run_scenario(args.scenario, filter=args.filter, run=args.run, case=args.case,
                                d00=d00, Pd00_scale=args.Pd00_scale, eta=args.eta,
                                metrics_only=args.metrics_only), args.output)
        else:
            return _plot(args)
    except Error as e:
        print("python -m dkf %s: %s" % (args.command, e), file=sys.stderr)
        return 3
    except (OSError, ValueError, KeyError, TypeError) as e:
        print("python -m dkf %s: %s" % (args.command, e), file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
