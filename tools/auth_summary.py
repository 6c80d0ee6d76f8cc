#!/usr/bin/env python3
"""auth_summary.py RESULT.json... - one line on the authentication of a run's
processes (the "auth" object of dkf-tw-node's and dkf-fusion's result files,
docs/guide/network.md "Authentication"): the modes, the datagrams accepted and
rejected, summed over the files.

Exit 0 when every file was authenticated and nothing was rejected (a demo's
clean run), 1 otherwise (a process ran unauthenticated, or a datagram was
refused), 2 when a file cannot be read.
"""
import argparse
import json
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="+", help="result files (JSON)")
    ap.add_argument("--what", default="", help="words after the mode, e.g. 'a key per edge'")
    a = ap.parse_args()
    acc = rej = 0
    modes = set()
    for f in a.results:
        try:
            auth = json.load(open(f)).get("auth", {})
        except (OSError, ValueError) as e:
            print(f"auth_summary.py: {f}: {e}", file=sys.stderr)
            return 2
        modes.add(auth.get("mode", "off"))
        counts = auth.get("datagrams", {})
        acc += counts.get("accepted", 0)
        rej += sum(v for k, v in counts.items() if k != "accepted")
    what = f", {a.what}" if a.what else ""
    print(f"authentication: {', '.join(sorted(modes))}{what}; {len(a.results)} processes, "
          f"datagrams accepted {acc}, rejected {rej}")
    return 0 if modes == {"hmac-sha512-256"} and rej == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
