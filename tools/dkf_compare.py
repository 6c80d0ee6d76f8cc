#!/usr/bin/env python3
"""Compare the numeric arrays of two JSON files (dkf-run outputs, golden vectors).

    dkf_compare.py OUT.json VECTOR.json [--keys outputs.KF] [--rel 1e-9]
    dkf_compare.py OUT.json OUT.json --a-keys outputs.fused --b-keys outputs.central

Under the key path given for each file (--keys for both, --a-keys/--b-keys
to differ), every numeric array present on both sides is compared with the
rule of the golden-vector READMEs

    max|a - b| <= atol + rel * max(1, max|b|)        (per array; B is the reference)

A numeric array is a number or an arbitrarily nested list of numbers (a
whole per-step series such as xf counts as one array; --per-step applies the
rule to each step, i.e. each entry of the first axis, instead). Objects are
matched by key, lists of objects by position; strings are ignored.

Key paths: dot-separated keys and [i] indices, e.g. outputs.local[1]. The
index [*] gathers over a list: cases[0].steps[*].expected turns a list of
per-step objects into one object of per-step lists, which is how dkf-run
lays out its outputs. A key that only some steps have (the seed-003
vectors' intermediates on the first steps) gathers with null at the other
steps; null entries of B are skipped, so those steps are compared one by one.

Integer arrays (every value a JSON integer on both sides, e.g. `rank`) must
match exactly, and so must boolean arrays (every value true/false on both
sides, e.g. `matrix_weights_unique`). --only-where FLAG keeps, of the two
lists the key paths give, only the entries where the boolean list FLAG (a
key path in B) is true: the seed-002 vector's matrix weights are unique, so
comparable, only where `matrix_weights_unique` is (--b-keys
'cases[0].steps[*].expected.matrix_weights' --only-where
'cases[0].steps[*].expected.matrix_weights_unique'). --require-all makes a numeric array of B that A lacks a
failure (by default it is skipped).

A comparison must reach at least one real-valued array: when every array
compared is an integer one (only the time index `k`, say, because the key
paths point at the wrong level), that is a failure, not a pass.

Exit status: 0 all compared arrays pass; 1 a mismatch, nothing compared, or
only integer arrays compared; 2 bad arguments, unreadable file, or a key
path that does not exist.

Where the estimates sit (docs/reference/scenario-format.md, "Outputs of the steps-layout filters" and "Outputs"):
dkf-run writes outputs.<LABEL>.<key> as per-step lists; the seed-000 vectors
(tests/vectors/diffkf) have the same layout (--keys outputs.DKF), the
seed-003/004 vectors (tests/vectors/uif) keep per-step objects, e.g.
--a-keys outputs.RTSF --b-keys 'steps[*].expected' --per-step --require-all.
"""
import argparse
import json
import math
import re
import sys

TOKEN = re.compile(r"([^.\[\]]+)|\[(\*|\d+)\]|(\.)")


class PathError(Exception):
    pass


def parse_path(path):
    """'a.b[2].c[*]' -> ['a', 'b', 2, 'c', '*']."""
    out, pos = [], 0
    for m in TOKEN.finditer(path):
        if m.start() != pos:
            raise PathError("bad key path %r at %r" % (path, path[pos:]))
        pos = m.end()
        if m.group(1) is not None:
            out.append(m.group(1))
        elif m.group(2) is not None:
            out.append("*" if m.group(2) == "*" else int(m.group(2)))
    if pos != len(path):
        raise PathError("bad key path %r" % path)
    return out


def gather(items):
    """[{k: v0}, {k: v1}, {}] -> {k: [v0, v1, None]} (union of keys, None where an
    item lacks one); else the list. None items count as empty objects."""
    present = [x for x in items if x is not None]
    if present and all(isinstance(x, dict) for x in present):
        keys = []
        for x in present:
            keys.extend(k for k in x if k not in keys)
        out = {}
        for k in keys:
            vals = [x.get(k) if isinstance(x, dict) else None for x in items]
            given = [v for v in vals if v is not None]
            out[k] = gather(vals) if given and all(isinstance(v, dict) for v in given) else vals
        return out
    return items


