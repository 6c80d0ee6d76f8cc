#!/usr/bin/env python3
"""lcm_fused_decode.py TYPES_DIR MSG.bin: decodes the dkf_lcm.fused_t that
fused_dump wrote (the generated C encoder) with the generated Python type
from TYPES_DIR, as tools/dkf_monitor.py and any Python LCM subscriber do, and
checks every field, indexing contributed[0] (Debian's lcm-gen 1.3.1 made
contributed a `map` object in Python 3, where m.contributed[0] raises
TypeError). Prints PASS and exits 0, or names the first wrong field."""
import sys


def main():
    types_dir, path = sys.argv[1], sys.argv[2]
    sys.path.insert(0, types_dir)
    from dkf_lcm import fused_t

    with open(path, "rb") as f:
        m = fused_t.decode(f.read())
    want = {
        "utime": 1700000000000000, "model_id": 42, "k": 7, "seq": 8,
        "status": fused_t.DEGRADED, "nnodes": 3, "meas_utime_first": 11,
        "meas_utime_last": 12, "msg_utime_last": 13, "n": 2, "revision": 1,
        "xf": [1.5, -2.25], "xp": [1.0, -2.0], "Pf": [[2.0, 0.5], [0.5, 3.0]],
        "Pp": [[4.0, 1.0], [1.0, 5.0]],
    }
    if m.contributed[0] is not True or m.contributed[1] is not False:
        print("FAIL: contributed[0], contributed[1] = %r, %r" % (m.contributed[0],
                                                               m.contributed[1]))
        return 1
    if not isinstance(m.contributed, list) or m.contributed != [True, False, True]:
        print("FAIL: contributed = %r, expected the list [True, False, True]" % (m.contributed,))
        return 1
    for key, value in want.items():
        got = getattr(m, key)
        if isinstance(got, tuple):
            got = list(got)
        if isinstance(got, list) and got and isinstance(got[0], tuple):
            got = [list(r) for r in got]
        if got != value:
            print("FAIL: %s = %r, expected %r" % (key, got, value))
            return 1
    print("PASS: fused_t decoded in Python, contributed[0] = %r" % m.contributed[0])
    return 0


if __name__ == "__main__":
    sys.exit(main())
