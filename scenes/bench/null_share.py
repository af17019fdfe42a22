"""How tight can a majorant grid be? The thin-medium null-collision share by cell size.

usage: /usr/bin/python3 scenes/bench/null_share.py VDB [VDB...]   (Debian's pyopenvdb)

For cells of 2, 4, 8 and 16 voxels a side, each cell's majorant is the max density over
its trilinear footprint (its voxels and one layer beyond, as src/volumes/majorant/cells.rs
builds it). In an optically thin medium tentative collisions fall uniformly at rate
sigma_maj, so the share of null collisions is 1 - sum(density) / sum(cell majorant x
cell volume) over the non-empty cells. Dense media concentrate collisions where rays
enter, on the trilinear ramps at the boundary, so measured shares run higher; this is
the floor a finer grid could reach. Prints a markdown table.
"""
import sys

import numpy as np
import pyopenvdb as vdb

CELL_SIZES = (2, 4, 8, 16)


def dense_density(path: str) -> np.ndarray:
    """The 'density' grid as a dense array, one voxel of background around the active box."""
    grid = vdb.read(path, "density")
    lo, hi = grid.evalActiveVoxelBoundingBox()
    array = np.zeros(tuple(h - l + 3 for l, h in zip(lo, hi)), dtype=np.float32)
    grid.copyToArray(array, ijk=tuple(l - 1 for l in lo))
    return np.maximum(array, 0.0)


def null_share(density: np.ndarray, cell: int) -> float:
    """Thin-limit null share for cells of `cell` voxels a side (footprint one voxel wider)."""
    padded = np.pad(density, [(0, cell + 1)] * 3)
    n = [s // cell + (s % cell > 0) for s in density.shape]
    majorant_mass = real_mass = 0.0
    for i in range(n[0]):
        for j in range(n[1]):
            for k in range(n[2]):
                x, y, z = i * cell, j * cell, k * cell
                footprint = padded[x:x + cell + 1, y:y + cell + 1, z:z + cell + 1]
                top = footprint.max()
                if top > 0.0:
                    majorant_mass += top * cell ** 3
                    real_mass += footprint[:cell, :cell, :cell].sum()
    return 1.0 - real_mass / majorant_mass


def main() -> None:
    print("| VDB | " + " | ".join(f"{c}^3-voxel cells" for c in CELL_SIZES) + " |")
    print("|---|" + "---:|" * len(CELL_SIZES))
    for path in sys.argv[1:]:
        density = dense_density(path)
        shares = [f"{100 * null_share(density, c):.0f}%" for c in CELL_SIZES]
        print(f"| {path.rsplit('/', 1)[-1]} | " + " | ".join(shares) + " |")


if __name__ == "__main__":
    main()