def resolve(doc, tokens, shown=""):
    """Follows tokens into doc; raises PathError naming the missing piece."""
    for i, t in enumerate(tokens):
        if t == "*":
            if not isinstance(doc, list):
                raise PathError("%s: [*] needs a list" % (shown or "(top)"))
            return gather([resolve(x, tokens[i + 1:], "%s[%d]" % (shown, j))
                           for j, x in enumerate(doc)])
        if isinstance(t, int):
            if not isinstance(doc, list) or t >= len(doc):
                raise PathError("%s[%d]: no such list entry" % (shown, t))
            doc, shown = doc[t], "%s[%d]" % (shown, t)
        else:
            if not isinstance(doc, dict) or t not in doc:
                raise PathError("%s: missing key" % (shown + "." + t if shown else t))
            doc, shown = doc[t], (shown + "." + t if shown else t)
    return doc


def is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def flatten(x):
    """(values, structure) of a number or nested list of numbers, else None."""
    if is_number(x):
        return [float(x)], ()
    if isinstance(x, list):
        vals, shape = [], []
        for e in x:
            f = flatten(e)
            if f is None:
                return None
            vals.extend(f[0])
            shape.append(f[1])
        return vals, tuple(shape)
    return None


def shape_str(x):
    dims = []
    while isinstance(x, list):
        dims.append(len(x))
        if not x:
            break
        x = x[0]
    return "x".join(str(d) for d in dims) if dims else "scalar"


def all_bools(x):
    """True if x is a JSON boolean or a nested list of only booleans."""
    if isinstance(x, list):
        return bool(x) and all(all_bools(e) for e in x)
    return isinstance(x, bool)


def all_ints(x):
    """True if x is a JSON integer or a nested list of only JSON integers."""
    if isinstance(x, list):
        return all(all_ints(e) for e in x)
    return isinstance(x, int) and not isinstance(x, bool)


def check_array(a, b, rel, atol):
    """(max error, bound, ok) for flattened a against reference b."""
    if not b:
        return 0.0, atol, True
    scale = max(1.0, max(abs(v) for v in b))
    err = max(abs(p - q) for p, q in zip(a, b))
    bound = atol + rel * scale
    finite = all(math.isfinite(v) for v in a) and all(math.isfinite(v) for v in b)
    return err, bound, finite and err <= bound


def has_numbers(x):
    if is_number(x):
        return True
    if isinstance(x, list):
        return any(has_numbers(e) for e in x)
    if isinstance(x, dict):
        return any(has_numbers(e) for e in x.values())
    return False


def compare(a, b, key, args, rows):
    if b is None:
        return  # a step where the reference has no such field
    if isinstance(a, dict) and isinstance(b, dict):
        for k in b:
            sub = key + "." + k if key else k
            if k in a:
                compare(a[k], b[k], sub, args, rows)
            elif args.require_all and has_numbers(b[k]):
                rows.append((sub, "missing in A", float("nan"), 0.0, False, True))
        return
    if all_bools(a) and all_bools(b):
        same = json.dumps(a) == json.dumps(b)
        # a flag is a result (unlike an index such as k): it counts as compared
        rows.append((key, shape_str(b) + " boolean", 0.0 if same else 1.0, 0.0, same, True))
        return
    fa, fb = flatten(a), flatten(b)
    if fa is not None and fb is not None:
        if fa[1] != fb[1]:
            rows.append((key, shape_str(a) + " vs " + shape_str(b), float("nan"), 0.0, False,
                         True))
            return
        if all_ints(a) and all_ints(b):
            err = max((abs(p - q) for p, q in zip(fa[0], fb[0])), default=0.0)
            rows.append((key, shape_str(b) + " integer", err, 0.0, err == 0, False))
            return
        if args.per_step and isinstance(b, list) and b and isinstance(b[0], list):
            steps = [check_array(flatten(x)[0], flatten(y)[0], args.rel, args.atol)
                     for x, y in zip(a, b)]
            worst = max(steps, key=lambda r: r[0] / r[1] if r[1] > 0 else math.inf)
            worst = (worst[0], worst[1], all(r[2] for r in steps))
            rows.append((key, shape_str(b) + " per step") + worst + (True,))
        else:
            rows.append((key, shape_str(b)) + check_array(fa[0], fb[0], args.rel, args.atol)
                        + (True,))
        return
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            rows.append((key, "%d vs %d entries" % (len(a), len(b)), float("nan"), 0.0, False,
                         True))
            return
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, "%s[%d]" % (key, i), args, rows)
        return
    if (fa is None) != (fb is None) and not isinstance(a, str) and not isinstance(b, str):
        rows.append((key, "type mismatch", float("nan"), 0.0, False, True))


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise PathError("%s: %s" % (path, e))


