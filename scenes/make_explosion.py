"""Writes a synthetic explosion VDB (grids `density` and `temperature`) for the demo.

SYNTHETIC: no small public explosion with temperature grids exists, so this one is
made procedurally and deterministically (no random state): a turbulent fireball
of rising lobes. Run with Debian's /usr/bin/python3, which has pyopenvdb.

usage: /usr/bin/python3 scenes/make_explosion.py OUT.vdb [--res N]

Grids (index-to-world: uniform voxel size 2/N, centred on the origin, y up):
  density      0..~1, fog volume; sigma_t = densityScale x density per world unit
  temperature  Kelvin, ~300 at the rim to ~2400 in the hottest core
"""
import argparse

import numpy as np
import pyopenvdb as vdb


def turbulence(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """A few octaves of a smooth periodic pseudo-noise in [-1, 1] (deterministic)."""
    total = np.zeros_like(x)
    amplitude, frequency = 0.5, 3.0
    for octave in range(4):
        phase = 1.7 * octave
        total += amplitude * (
            np.sin(frequency * x + phase) * np.sin(frequency * 1.3 * y - phase) * np.sin(frequency * 0.9 * z + 2 * phase)
        )
        amplitude *= 0.5
        frequency *= 2.1
    return total


def fields(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Density and temperature at the index points i = -n/2 .. n/2 - 1 of a lattice
    with voxel size 2/n: value (i, j, k) is evaluated exactly where OpenVDB puts it,
    at world position (i, j, k) x voxel size (CONVENTIONS.md, voxel centres)."""
    axis = (np.arange(n) - n // 2) * (2.0 / n)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    # A main ball plus three lobes rising and spreading: the mushroom of a blast.
    lobes = [(0.0, -0.25, 0.0, 0.55), (0.3, 0.2, 0.1, 0.35), (-0.25, 0.3, -0.2, 0.33), (0.0, 0.5, 0.25, 0.3)]
    shape = np.full_like(x, -np.inf)
    for cx, cy, cz, r in lobes:
        shape = np.maximum(shape, 1.0 - np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / r)
    shape = shape + 0.35 * turbulence(x, y, z)
    density = np.clip(shape * 2.0, 0.0, 1.0).astype(np.float32)
    heat = np.clip(shape * 1.6 - 0.1, 0.0, 1.0)
    temperature = np.where(density > 0.0, 300.0 + 2100.0 * heat**1.5, 0.0).astype(np.float32)
    return density, temperature


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--res", type=int, default=96, help="voxels per axis")
    args = parser.parse_args()

    density, temperature = fields(args.res)
    transform = vdb.createLinearTransform(voxelSize=2.0 / args.res)
    grids = []
    for name, values in (("density", density), ("temperature", temperature)):
        grid = vdb.FloatGrid()
        grid.copyFromArray(values, ijk=(-args.res // 2,) * 3, tolerance=0.0)
        grid.prune()
        grid.name = name
        grid.gridClass = vdb.GridClass.FOG_VOLUME
        grid.transform = transform
        grid["synthetic"] = "procedural explosion made by scenes/make_explosion.py"
        grids.append(grid)
    vdb.write(args.out, grids=grids)


if __name__ == "__main__":
    main()
