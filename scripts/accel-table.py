#!/usr/bin/env python3
"""The README's ray-query table from bench_accel's output.

Usage: scripts/bench-accel.sh | tee docs/bench/bench-accel.txt
       python3 scripts/accel-table.py docs/bench/bench-accel.txt

Each cell is time(grid) / time(Embree) of one row's medians: CPU time for one thread (1t),
wall-clock time for all threads (2t); the build's wall-clock time; the bytes per triangle
each back-end reports.
"""
import sys, re
rows = {}
units = {'ns': 1e-6, 'us': 1e-3, 'ms': 1.0, 's': 1e3}
bytes_ = {}
scene = None
for line in open(sys.argv[1]):
    line = re.sub(r'\x1b\[[0-9;]*m', '', line)
    m = re.match(r'^(\w+): \d+ triangles', line)
    if m: scene = m.group(1)
    m = re.match(r'\s+\[(grid|embree)\] (?:grid|embree) bytes: \d+ \(([\d.]+) per triangle', line)
    if m and scene: bytes_[(scene, m.group(1))] = m.group(2)
    m = re.match(r'^(\S+)_median\s+([\d.]+) (\w+)\s+([\d.]+) (\w+)', line)
    if not m: continue
    name = m.group(1)
    parts = name.split('/')
    sc, kind, accel = parts[0], parts[1], parts[2]
    if kind == 'build': t = float(m.group(2)) * units[m.group(3)]; th = 'build'
    elif parts[3] == '1t': t = float(m.group(4)) * units[m.group(5)]; th = '1t'  # CPU time
    else: t = float(m.group(2)) * units[m.group(3)]; th = '2t'
    rows[(sc, kind, accel, th)] = t
def fmt(b):
    return '?' if b is None else '%.0f' % float(b)


order = ['gazebo', 'castle', 'stadium', 'trees', 'garden']
print('| scene | camera 1t / 2t | camera packets 1t / 2t | shadow 1t / 2t | shadow packets 1t / 2t | short 1t / 2t | build | bytes per triangle, grid / Embree |')
print('|---|---|---|---|---|---|---|---|')
for sc in order:
    if not any(k[0] == sc for k in rows): continue
    cells = []
    for kind in ['camera', 'camera-packets', 'shadow', 'shadow-packets', 'short']:
        r = [(rows.get((sc, kind, 'grid', th)), rows.get((sc, kind, 'embree', th))) for th in ['1t', '2t']]
        cells.append(' / '.join('%.2f' % (g / e) if g and e else '?' for g, e in r))
    gb, eb = rows.get((sc, 'build', 'grid', 'build')), rows.get((sc, 'build', 'embree', 'build'))
    cells.append('%.2f' % (gb / eb) if gb and eb else '?')
    cells.append('%s / %s' % (fmt(bytes_.get((sc, 'grid'))), fmt(bytes_.get((sc, 'embree')))))
    print('| %s | %s |' % (sc, ' | '.join(cells)))
