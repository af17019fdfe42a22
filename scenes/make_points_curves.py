#!/usr/bin/env python3
"""Writes the stage of `cirrus bench points-curves` (issue 22) as .usdc.

SYNTHETIC: /World/Dots, one Points prim of N spheres (default 1,000,000) at uniformly
random places in a 100-unit cube, diameters uniform in [0.02, 0.1] (per point); and
/World/Hair, one BasisCurves prim of C cubic bspline hairs (default 100,000), each of 6
control points rising 4 units from a random root on a 100 x 100 ground with a random
sideways sway, widths 0.02 at the root to 0.005 at the tip (vertex interpolation).

Deterministic for given arguments (numpy Generator, fixed seed) and vectorised.
usage: .venv/bin/python scenes/make_points_curves.py OUT.usdc [--points N] [--curves C]
"""

import argparse
from pathlib import Path

import numpy as np
from pxr import Usd, UsdGeom, Vt

CONTROL_POINTS = 6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--curves", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=22)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    stage = Usd.Stage.CreateNew(str(args.out))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.Xform.Define(stage, "/World")
    if args.points:
        dots = UsdGeom.Points.Define(stage, "/World/Dots")
        dots.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(rng.uniform(-50, 50, (args.points, 3)).astype(np.float32)))
        dots.GetWidthsAttr().Set(Vt.FloatArray.FromNumpy(rng.uniform(0.02, 0.1, args.points).astype(np.float32)))
        dots.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    if args.curves:
        roots = np.stack([rng.uniform(-50, 50, args.curves), np.zeros(args.curves),
                          rng.uniform(-50, 50, args.curves)], axis=1)
        t = np.linspace(0.0, 1.0, CONTROL_POINTS)
        sway = rng.normal(0.0, 0.6, (args.curves, 1, 3)) * np.array([1.0, 0.0, 1.0])
        points = roots[:, None, :] + t[None, :, None] ** 2 * sway + t[None, :, None] * np.array([0.0, 4.0, 0.0])
        hair = UsdGeom.BasisCurves.Define(stage, "/World/Hair")
        hair.GetTypeAttr().Set(UsdGeom.Tokens.cubic)
        hair.GetBasisAttr().Set(UsdGeom.Tokens.bspline)
        hair.GetCurveVertexCountsAttr().Set(Vt.IntArray.FromNumpy(np.full(args.curves, CONTROL_POINTS, np.int32)))
        hair.GetPointsAttr().Set(Vt.Vec3fArray.FromNumpy(points.reshape(-1, 3).astype(np.float32)))
        widths = np.tile(np.linspace(0.02, 0.005, CONTROL_POINTS), args.curves).astype(np.float32)
        hair.GetWidthsAttr().Set(Vt.FloatArray.FromNumpy(widths))
        hair.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    stage.GetRootLayer().Save()


if __name__ == "__main__":
    main()
