"""Writes the fire VDBs of the emission light-sampling stability rows (Debian's pyopenvdb, run by /usr/bin/python3).

usage: make_emission_stability.py OUT.vdb MODE
Voxel size 1/16, index (0,0,0) at the world origin; trilinear lookups, so a value set on
index points [a, b] is constant over [a, b] and falls to 0 one voxel beyond. MODE:
  hot_spot  'density' 1 over index [0, 15]^3 (a 1-unit cube of smoke); 'temperature'
            3000 (kelvin) on the 2 x 2 x 2 index points [3, 4]^3 and 0 elsewhere, so
            emission is non-zero only over index (2, 5)^3, all inside the first 8^3
            majorant cell.
  shell     'density' 1 over index [0, 23]^3 (a 1.5-unit cube), except 0.02 on the core
            [8, 15]^3; 'temperature' 2000 on the core. From any point where the
            temperature is not zero (index (7, 16)^3) to outside the cube a ray crosses
            at least 7 voxels (0.4375 units) of density 1 and more: optical depth at
            least 0.4375 x densityScale.
"""
import sys

import pyopenvdb as vdb

out, mode = sys.argv[1], sys.argv[2]
transform = vdb.createLinearTransform(voxelSize=1.0 / 16.0)
density = vdb.FloatGrid()
density.name = "density"
temperature = vdb.FloatGrid()
temperature.name = "temperature"
if mode == "hot_spot":
    density.fill((0, 0, 0), (15, 15, 15), 1.0)
    temperature.fill((3, 3, 3), (4, 4, 4), 3000.0)
elif mode == "shell":
    density.fill((0, 0, 0), (23, 23, 23), 1.0)
    density.fill((8, 8, 8), (15, 15, 15), 0.02)
    temperature.fill((8, 8, 8), (15, 15, 15), 2000.0)
else:
    sys.exit(f"unknown mode {mode!r}")
density.transform = transform
temperature.transform = transform
vdb.write(out, grids=[density, temperature])
