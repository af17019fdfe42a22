"""Writes a constant-density VDB box for the volume render tests (Debian's pyopenvdb, run by /usr/bin/python3).

usage: make_volume_box.py OUT.vdb N VOXEL_SIZE [BACKGROUND]
Grid 'density': value 1 at every index point (0..N-1)^3, voxel size VOXEL_SIZE, index
(0,0,0) at the world origin. Trilinear density is then 1 over [0, N-1]^3 (index space)
and falls linearly to 0 over one voxel beyond, so a ray along an axis through the box's
interior sees an optical depth of densityScale * N * VOXEL_SIZE exactly.
Grid 'temperature': 1500 (kelvin) over (-2..N+1)^3, same transform: constant wherever
the density is not zero, so emission is uniform over the whole medium.
BACKGROUND (default 0) is the density grid's background value, for the test that a
non-zero background is reported.
"""
import sys

import pyopenvdb as vdb

out, n, voxel = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
background = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
grid = vdb.FloatGrid(background)
grid.name = "density"
grid.fill((0, 0, 0), (n - 1, n - 1, n - 1), 1.0)
grid.transform = vdb.createLinearTransform(voxelSize=voxel)
temperature = vdb.FloatGrid()
temperature.name = "temperature"
temperature.fill((-2, -2, -2), (n + 1, n + 1, n + 1), 1500.0)
temperature.transform = vdb.createLinearTransform(voxelSize=voxel)
vdb.write(out, grids=[grid, temperature])
