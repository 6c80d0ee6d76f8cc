#!/usr/bin/env python3
"""Worst-case stack depth of given entry points, from GCC call-graph info.

Every object of the firmware build is compiled with
    -fstack-usage -fcallgraph-info=su
which makes GCC write, next to each object, a VCG graph (*.ci) holding one
node per function defined in that file, labelled with its frame size
("N bytes (static|dynamic|dynamic,bounded)"), and one edge per call site.
This script merges the graphs of all objects, and for functions that have
no node of their own (newlib's memcpy, sqrtf, ... compiled without the
flag) reads the frame and the direct calls from the disassembly of the ELF
(push/vpush/sub sp prologue, bl/b.w targets).

The bound of a function is its frame plus the largest bound among its
callees (the worst path through the call graph). It is exact for
non-recursive code without indirect calls; both are reported as errors,
as is any frame GCC calls "dynamic" (a VLA or alloca). An indirect call
is bounded only when --indirect names every function it can reach (the
callbacks an image gives the library, e.g. a nonlinear model's f, h,
y_diff): each indirect call site then counts as a call to each of them.

usage: stack_usage.py --elf image.elf --objdump arm-none-eabi-objdump \
                      [--indirect F,G,...] [--skip PATH_PART]... BUILD_DIR ROOT [ROOT...]
"""
import argparse
import glob
import os
import re
import subprocess
import sys

NODE_RE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
EDGE_RE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
FRAME_RE = re.compile(r'\\n(\d+) bytes \(([a-z,]+)\)')


def read_callgraph(build_dir, skip=()):
    frames, kinds, edges, names = {}, {}, {}, {}
    files = [f for f in glob.glob(os.path.join(build_dir, '**', '*.ci'), recursive=True)
             if not any(s in f for s in skip)]
    for path in files:
        with open(path, encoding='utf-8', errors='replace') as f:
            for line in f:
                m = NODE_RE.search(line)
                if m:
                    title, label = m.group(1), m.group(2)
                    names.setdefault(title, label.split('\\n')[0])
                    fm = FRAME_RE.search(label)
                    if fm:
                        frames[title] = int(fm.group(1))
                        kinds[title] = fm.group(2)
                    continue
                m = EDGE_RE.search(line)
                if m:
                    edges.setdefault(m.group(1), set()).add(m.group(2))
    return files, frames, kinds, edges, names


FUNC_RE = re.compile(r'^[0-9a-f]+ <([^>]+)>:$')
CALL_RE = re.compile(r'\t(?:bl|blx|b\.w|b)\t[0-9a-f]+ <([^>+]+)>')
PUSH_RE = re.compile(r'\t(?:push(?:\.w)?|stmdb(?:\.w)?\tsp!,)\s*\{([^}]*)\}')
VPUSH_RE = re.compile(r'\t(?:vpush|vstmdb\tsp!,)\s*\{([^}]*)\}')
SUBSP_RE = re.compile(r'\tsub(?:\.w|w)?\tsp, (?:sp, )?#(\d+)')
STRPRE_RE = re.compile(r'\tstr(?:\.w)?\t\w+, \[sp, #-(\d+)\]!')


def reg_count(regs, vfp):
    n = 0
    for part in regs.split(','):
        part = part.strip()
        if not part:
            continue
        if '-' in part:
            a, b = part.split('-')
            count = int(b[1:]) - int(a[1:]) + 1
        else:
            count = 1
        n += count * (8 if vfp and part.startswith('d') else 4)
    return n


def read_disassembly(elf, objdump):
    """frame bytes and direct callees of every function in the ELF."""
    out = subprocess.run([objdump, '-d', '--no-show-raw-insn', elf],
                         check=True, capture_output=True, text=True).stdout
    frames, calls, cur = {}, {}, None
    for line in out.splitlines():
        m = FUNC_RE.match(line)
        if m:
            cur = m.group(1)
            frames[cur], calls[cur] = 0, set()
            continue
        if cur is None:
            continue
        m = PUSH_RE.search(line)
        if m:
            frames[cur] += reg_count(m.group(1), False)
        m = VPUSH_RE.search(line)
        if m:
            frames[cur] += reg_count(m.group(1), True)
        m = SUBSP_RE.search(line)
        if m:
            frames[cur] += int(m.group(1))
        m = STRPRE_RE.search(line)
        if m:
            frames[cur] += int(m.group(1))
        m = CALL_RE.search(line)
        if m and m.group(1) != cur:
            calls[cur].add(m.group(1))
    return frames, calls


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--elf', required=True)
    ap.add_argument('--objdump', default='arm-none-eabi-objdump')
    ap.add_argument('--indirect', default='',
                    help='comma-separated functions every indirect call may reach')
    ap.add_argument('--skip', action='append', default=[],
                    help='ignore the *.ci files whose path contains this (another image)')
    ap.add_argument('build_dir')
    ap.add_argument('roots', nargs='+')
    args = ap.parse_args()

    files, frames, kinds, edges, names = read_callgraph(args.build_dir, args.skip)
    if not files:
        sys.exit('stack_usage: no *.ci files under %s (build with -fcallgraph-info=su)'
                 % args.build_dir)
    dis_frames, dis_calls = read_disassembly(args.elf, args.objdump)
    indirect = [t for t in args.indirect.split(',') if t]
    # a static function's node title is "file.c:name": find it by name
    title_of = {}
    for title, name in names.items():
        title_of.setdefault(name, title)
    problems = []
    memo = {}

    def frame_and_callees(fn):
        if fn in frames:
            if kinds[fn] != 'static':
                problems.append('%s has a %s frame' % (names.get(fn, fn), kinds[fn]))
            return frames[fn], edges.get(fn, set()), 'su'
        sym = names.get(fn, fn)
        if sym.startswith('__builtin_'):
            sym = sym[len('__builtin_'):]
        for cand in (fn, sym):
            if cand in dis_frames:
                return dis_frames[cand], dis_calls[cand], 'disasm'
        # Not in the image: inlined or removed by --gc-sections, costs 0.
        return 0, set(), 'absent'

    def worst(fn, stack):
        if fn in memo:
            return memo[fn]
        if fn in stack:
            problems.append('recursion: ' + ' -> '.join(stack + [fn]))
            return 0, [fn]
        if fn == '__indirect_call':
            if not indirect:
                problems.append('indirect call from ' + stack[-1])
                return 0, [fn]
            best, best_path = 0, []
            for t in indirect:
                b, p = worst(title_of.get(t, t), stack + [fn])
                if b > best:
                    best, best_path = b, p
            return best, ['(indirect)'] + best_path
        frame, callees, src = frame_and_callees(fn)
        best, best_path = 0, []
        for c in sorted(callees):
            b, p = worst(c, stack + [fn])
            if b > best:
                best, best_path = b, p
        label = '%s(%d%s)' % (names.get(fn, fn).replace('__builtin_', ''), frame,
                              '' if src == 'su' else ',' + src)
        memo[fn] = (frame + best, [label] + best_path)
        return memo[fn]

    for root in args.roots:
        total, path = worst(root, [])
        print('%-16s %5d bytes  %s' % (root, total, ' -> '.join(path)))
    for p in sorted(set(problems)):
        print('stack_usage: ERROR: ' + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