def main(argv=None):
    ap = argparse.ArgumentParser(
        description="Compare numeric arrays of two JSON files key by key "
                    "(rule: max|a-b| <= atol + rel*max(1, max|b|) per array; B is the reference).",
        epilog="examples: dkf_compare.py out.json tests/vectors/diffkf/ex1_single.json "
               "--keys outputs.DKF;  dkf_compare.py out.json tests/vectors/uif/s004_rtsf.json "
               "--a-keys outputs.RTSF --b-keys 'steps[*].expected' --per-step --require-all")
    ap.add_argument("a", help="JSON file under test (e.g. a dkf-run output)")
    ap.add_argument("b", help="reference JSON file (e.g. a golden vector)")
    ap.add_argument("--keys", default="", help="key path used in both files (default: top level)")
    ap.add_argument("--a-keys", help="key path in A (overrides --keys)")
    ap.add_argument("--b-keys", help="key path in B (overrides --keys)")
    ap.add_argument("--rel", type=float, default=1e-9, help="relative tolerance (default 1e-9)")
    ap.add_argument("--atol", type=float, default=0.0, help="absolute tolerance (default 0)")
    ap.add_argument("--per-step", action="store_true",
                    help="apply the rule to each entry of an array's first axis")
    ap.add_argument("--require-all", action="store_true",
                    help="fail when A lacks a numeric array that B has (default: skip it)")
    ap.add_argument("--only-where", metavar="FLAG",
                    help="key path in B of a list of booleans: compare only the entries of the "
                         "two lists where it is true")
    ap.add_argument("--quiet", action="store_true", help="print failures and the verdict only")
    args = ap.parse_args(argv)

    try:
        ka = args.a_keys if args.a_keys is not None else args.keys
        kb = args.b_keys if args.b_keys is not None else args.keys
        a = resolve(load(args.a), parse_path(ka) if ka else [])
        bdoc = load(args.b)
        b = resolve(bdoc, parse_path(kb) if kb else [])
        if args.only_where is not None:
            flags = resolve(bdoc, parse_path(args.only_where))
            if not isinstance(flags, list) or not all(isinstance(f, bool) for f in flags):
                raise PathError("--only-where %s: expected a list of booleans" % args.only_where)
            if not isinstance(a, list) or not isinstance(b, list) or \
                    len(a) != len(flags) or len(b) != len(flags):
                def what(x):
                    return "a list of %d" % len(x) if isinstance(x, list) else "not a list"
                raise PathError("--only-where %s: %d flags; A gives %s, B %s"
                                % (args.only_where, len(flags), what(a), what(b)))
            a = [x for x, f in zip(a, flags) if f]
            b = [x for x, f in zip(b, flags) if f]
            print("only where %s: %d of %d entries" % (args.only_where, len(b), len(flags)))
    except PathError as e:
        print("dkf_compare: %s" % e, file=sys.stderr)
        return 2

    rows = []
    compare(a, b, "", args, rows)
    width = max([len("key")] + [len(r[0] or "(top)") for r in rows])
    print("A = %s : %s" % (args.a, ka or "(top)"))
    print("B = %s : %s" % (args.b, kb or "(top)"))
    print("%-*s  %-18s %12s %12s  %s" % (width, "key", "shape", "max|a-b|", "bound", "pass"))
    for key, shape, err, bound, ok, _ in rows:
        if ok and args.quiet:
            continue
        print("%-*s  %-18s %12.3e %12.3e  %s" % (width, key or "(top)", shape, err, bound,
                                                 "ok" if ok else "FAIL"))
    failed = sum(1 for r in rows if not r[4])
    if not rows:
        print("FAIL: nothing compared (no numeric array present in both)")
        return 1
    if not any(r[5] for r in rows):
        print("FAIL: only integer arrays compared (%s), no estimate: point --keys or "
              "--a-keys/--b-keys at the values (see --help)"
              % ", ".join(r[0] or "(top)" for r in rows))
        return 1
    print("%s: %d array(s) compared, %d failed (rel %g, atol %g)" %
          ("FAIL" if failed else "PASS", len(rows), failed, args.rel, args.atol))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
