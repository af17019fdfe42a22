"""Writes a VDB whose "density" grid is not float, for tests/bad_input.rs.

usage: bad_vdb_grid.py OUT.vdb vec3s|bool
An 8^3 box of value (1, 1, 1) or true, voxel size 0.25: a valid grid of the wrong type.
"""
import sys

import pyopenvdb as vdb

path, kind = sys.argv[1], sys.argv[2]
grid, value = {"vec3s": (vdb.Vec3SGrid, (1.0, 1.0, 1.0)), "bool": (vdb.BoolGrid, True)}[kind]
g = grid()
g.name = "density"
g.fill((0, 0, 0), (7, 7, 7), value)
g.transform = vdb.createLinearTransform(voxelSize=0.25)
vdb.write(path, grids=[g])
