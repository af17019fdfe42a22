"""Writes small VDB files for the tests with Debian's pyopenvdb (run by /usr/bin/python3).

usage: make_vdb.py OUT.vdb
Grids, in file order:
  0 'density'  constant 8^3 leaf of 1.0 at the origin, identity transform
  1 'density'  (same name) 2.0 over a 10^3 box, rotated, mirrored, non-uniformly scaled
  2 'velocity' a vec3s grid
"""
import sys

import pyopenvdb as vdb

out = sys.argv[1]

first = vdb.FloatGrid()
first.name = "density"
first.fill((0, 0, 0), (7, 7, 7), 1.0)

second = vdb.FloatGrid()
second.name = "density"
second.fill((-3, 0, 2), (6, 9, 11), 2.0)
# Row-vector convention (OpenVDB): p_world = p_index * M. A rotation about Z by
# 90 degrees, scales (0.5, -0.25, 2) (negative: mirrored), then a translation.
second.transform = vdb.createLinearTransform(
    [[0.0, 0.5, 0.0, 0.0], [0.25, 0.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0], [1.0, -2.0, 3.0, 1.0]]
)
# Vary the values so interpolation is exercised in world space too.
acc = second.getAccessor()
for i in range(-3, 7):
    for j in range(0, 10):
        for k in range(2, 12):
            acc.setValueOn((i, j, k), 1.0 + 0.1 * i + 0.01 * j * j + 0.05 * k)

velocity = vdb.Vec3SGrid()
velocity.name = "velocity"
velocity.fill((0, 0, 0), (3, 3, 3), (1.0, 0.0, 0.0))

vdb.write(out, grids=[first, second, velocity])
