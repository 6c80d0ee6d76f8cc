#!/usr/bin/env python3
"""Checks the host's layer rules (docs/layout.md, "Host layers"; decision 40).

    tools/check_layers.py ports/linux [--core libdkf.a --core-include include/dkf LIB.a ...]

Every file named LAYERS under the host directory lists layer folders, one
per line, lowest first (blank lines and lines starting with # are
ignored). A listed folder that has a LAYERS file of its own is made of the
layers that file lists, in its place in the order. The rules:

  1. a layer's C files include headers only from their own layer and the
     layers listed before it (and the core's dkf/, system and third-party
     headers: anything not found in a layer); never another layer's
     private/ headers;
  2. no include cycle between layers;
  3. no directory of a layer holds more than 15 C files;
  4. with --core, no global symbol defined in the given host libraries
     starts with a core module prefix: dkf_<module>_ of every symbol the
     core library defines (dkf_kf_, dkf_tw_, ...) and, with --core-include,
     of every name its public headers declare (types too: dkf_ui_).

Exit status 0 when every rule holds, 1 with one line per violation.
"""
import argparse
import os
import re
import subprocess
import sys

MAX_C_FILES = 15
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
CORE_SYMBOL = re.compile(r"^dkf_([a-z0-9]+)_")


def read_layers(path):
    with open(path, encoding="utf-8") as f:
        return [ln.strip() for ln in f if ln.strip() and not ln.lstrip().startswith("#")]


def layer_order(root, rel=""):
    """The layers under root/rel in order, as paths relative to root."""
    order = []
    for name in read_layers(os.path.join(root, rel, "LAYERS")):
        sub = os.path.normpath(os.path.join(rel, name))
        if not os.path.isdir(os.path.join(root, sub)):
            raise SystemExit(f"check_layers: {os.path.join(rel, 'LAYERS')}: {name}: no such folder")
        if os.path.isfile(os.path.join(root, sub, "LAYERS")):
            order += layer_order(root, sub)
        else:
            order.append(sub)
    return order


def layer_files(root, layer, layers):
    """The .c and .h files of a layer: its folder's, minus other layers' folders."""
    out = []
    for d, subdirs, files in os.walk(os.path.join(root, layer)):
        rel = os.path.relpath(d, root)
        subdirs[:] = [s for s in subdirs if os.path.normpath(os.path.join(rel, s)) not in layers]
        out += [os.path.join(d, f) for f in sorted(files) if f.endswith((".c", ".h"))]
    return out


def owner(path, root, layers):
    """The layer holding path (the longest layer folder that contains it)."""
    rel = os.path.relpath(path, root)
    best = None
    for layer in layers:
        if rel.startswith(layer + os.sep) and (best is None or len(layer) > len(best)):
            best = layer
    return best


def resolve(inc, src, root, layers):
    """The header an #include "inc" of src names: the including file's
    folder first, then every layer folder and its private/ (as the build's
    include paths); [] when no layer has it (a core or outside header)."""
    local = os.path.normpath(os.path.join(os.path.dirname(src), inc))
    if os.path.isfile(local):
        return [local]
    found = []
    for layer in layers:
        for d in (layer, os.path.join(layer, "private")):
            p = os.path.normpath(os.path.join(root, d, inc))
            if os.path.isfile(p):
                found.append(p)
    return found


def is_private(path, root, layer):
    rel = os.path.relpath(path, os.path.join(root, layer))
    return rel.split(os.sep)[0] == "private"


def check_includes(root, layers, problems):
    """Rules 1 and 3; returns the layer graph (edges to lower layers)."""
    rank = {layer: i for i, layer in enumerate(layers)}
    graph = {layer: set() for layer in layers}
    for layer in layers:
        files = layer_files(root, layer, set(layers))
        per_dir = {}
        for f in files:
            if f.endswith(".c"):
                per_dir[os.path.dirname(f)] = per_dir.get(os.path.dirname(f), 0) + 1
        for d, n in sorted(per_dir.items()):
            if n > MAX_C_FILES:
                problems.append(f"{os.path.relpath(d, root)}: {n} C files (at most {MAX_C_FILES})")
        for f in files:
            with open(f, encoding="utf-8", errors="replace") as fh:
                text = fh.read()
            for inc in INCLUDE.findall(text):
                found = resolve(inc, f, root, layers)
                where = os.path.relpath(f, root)
                if len(found) > 1:
                    problems.append(f'{where}: "{inc}" names {len(found)} headers: '
                                    + ", ".join(os.path.relpath(p, root) for p in found))
                    continue
                if not found:
                    continue
                target = owner(found[0], root, layers)
                if target is None or target == layer:
                    continue
                graph[layer].add(target)
                if rank[target] > rank[layer]:
                    problems.append(f'{where}: includes "{inc}" of {target}, a layer above {layer}')
                if is_private(found[0], root, target):
                    problems.append(f'{where}: includes "{inc}", private to {target}')
    return graph


def find_cycle(graph):
    """A cycle of layers (a list, first == last), or None."""
    state = {}

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                cycle = visit(nxt, path + [nxt])
                if cycle:
                    return cycle
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            cycle = visit(node, [node])
            if cycle:
                return cycle
    return None


def defined_globals(lib):
    out = subprocess.run(["nm", "-g", "--defined-only", lib], capture_output=True, text=True,
                         check=True).stdout
    return {ln.split()[-1] for ln in out.splitlines() if len(ln.split()) >= 3}


def check_symbols(core, include, libs, problems):
    """Rule 4: the core's module prefixes, from its own names."""
    names = set(defined_globals(core))
    for h in sorted(os.listdir(include)) if include else []:
        if h.endswith(".h"):
            with open(os.path.join(include, h), encoding="utf-8") as f:
                names |= set(re.findall(r"\bdkf_[a-z0-9]+_\w*", f.read()))
    prefixes = set()
    for sym in names:
        m = CORE_SYMBOL.match(sym)
        if m:
            prefixes.add(f"dkf_{m.group(1)}_")
    if not prefixes:
        problems.append(f"{core}: no dkf_<module>_ symbol (not the core library?)")
    count = 0
    for lib in libs:
        for sym in sorted(defined_globals(lib)):
            count += 1
            hit = [p for p in prefixes if sym.startswith(p)]
            if hit:
                problems.append(f"{os.path.basename(lib)}: {sym}: a host symbol with the core "
                                f"prefix {hit[0]}")
    return len(prefixes), count


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("root", help="the host directory (ports/linux), holding LAYERS")
    ap.add_argument("--core", help="the core library, whose dkf_<module>_ prefixes host "
                    "symbols may not use")
    ap.add_argument("--core-include", help="the core's public headers (include/dkf), whose "
                    "dkf_<module>_ names count as the core's too")
    ap.add_argument("libs", nargs="*", help="the host libraries to check with nm")
    a = ap.parse_intermixed_args()
    root = os.path.abspath(a.root)
    layers = layer_order(root)
    problems = []
    graph = check_includes(root, layers, problems)
    cycle = find_cycle(graph)
    if cycle:
        problems.append("include cycle between layers: " + " -> ".join(cycle))
    summary = f"{len(layers)} layers"
    if a.core:
        nprefix, nsym = check_symbols(a.core, a.core_include, a.libs, problems)
        summary += f", {nsym} host symbols against {nprefix} core prefixes"
    for p in problems:
        print(f"check_layers: {p}")
    if problems:
        print(f"check_layers: FAILED ({len(problems)} problems; {summary})")
        return 1
    print(f"check_layers: OK ({summary})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
