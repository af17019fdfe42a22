"""Writes one VDB float grid as a Mitsuba 3 `.vol` file (run with Debian's /usr/bin/python3).

Usage: /usr/bin/python3 vdb_to_vol.py FILE.vdb GRID INDEX OUT.vol

pyopenvdb is only importable by the system Python, so the converter
(to_mitsuba.py, in the project .venv) shells out to this script.

Placement, so that Mitsuba's `gridvolume` reproduces OpenVDB's BoxSampler
(docs/conventions.md, "Voxel centres"):
- OpenVDB puts value v(i,j,k) at the integer index point (i,j,k) and falls
  trilinearly to the background (0) over one voxel past the stored data.
- Mitsuba's `gridvolume` (src/volumes/grid.cpp, a dr::Texture3f) puts texel n
  of N at the local coordinate (n + 0.5) / N of its unit cube, interpolates
  trilinearly between texel centres and clamps outside them; the .vol header's
  bbox is ignored unless `use_grid_bbox` is set, so the placement is the
  `to_world` the converter passes.
- So the dense block is the data's index bounds [lo, hi] padded by one voxel of
  background on every side, N = hi - lo + 3 texels per axis, and index point i
  sits at local (i - (lo - 1) + 0.5) / N: the unit cube spans the index box
  [lo - 1.5, hi + 1.5], i.e. to_world = world_from_index x translate(lo - 1.5) x scale(N).
  The padding reproduces the one-voxel linear falloff; the clamped half voxel
  beyond it reads 0, like the background.

Prints one JSON line: {"index_min": lo - 1.5 (3 floats), "shape": N (3 ints),
"world_from_index": 3x4 rows, "negative": count of negative values,
"non_finite": count of NaN/Inf values, "max": the largest value}. Negative and
non-finite values are written as 0, as Cirrus reads them.
"""

import json
import struct
import sys

import numpy as np
import pyopenvdb as vdb


#: Largest dense grid written (1 GiB of float32): Mitsuba's gridvolume is dense.
MAX_VOXELS = 2**28


def pick_grid(path, name, index):
    """The `index`-th float grid called `name` in the file (0 = the first)."""
    grids, _ = vdb.readAll(path)
    matching = [g for g in grids if g.name == name]
    if index >= len(matching):
        raise SystemExit(f"error: {path}: no grid {name!r} with index {index}")
    return matching[index]


def data_bounds(grid):
    """Index bounds (lo, hi), inclusive, of every stored voxel: leaves and active tiles."""
    boxes = [grid.evalActiveVoxelBoundingBox(), grid.evalLeafBoundingBox()]
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    return lo.astype(np.int64), hi.astype(np.int64)


def world_from_index(grid):
    """The grid's linear index-to-world map as 3x4 rows [A | t]."""
    if not grid.transform.isLinear:
        raise SystemExit(f"error: grid {grid.name}: non-linear (frustum) transforms are not supported")
    origin = np.array(grid.transform.indexToWorld((0, 0, 0)))
    axes = [np.array(grid.transform.indexToWorld(e)) - origin for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    return np.column_stack(axes + [origin])


def write_vol(path, data_zyx):
    """A Mitsuba .vol file: 'VOL', version 3, float32 encoding, one channel, x fastest.

    The bbox field is written as the unit cube: Mitsuba ignores it by default.
    """
    zres, yres, xres = data_zyx.shape
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]))
        f.write(struct.pack("<iiiii", 1, xres, yres, zres, 1))
        f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
        f.write(np.ascontiguousarray(data_zyx, dtype="<f4").tobytes())


def main():
    if len(sys.argv) != 5:
        raise SystemExit(__doc__.split("\n\n")[1])
    path, name, index, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    grid = pick_grid(path, name, index)
    if grid.valueTypeName != "float":
        raise SystemExit(f"error: grid {name}: value type {grid.valueTypeName}, not float")
    lo, hi = data_bounds(grid)
    shape_xyz = hi - lo + 3
    if np.prod(shape_xyz) > MAX_VOXELS:
        raise SystemExit(f"error: grid {name}: a dense copy of {shape_xyz.tolist()} voxels "
                         f"exceeds {MAX_VOXELS} (Mitsuba's gridvolume is dense)")
    dense = np.zeros(tuple(shape_xyz), dtype=np.float32)
    inner = np.zeros(tuple(hi - lo + 1), dtype=np.float32)
    grid.copyToArray(inner, ijk=tuple(int(v) for v in lo))
    dense[1:-1, 1:-1, 1:-1] = inner
    non_finite = int(np.count_nonzero(~np.isfinite(dense)))
    dense[~np.isfinite(dense)] = 0.0
    negative = int(np.count_nonzero(dense < 0))
    dense[dense < 0] = 0.0
    write_vol(out, dense.transpose(2, 1, 0))
    print(json.dumps({
        "index_min": (lo - 1.5).tolist(),
        "shape": shape_xyz.tolist(),
        "world_from_index": world_from_index(grid).tolist(),
        "negative": negative,
        "non_finite": non_finite,
        "background": float(grid.background),
        "max": float(dense.max()),
    }))


if __name__ == "__main__":
    main()
