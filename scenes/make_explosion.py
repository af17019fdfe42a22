"""Writes a synthetic explosion VDB (grids `density`, `temperature` and `vel`) for the demo.

SYNTHETIC: no small public explosion with temperature grids exists, so this one is
made procedurally and deterministically (no random state: the noise lattice is an
integer hash with fixed seeds, so every run writes the same values):

  fireball (default)  a rising mushroom: a stem column under a toroidal, rolling cap,
                      domain-warped and displaced by multi-octave gradient noise into
                      billows; a hot core (2000-2600 K) cooling to ~600 K at the rim
                      of the fire, wrapped in a cold, denser soot shell that is
                      thickest on top, with a smoke crown above and a dust ring at the
                      foot; about 1.6 wide and 1.95 tall, its foot on the grid's
                      bottom face (y = -1).
  flame               a campfire-like flame column for benchmarks: about 1 unit wide
                      and 1.7 tall from the grid's bottom face (y = -1), tapering and
                      splitting into flickering tongues, 1200-2000 K, thin gas
                      (density ~0.1-0.3), with a little cold smoke above up to y ~ 1.

Run with Debian's /usr/bin/python3, which has pyopenvdb.

usage: /usr/bin/python3 scenes/make_explosion.py OUT.vdb [--res N] [--shape fireball|flame]

Grids (index-to-world: uniform voxel size 2/N, centred on the origin, y up; the
lattice covers [-1, 1) on each axis). Only voxels with density > 0 are active:
  density      0..1, fog volume; sigma_t = densityScale x density per world unit
               (fireball: soot ~0.5-1, fire ~0.3-0.5; flame: ~0.1-0.3)
  temperature  Kelvin where there is fire (fireball ~600 at the rim of the fire to
               ~2600 in the hottest core; flame 1200-2000), 0 (inactive) in smoke
  vel          vec3s, world units per second, on a 4x coarser lattice (voxel size 8/N)
               filling the whole cube, so gas can be advected into empty space: the gas
               rising at RISE and expanding from the grid's centre at EXPAND per second,
               v = (0, RISE, 0) + EXPAND x (x, y, z) (linear, so trilinear lookups of
               the coarse grid are exact); for motion blur
               (docs/volumes.md, "Motion blur"), read only when a Volume names it
               (`field:velocity`) and the shutter is open
"""
import argparse

import numpy as np
import pyopenvdb as vdb

# Perlin's 12 edge gradients, padded to 16 so a hash's low 4 bits pick one.
GRADIENTS = np.array([(1, 1, 0), (-1, 1, 0), (1, -1, 0), (-1, -1, 0), (1, 0, 1), (-1, 0, 1),
                      (1, 0, -1), (-1, 0, -1), (0, 1, 1), (0, -1, 1), (0, 1, -1), (0, -1, -1),
                      (1, 1, 0), (-1, 1, 0), (0, -1, 1), (0, -1, -1)], dtype=np.float64)


def lattice_hash(ix: np.ndarray, iy: np.ndarray, iz: np.ndarray, seed: int) -> np.ndarray:
    """A 32-bit integer hash of lattice points (murmur3's finaliser): deterministic on
    every machine and numpy version, unlike a random generator's stream."""
    with np.errstate(over="ignore"):
        h = ((ix + (1 << 20)).astype(np.uint32) * np.uint32(0x8DA6B343)
             ^ (iy + (1 << 20)).astype(np.uint32) * np.uint32(0xD8163841)
             ^ (iz + (1 << 20)).astype(np.uint32) * np.uint32(0xCB1AB31F)
             ^ np.uint32((seed * 0x9E3779B9) & 0xFFFFFFFF))
        h ^= h >> np.uint32(16)
        h *= np.uint32(0x85EBCA6B)
        h ^= h >> np.uint32(13)
        h *= np.uint32(0xC2B2AE35)
        h ^= h >> np.uint32(16)
    return h


