#!/usr/bin/env python3
"""Writes the instancing stress stage of `cirrus bench instances` (issue 3) as .usdc.

SYNTHETIC: one PointInstancer at /World/Instancer placing N copies (default 1,000,000)
of one triangle-mesh prototype, a UV sphere of radius 1 with about T triangles
(default 100,000). It measures what ingest costs per instance (export, load, TLAS
build, memory) with the prototype held fixed, which no shared asset does at this size.

Deterministic for given arguments (numpy Generator with a fixed seed) and vectorised:
no Python loop per instance or per triangle, so the script itself stays a small part
of the benchmark. Run with the project's venv Python (usd-core, numpy).

usage: .venv/bin/python scenes/make_instancing_stress.py OUT.usdc
           [--instances N] [--triangles T] [--seed S]

Placement (scene units, y up): instance i sits in cell i of a cubic grid with spacing
3.0, filled x fastest, jittered by up to +-0.25 per axis; each has a uniformly random
orientation and a per-axis scale in [0.5, 1.0], so neighbours never touch.
"""

import argparse
import math
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

SPACING = 3.0  # grid cell size; the largest scaled sphere is 2.0 across
JITTER = 0.25  # largest offset from the cell centre, per axis
SCALE_RANGE = (0.5, 1.0)  # per-axis scale, uniform


def parse_args() -> argparse.Namespace:
    """The command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="stage to write (.usdc)")
    parser.add_argument("--instances", type=int, default=1_000_000, help="PointInstancer instances (>= 1)")
    parser.add_argument("--triangles", type=int, default=100_000, help="approximate prototype triangles (>= 8)")
    parser.add_argument("--seed", type=int, default=1, help="random seed of the placement")
    args = parser.parse_args()
    if args.instances < 1 or args.triangles < 8:
        parser.error("--instances must be >= 1 and --triangles >= 8")
    return args


def uv_sphere(triangles: int) -> tuple[np.ndarray, np.ndarray]:
    """A unit UV sphere with close to `triangles` triangles (never fewer than 8).

    With `rings` latitude bands and `2 * rings` segments it has
    2 * segments * (rings - 1) triangles: fans at the two poles, quads split in two
    between. Returns (points (p, 3) f32, triangle indices (t, 3) i32), CCW seen from
    outside.
    """
    rings = max(2, round(math.sqrt(triangles / 4)) + 1)
    segments = 2 * rings
    theta = np.pi * np.arange(1, rings) / rings  # polar angle of each inner ring
    phi = 2 * np.pi * np.arange(segments) / segments
    ring = np.stack(np.broadcast_arrays(
        np.sin(theta)[:, None] * np.cos(phi), np.cos(theta)[:, None] * np.ones_like(phi),
        -np.sin(theta)[:, None] * np.sin(phi)), axis=-1).reshape(-1, 3)
    points = np.concatenate([[[0, 1, 0]], ring, [[0, -1, 0]]]).astype(np.float32)
    south = len(points) - 1

    def at(r: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Index of inner ring r, segment s (wrapping)."""
        return 1 + r * segments + s % segments

    s = np.arange(segments)
    top = np.stack([np.zeros_like(s), at(0, s), at(0, s + 1)], axis=1)
    bottom = np.stack([np.full_like(s, south), at(rings - 2, s + 1), at(rings - 2, s)], axis=1)
    r, s = (a.ravel() for a in np.meshgrid(np.arange(rings - 2), s, indexing="ij"))
    a, b, c, d = at(r, s), at(r + 1, s), at(r + 1, s + 1), at(r, s + 1)
    quads = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)])
    return points, np.concatenate([top, quads, bottom]).astype(np.int32)


def placement(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (n, 3), unit quaternions (n, 4), scales (n, 3).

    The quaternions are in GfQuath's memory order (i, j, k, real), as
    Vt.QuathArray.FromNumpy reads them; being uniform, any order would do.
    """
    rng = np.random.default_rng(seed)
    side = math.ceil(round(n ** (1 / 3), 9))
    i = np.arange(n)
    cell = np.stack([i % side, i // side % side, i // (side * side)], axis=1)
    positions = (cell - (side - 1) / 2) * SPACING + rng.uniform(-JITTER, JITTER, (n, 3))
    # A normalised 4D Gaussian is uniform over rotations.
    quats = rng.standard_normal((n, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    scales = rng.uniform(*SCALE_RANGE, (n, 3))
    return positions, quats, scales


def write_stage(out: Path, n: int, triangles: int, seed: int) -> int:
    """Writes the stage; returns the prototype's triangle count."""
    stage = Usd.Stage.CreateNew(str(out))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())

    instancer = UsdGeom.PointInstancer.Define(stage, "/World/Instancer")
    mesh = UsdGeom.Mesh.Define(stage, "/World/Instancer/Prototypes/Sphere")
    points, tris = uv_sphere(triangles)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(tris), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(tris.ravel()))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateExtentAttr([Gf.Vec3f(-1), Gf.Vec3f(1)])

    positions, quats, scales = placement(n, seed)
    instancer.CreatePrototypesRel().SetTargets([mesh.GetPath()])
    instancer.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(n, np.int32)))
    instancer.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(positions.astype(np.float32)))
    instancer.CreateOrientationsAttr(Vt.QuathArray.FromNumpy(quats.astype(np.float16)))
    instancer.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(scales.astype(np.float32)))
    # The unit sphere scaled by at most SCALE_RANGE[1] per axis stays in that radius.
    lo = positions.min(axis=0) - SCALE_RANGE[1]
    hi = positions.max(axis=0) + SCALE_RANGE[1]
    instancer.CreateExtentAttr([Gf.Vec3f(*lo), Gf.Vec3f(*hi)])
    stage.GetRootLayer().Save()
    return len(tris)


def main() -> None:
    """Writes the stage and prints what it holds."""
    args = parse_args()
    if args.out.suffix != ".usdc":
        raise SystemExit(f"error: {args.out}: the stage is written as .usdc; name it so")
    n_tris = write_stage(args.out, args.instances, args.triangles, args.seed)
    print(f"wrote {args.out}: {args.instances} instances of a {n_tris}-triangle sphere (seed {args.seed})")


if __name__ == "__main__":
    main()
