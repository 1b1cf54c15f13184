#!/usr/bin/env python3
"""Helper of scripts/qemu-profile.sh.

count LOG: executed instructions per guest address from a `qemu -d in_asm,exec,nochain` log
(each translation block's instructions from `in_asm`, its executions from `exec`), printed as
`address count` lines.
diff PC_A ELF_A PC_B ELF_B SAMPLES: (B - A) / SAMPLES by source line, innermost function and
outermost estimator-core frame, each run symbolized against its own ELF (the two builds differ
in a constant, so their addresses may too); only code inlined from estimator-core outside the
bench's motion model counts.
"""
import collections
import os
import re
import subprocess
import sys


def count(log):
    blocks, execs, cur = {}, collections.Counter(), None
    trace = re.compile(r'Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/')
    with open(log, errors='replace') as f:
        for line in f:
            if line.startswith('IN:'):
                cur = None
            elif line.startswith('0x'):
                pc = int(line[2:10], 16)
                if cur is None:
                    cur = pc
                    blocks[cur] = []
                blocks[cur].append(pc)
            elif line.startswith('Trace'):
                m = trace.search(line)
                if m:
                    cur = None
                    execs[int(m.group(1), 16)] += 1
    per_pc = collections.Counter()
    for pc, k in execs.items():
        for a in blocks.get(pc, []):
            per_pc[a] += k
    for a in sorted(per_pc):
        print('%x %d' % (a, per_pc[a]))


def tally(pcfile, elf):
    pcs = [line.split() for line in open(pcfile)]
    query = ''.join('0x%s\n' % p[0] for p in pcs)
    out = subprocess.run(['llvm-symbolizer', '--obj=' + elf, '--inlining',
                          '--functions=linkage', '-C'],
                         input=query, capture_output=True, text=True, check=True).stdout
    by = [collections.Counter() for _ in range(3)]
    for (_, c), blk in zip(pcs, out.strip('\n').split('\n\n')):
        lines = blk.split('\n')
        frames = [(lines[i], lines[i + 1]) for i in range(0, len(lines) - 1, 2)]
        whole = ' '.join(f[0] + f[1] for f in frames)
        if not frames or 'estimator' not in whole or 'scenario' in whole \
                or 'qemu_bench' in whole:
            continue
        c = int(c)
        by[0][frames[0][1].replace(os.getcwd() + '/', '').rsplit(':', 1)[0]] += c
        by[1][frames[0][0][:120]] += c
        est = [f for f in frames if 'estimator-core' in f[1]]
        if est:
            by[2][est[-1][1].split('estimator-core/')[-1].rsplit(':', 1)[0]] += c
    return by


def diff(pa, ea, pb, eb, samples):
    a, b = tally(pa, ea), tally(pb, eb)
    for title, x, y in zip(['source line (innermost)', 'function (innermost)',
                            'estimator-core line (outermost)'], a, b):
        d = {k: y[k] - x[k] for k in set(x) | set(y)}
        print('--- instructions per estimate by %s: total %.0f' % (title, sum(d.values()) / samples))
        for k, v in sorted(d.items(), key=lambda kv: -abs(kv[1]))[:40]:
            print('%8.1f  %s' % (v / samples, k))


if __name__ == '__main__':
    if sys.argv[1] == 'count':
        count(sys.argv[2])
    else:
        diff(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], float(sys.argv[6]))
