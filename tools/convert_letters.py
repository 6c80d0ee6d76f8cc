#!/usr/bin/env python3
"""Rewrites a scenario file's model matrices in the library's letters.

    convert_letters.py [--indent N] IN.json [OUT.json]    (OUT: default IN, in place)

The keys renamed are exactly those dkf-run's reader renames as it reads an
old file (ports/linux/scenario/scn_letters.c; docs/reference/scenario-format.md,
"Letters"), in the objects it renames them in, each with its `_prev` form:

    canonical (model, model.sensors[])    A -> D
    cases (cases[])                        C -> H
    steps (model, steps[].inputs)          H -> D, C -> H, A -> F (H first)
    steps with graph (same objects)        A -> F, B -> G, Sv -> Q, Sw -> R

Every other key, every string and every number is written back unchanged
(a number as the shortest text that reads back to the same double), a key
keeps its place in its object. The output is compact JSON (no spaces, ASCII,
the form of tests/vectors/; --indent N: indented) with the input's trailing
newline if it had one; it is a function of the input's parsed content alone,
so the same input always gives the same bytes. A file already in the
library's letters is not rewritten (copied as it is to OUT); a file mixing
both conventions is refused, as the reader refuses it.

Exit status: 0 converted or nothing to convert; 1 mixed letters; 2 usage or
an unreadable file.
"""
import argparse
import json
import sys

# Per layout: the renames in the order the reader applies them, the letters
# only the old convention has, the letters only the library's has.
LETTERS = {
    "canonical": ((("A", "D"),), ("A",), ("D",)),
    "cases": ((("C", "H"),), ("C",), ("H",)),
    "steps": ((("H", "D"), ("C", "H"), ("A", "F")), ("A", "C"), ("F", "D")),
    "network": ((("A", "F"), ("B", "G"), ("Sv", "Q"), ("Sw", "R")),
                ("A", "B", "Sv", "Sw"), ("F", "G", "Q", "R")),
}


def layout(root):
    """The layout whose letters root's matrices have (scenario.c letters_layout)."""
    if "cases" in root:
        return "cases"
    if "steps" in root and "y" not in root and "runs" not in root:
        return "network" if "graph" in root else "steps"
    return "canonical"


def matrix_objects(root, lay):
    """Every object of root that holds the model's matrices (scn_letters.c visit_all)."""
    def objects(items):
        return [o for o in items if isinstance(o, dict)]

    def listed(v):
        return v if isinstance(v, list) else []

    if lay == "cases":
        return objects(listed(root.get("cases")))
    model = root.get("model")
    found = objects([model])
    if lay == "canonical":
        return found + objects(listed(model.get("sensors") if isinstance(model, dict) else None))
    return found + objects(st.get("inputs") for st in objects(listed(root.get("steps"))))


def first_letter(objs, letters):
    """The first key (or its _prev) of letters found in objs, or None."""
    for obj in objs:
        for letter in letters:
            for key in (letter, letter + "_prev"):
                if key in obj:
                    return key
    return None


def rename(objs, renames):
    """Each (old, new) of renames, in order, in every object of objs: old and
    old_prev become new and new_prev, each in its key's place."""
    for obj in objs:
        keys = dict(obj)
        for old, new in renames:
            names = {old: new, old + "_prev": new + "_prev"}
            keys = {names.get(key, key): value for key, value in keys.items()}
        obj.clear()
        obj.update(keys)


def convert(root):
    """root in the library's letters, in place; False if it had no old letter.
    Raises ValueError if it mixes both conventions."""
    lay = layout(root)
    renames, old_only, new_only = LETTERS[lay]
    objs = matrix_objects(root, lay)
    old, new = first_letter(objs, old_only), first_letter(objs, new_only)
    if old is None:
        return False
    if new is not None:
        raise ValueError("the library's letters (%s) mixed with the old ones (%s)" % (new, old))
    rename(objs, renames)
    return True


def refuse_constant(name):
    raise ValueError("%s is not JSON" % name)


def fail(path, msg, status):
    print("convert_letters.py: %s: %s" % (path, msg), file=sys.stderr)
    return status


def main():
    ap = argparse.ArgumentParser(description="A scenario file's model matrices in the "
                                 "library's letters (docs/reference/scenario-format.md, \"Letters\").")
    ap.add_argument("input")
    ap.add_argument("output", nargs="?", help="default: the input, rewritten in place")
    ap.add_argument("--indent", type=int, default=None,
                    help="indent the output by N spaces (default: compact, one line)")
    args = ap.parse_args()
    try:
        with open(args.input, encoding="utf-8") as f:
            text = f.read()
        root = json.loads(text, parse_constant=refuse_constant)
    except (OSError, ValueError) as e:
        return fail(args.input, e, 2)
    if not isinstance(root, dict):
        return fail(args.input, "not a JSON object", 2)
    try:
        done = convert(root)
    except ValueError as e:
        return fail(args.input, e, 1)
    if done:
        newline = "\n" if text.endswith("\n") or args.indent is not None else ""
        sep = (",", ":") if args.indent is None else (",", ": ")
        try:  # a number beyond a double's range would be written Infinity
            text = json.dumps(root, separators=sep, indent=args.indent, allow_nan=False)
        except ValueError:
            return fail(args.input, "a number out of a double's range", 2)
        text += newline
    if done or args.output is not None:
        with open(args.output or args.input, "w", encoding="utf-8") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