def gradient_noise(x: np.ndarray, y: np.ndarray, z: np.ndarray, seed: int) -> np.ndarray:
    """Perlin gradient noise (quintic fade), about [-1, 1], zero on the lattice."""
    cx, cy, cz = np.floor(x), np.floor(y), np.floor(z)
    fx, fy, fz = x - cx, y - cy, z - cz
    ix, iy, iz = cx.astype(np.int64), cy.astype(np.int64), cz.astype(np.int64)
    u, v, w = (f * f * f * (f * (f * 6.0 - 15.0) + 10.0) for f in (fx, fy, fz))
    corner = {}
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                g = GRADIENTS[lattice_hash(ix + dx, iy + dy, iz + dz, seed) & np.uint32(15)]
                corner[dx, dy, dz] = g[:, 0] * (fx - dx) + g[:, 1] * (fy - dy) + g[:, 2] * (fz - dz)
    x00 = corner[0, 0, 0] + u * (corner[1, 0, 0] - corner[0, 0, 0])
    x10 = corner[0, 1, 0] + u * (corner[1, 1, 0] - corner[0, 1, 0])
    x01 = corner[0, 0, 1] + u * (corner[1, 0, 1] - corner[0, 0, 1])
    x11 = corner[0, 1, 1] + u * (corner[1, 1, 1] - corner[0, 1, 1])
    y0 = x00 + v * (x10 - x00)
    y1 = x01 + v * (x11 - x01)
    return y0 + w * (y1 - y0)


def fbm(p: tuple, octaves: int, seed: int, billow: bool = False) -> np.ndarray:
    """Fractal sum of gradient noise, each octave 2.03x the frequency and half the
    amplitude (about [-1, 1], standard deviation ~0.26); `billow` sums |noise|
    instead: rounded lumps between sharp creases, the cauliflower look of a
    fireball's surface (0 to ~1.4, mean ~0.45)."""
    x, y, z = p
    total = np.zeros_like(x)
    amplitude, frequency, norm = 1.0, 1.0, 0.0
    for octave in range(octaves):
        n = gradient_noise(x * frequency, y * frequency, z * frequency, seed + 101 * octave)
        total += amplitude * (np.abs(n) * 2.0 if billow else n)
        norm += amplitude
        amplitude, frequency = amplitude * 0.5, frequency * 2.03
    return total / norm if billow else 1.5 * total / norm


