"""Writes a small emitting box VDB for the fire bad-input tests (Debian's pyopenvdb, run by /usr/bin/python3).

usage: make_fire_box.py OUT.vdb MODE
Grid 'density': 1 over index (0..7)^3, voxel size 0.25. MODE picks the emission grid:
  bad_temperature  'temperature' 1500 over the box, with one NaN, one +inf and one -5 voxel
  cold             'temperature' 0 over the box (nothing emits)
  vector_emission  'emission' as a vec3s grid (not a float grid)
"""
import sys

import pyopenvdb as vdb

out, mode = sys.argv[1], sys.argv[2]
transform = vdb.createLinearTransform(voxelSize=0.25)
density = vdb.FloatGrid()
density.name = "density"
density.fill((0, 0, 0), (7, 7, 7), 1.0)
density.transform = transform
if mode == "vector_emission":
    emission = vdb.Vec3SGrid()
    emission.name = "emission"
    emission.fill((0, 0, 0), (7, 7, 7), (1.0, 1.0, 1.0))
else:
    emission = vdb.FloatGrid()
    emission.name = "temperature"
    emission.fill((0, 0, 0), (7, 7, 7), 0.0 if mode == "cold" else 1500.0)
    if mode == "bad_temperature":
        access = emission.getAccessor()
        access.setValueOn((2, 2, 2), float("nan"))
        access.setValueOn((4, 4, 4), float("inf"))
        access.setValueOn((5, 5, 5), -5.0)
emission.transform = transform
vdb.write(out, grids=[density, emission])
