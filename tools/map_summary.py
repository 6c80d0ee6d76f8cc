#!/usr/bin/env python3
"""Bytes each input (archive or object) contributes to a GNU ld map file's
output, split into flash (text, rodata, data init) and RAM (data, bss).

usage: map_summary.py image.map
"""
import collections
import os
import re
import sys

# An input section line: " .text.name  0xADDR  0xSIZE  path(obj)" - the name
# may stand alone on the previous line when it is long.
SEC_RE = re.compile(r'^ (\.[\w.$]+)?\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$')


def owner(path):
    m = re.match(r'(.*?)\(([^)]*)\)$', path)
    if m:
        return os.path.basename(m.group(1))
    return os.path.basename(path)


def main():
    totals = collections.defaultdict(lambda: [0, 0])
    pending = None
    in_map = False
    with open(sys.argv[1], encoding='utf-8', errors='replace') as f:
        for line in f:
            if line.startswith('Linker script and memory map'):
                in_map = True
                continue
            if not in_map:
                continue
            if line.startswith('/DISCARD/'):
                break
            stripped = line.rstrip('\n')
            m = SEC_RE.match(stripped)
            if m:
                name = m.group(1) or pending
                pending = None
                size = int(m.group(3), 16)
                if name is None or size == 0 or int(m.group(2), 16) == 0:
                    continue
                src = owner(m.group(4).strip())
                if name.startswith(('.text', '.rodata', '.isr_vector', '.ARM.exidx', '.ARM.extab')):
                    totals[src][0] += size
                elif name.startswith('.data'):
                    totals[src][0] += size  # initial values live in flash
                    totals[src][1] += size
                elif name.startswith(('.bss', 'COMMON')):
                    totals[src][1] += size
                continue
            if re.match(r'^ \.[\w.$]+$', stripped) or stripped.startswith(' COMMON'):
                pending = stripped.strip()
    print('  %-24s %8s %8s' % ('input', 'flash', 'ram'))
    for src, (fl, ram) in sorted(totals.items(), key=lambda kv: -kv[1][0]):
        print('  %-24s %8d %8d' % (src, fl, ram))
    print('  %-24s %8d %8d' % ('total', sum(v[0] for v in totals.values()),
                                 sum(v[1] for v in totals.values())))


if __name__ == '__main__':
    main()