def smoothstep(a, b, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - a) / (b - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def smooth_max(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Union of two 'inside depth' fields (positive inside) with a blend of width k."""
    h = np.clip(0.5 + 0.5 * (a - b) / k, 0.0, 1.0)
    return b + (a - b) * h + k * h * (1.0 - h)


def candidates(n: int, keep) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The index points i = -n/2 .. n/2 - 1 (voxel size 2/n) where keep(x, y, z) holds:
    their flat indices into an n^3 array and their world positions. Value (i, j, k) is
    evaluated exactly where OpenVDB puts it, at (i, j, k) x voxel size (docs/conventions.md,
    "Voxel centres"). One x slab at a time, to bound the memory."""
    axis = (np.arange(n) - n // 2) * (2.0 / n)
    y, z = np.meshgrid(axis, axis, indexing="ij")
    where = []
    for i in range(n):
        x = np.full_like(y, axis[i])
        where.append(i * n * n + np.flatnonzero(keep(x, y, z)))
    where = np.concatenate(where)
    return where, axis[where // (n * n)], axis[where // n % n], axis[where % n]


# --- the fireball ----------------------------------------------------------------------

STEM_BOTTOM, CAP_Y, TORUS_R, TUBE_R = -0.97, 0.17, 0.36, 0.27


def fireball_shape(x, y, z):
    """Inside depths (world units, positive inside) of the parts of the mushroom:
    (cap: a rolling torus under a dome, stem: the rising column, cold: the smoke
    crown above the cap and the dust ring at the foot, which hold no fire)."""
    rho = np.sqrt(x * x + z * z)
    torus = TUBE_R - np.sqrt((rho - TORUS_R) ** 2 + (y - CAP_Y) ** 2)
    dome = 1.0 - np.sqrt((rho / 0.5) ** 2 + ((y - CAP_Y - 0.1) / 0.36) ** 2)
    cap = smooth_max(torus, 0.35 * dome, 0.1)
    # The stem narrows above its skirt and widens into the cap.
    radius = 0.15 + 0.16 * np.exp(-(y - STEM_BOTTOM) / 0.1) + 0.12 * smoothstep(-0.3, CAP_Y, y)
    stem = np.minimum(radius - rho, np.minimum(y - STEM_BOTTOM, CAP_Y + 0.05 - y))
    crown = 0.12 - np.sqrt((rho / 2.2) ** 2 + (y - CAP_Y - 0.45) ** 2)
    ring = 0.07 - np.sqrt((rho - 0.26) ** 2 + ((y - STEM_BOTTOM - 0.05) / 0.8) ** 2)
    return cap, stem, np.maximum(crown, ring)


def near_fireball(x, y, z) -> np.ndarray:
    """Where the fireball can reach: noise moves its surface by at most ~0.25."""
    return np.max(fireball_shape(x, y, z), axis=0) > -0.25


def fireball(x, y, z) -> tuple[np.ndarray, np.ndarray]:
    """Density and temperature at world points (x, y, z) (flat arrays)."""
    # Roll: twist space about the torus tube (more near its core), so the noise curls
    # the way the gas rolls: up the middle, out over the top and down the outside.
    rho = np.maximum(np.sqrt(x * x + z * z), 1e-9)
    a, b = rho - TORUS_R, y - CAP_Y
    angle = 1.4 * np.exp(-(a * a + b * b) / (1.7 * TUBE_R * TUBE_R))
    a, b = a * np.cos(angle) - b * np.sin(angle), a * np.sin(angle) + b * np.cos(angle)
    rx, rz = x / rho * (TORUS_R + a), z / rho * (TORUS_R + a)
    ry = CAP_Y + b
    # Domain warp: a smooth vector noise displaces the point the shape is evaluated at.
    f = 1.8
    warp = [fbm((rx * f + 3.1, ry * f + s, rz * f - 1.7), 3, seed=11 + s) for s in range(3)]
    qx, qy, qz = x + 0.3 * warp[0], y + 0.22 * warp[1], z + 0.3 * warp[2]
    cap, stem, cold = fireball_shape(qx, qy, qz)
    # Billows: the surface bulges outward in rounded lumps, largest on the cap.
    billows = fbm((rx * 3.2 + 0.5 * warp[1], ry * 3.2, rz * 3.2 + 0.5 * warp[0]), 4, seed=31, billow=True)
    lumps = 0.15 * billows - 0.04
    cap, stem, cold = cap + lumps, stem + 0.6 * lumps, cold + 0.7 * lumps
    outer = smooth_max(smooth_max(cap, stem, 0.12), cold, 0.06)

    # The soot shell: thin under the cap (the rolling fire shows there), thick on top,
    # torn open in places by noise; the fire is what lies deeper than the shell.
    holes = fbm((rx * 3.0 - 5.0, ry * 3.0, rz * 3.0 + 2.0), 3, seed=47)
    shell = 0.02 + 0.07 * smoothstep(CAP_Y - 0.1, CAP_Y + 0.4, qy) + 0.2 * holes
    cap_fire, stem_fire = cap - shell, stem - 0.03 - 0.1 * holes
    fire = smooth_max(cap_fire, stem_fire, 0.08)
    pockets = fbm((rx * 6.0, ry * 6.0 + 7.0, rz * 6.0), 3, seed=59)
    # Heat: the deepest fire is hottest; the stem's narrower core runs cooler.
    rise = smoothstep(STEM_BOTTOM, CAP_Y, qy)  # the stem's gas heats up as it nears the cap
    heat = np.clip(np.maximum(cap_fire / 0.2, (0.3 + 0.4 * rise) * stem_fire / 0.1) + 0.3 * pockets, 0.0, 1.0)
    lit = (fire > 0.0) & (outer > 0.0)
    temperature = np.where(lit, 600.0 + 2000.0 * heat, 0.0)

    # Density: soft edge, puffy dense soot, thinner hot gas inside.
    puff = fbm((rx * 7.0 + 9.0, ry * 7.0, rz * 7.0), 3, seed=73)
    soot = np.clip(0.8 + 0.35 * puff, 0.4, 1.0)
    gas = 0.3 + 0.2 * heat
    burning = smoothstep(0.0, 0.04, fire)
    density = smoothstep(0.0, 0.035, outer) * (soot + (gas - soot) * burning)
    density = np.where(density >= 1e-3, density, 0.0)
    temperature = np.where(density > 0.0, temperature, 0.0)
    return density, temperature


# --- the flame -------------------------------------------------------------------------

FLAME_TONGUES = [  # (direction about y in degrees, distance from the axis, height, width)
    (0.0, 0.04, 1.8, 0.19), (20.0, 0.3, 1.3, 0.13), (95.0, 0.3, 1.05, 0.12),
    (165.0, 0.27, 1.5, 0.14), (235.0, 0.32, 0.95, 0.12), (300.0, 0.28, 1.2, 0.13),
]


def near_flame(x, y, z) -> np.ndarray:
    """Where the flame and its smoke can reach."""
    return (x * x + z * z < 0.75 ** 2) & (y > -0.999)


def flame(x, y, z) -> tuple[np.ndarray, np.ndarray]:
    """Density and temperature at world points (x, y, z) (flat arrays)."""
    t = (y + 1.0) / 2.0  # height above the grid's bottom face, 0..1 over 2 units

    # Flicker: a warp stretched along y (tall streaks), growing with height, so the
    # base holds still and the tips lick about.
    sway = 0.02 + 0.5 * t * t
    warp = [fbm((x * 2.0 + 4.0 * s, y * 0.8 - 1.3 * s, z * 2.0), 3, seed=211 + s) for s in range(2)]
    qx, qz = x + sway * warp[0], z + sway * warp[1]
    licks = fbm((qx * 4.0, y * 1.6, qz * 4.0), 3, seed=229)
    detail = fbm((qx * 9.0, y * 4.0, qz * 9.0), 2, seed=239)
    # Tongues: tapering columns from a ring over the bed, leaning in; their union is
    # the flame, the deepest point of the nearest tongue sets its heat.
    inside = np.full_like(x, -1.0)
    heat = np.zeros_like(x)
    for angle, ring, tall, width in FLAME_TONGUES:
        bx, bz = ring * np.cos(np.radians(angle)), ring * np.sin(np.radians(angle))
        s = np.clip((y + 1.0) / tall, 0.0, 1.0)
        lean = 1.0 - 0.4 * s
        radius = width * (1.0 + 0.6 * s) * (1.0 - s) ** 1.1
        ragged = (0.02 + 0.1 * s) * np.sqrt(1.0 - s) * licks  # ragged edges, none at the tip
        depth = radius - np.sqrt((qx - bx * lean) ** 2 + (qz - bz * lean) ** 2) + ragged
        depth = np.where((y + 1.0) < tall, depth, -1.0)
        heat = np.maximum(heat, np.clip(depth / np.maximum(0.6 * radius, 0.03), 0.0, 1.0) * (1.0 - 0.6 * s))
        inside = smooth_max(inside, depth, 0.03)
    inside += 0.02 * detail
    temperature = np.where(inside > 0.0, 1200.0 + 800.0 * np.clip(heat ** 0.7 + 0.08 * detail, 0.0, 1.0), 0.0)
    gas = smoothstep(0.0, 0.04, inside) * np.clip(0.2 + 0.1 * licks, 0.1, 0.3)

    # A little cold smoke rising off the tips: thin wisps, drifting further up.
    drift = 0.05 + 0.25 * smoothstep(0.6, 1.0, t)
    sx, sz = x + drift * warp[0] * 1.5, z + drift * warp[1] * 1.5
    srho = np.sqrt(sx * sx + sz * sz)
    wisps = np.clip(fbm((sx * 5.0, y * 2.0, sz * 5.0), 3, seed=251) + 0.15, 0.0, 1.0)
    column = smoothstep(0.0, 0.06, 0.06 + 0.22 * (t - 0.55) - srho) * smoothstep(0.55, 0.8, t)
    smoke = 0.12 * column * wisps * (1.0 - smoothstep(0.9, 0.995, t))
    density = np.maximum(gas, smoke)
    density = np.where(density >= 1e-3, density, 0.0)
    temperature = np.where((density > 0.0) & (gas >= smoke), temperature, 0.0)
    return density, temperature


SHAPES = {"fireball": (near_fireball, fireball), "flame": (near_flame, flame)}

# The velocity field: rising at RISE and expanding from the grid's centre at EXPAND per
# second (world units per second: 3 units/s moves the gas an eighth of a unit over a
# 24 fps frame, a few pixels of blur at the quick start's 1280x720).
RISE, EXPAND = 3.0, 1.5


def velocity(n: int) -> np.ndarray:
    """Dense float32 (n, n, n, 3) velocities at the index points i = -n/2 .. n/2 of a
    lattice of voxel size 2/n (one more point than the density's, to reach its far faces)."""
    axis = (np.arange(n + 1) - n // 2) * (2.0 / n)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return np.stack([EXPAND * x, RISE + EXPAND * y, EXPAND * z], axis=-1).astype(np.float32)


def fields(n: int, shape: str) -> tuple[np.ndarray, np.ndarray]:
    """Dense float32 n^3 density and temperature, zero outside the shape; the noise is
    evaluated a chunk of points at a time (the values are pointwise, so the same)."""
    near, values = SHAPES[shape]
    where, x, y, z = candidates(n, near)
    density, temperature = np.zeros(n ** 3, np.float32), np.zeros(n ** 3, np.float32)
    for start in range(0, len(where), 1 << 18):
        chunk = slice(start, start + (1 << 18))
        density[where[chunk]], temperature[where[chunk]] = values(x[chunk], y[chunk], z[chunk])
    return density.reshape(n, n, n), temperature.reshape(n, n, n)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--res", type=int, default=160, help="voxels per axis (voxel size 2/N)")
    parser.add_argument("--shape", choices=("fireball", "flame"), default="fireball")
    args = parser.parse_args()

    density, temperature = fields(args.res, args.shape)
    transform = vdb.createLinearTransform(voxelSize=2.0 / args.res)
    grids = []
    for name, values in (("density", density), ("temperature", temperature)):
        grid = vdb.FloatGrid()
        # Zero is the background: only the voxels holding a value are active.
        grid.copyFromArray(values, ijk=(-(args.res // 2),) * 3, tolerance=0.0)
        grid.name = name
        grid.gridClass = vdb.GridClass.FOG_VOLUME
        grid.transform = transform
        grid["synthetic"] = f"procedural {args.shape} made by scenes/make_explosion.py"
        grids.append(grid)
    coarse = max(args.res // 4, 2)
    vel = vdb.Vec3SGrid()
    vel.copyFromArray(velocity(coarse), ijk=(-(coarse // 2),) * 3, tolerance=(-1.0, -1.0, -1.0))
    vel.name = "vel"
    vel.transform = vdb.createLinearTransform(voxelSize=2.0 / coarse)
    vel["synthetic"] = f"rising {RISE} and expanding {EXPAND} per second, scenes/make_explosion.py"
    grids.append(vel)
    vdb.write(args.out, grids=grids)
    hot = temperature[temperature > 0.0]
    print(f"make_explosion: wrote {args.out} ({args.shape}, {args.res}^3, {grids[0].activeVoxelCount()} "
          f"active voxels, {hot.min():.0f}-{hot.max():.0f} K in {hot.size} hot ones)")


if __name__ == "__main__":
    main()
