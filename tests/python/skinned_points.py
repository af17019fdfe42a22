"""World-space points of every skinnable Mesh, as usd-core poses them, printed as JSON.

usage: skinned_points.py IN.usd FRAME

Independent of the exporter: UsdSkel.BakeSkinning (usd-core's own blend shapes, skinning
and normal skinning, into each mesh's local space) on the stage in memory, then each mesh's
world transform from UsdGeom.XformCache. A mesh with faceVarying normals is listed per face
corner (points repeated), as the exporter unwelds it. Prints one JSON object:
  {"posed":    {path: [[x, y, z], ...]},   baked points in world space
   "normals":  {path: [[x, y, z], ...]},   baked normals in world space, unit length
   "authored": {path: [[x, y, z], ...]}}   the authored (bind pose) points in world space
"""
import json
import sys

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel


def world_points(stage: Usd.Stage, time: Usd.TimeCode) -> tuple[dict, dict]:
    """Points and unit normals of every Mesh through its world transform at `time`."""
    cache = UsdGeom.XformCache(time)
    points, normals = {}, {}
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh) or not UsdSkel.BindingAPI(prim).GetJointIndicesPrimvar():
            continue
        mesh = UsdGeom.Mesh(prim)
        world = np.array(cache.GetLocalToWorldTransform(prim)).reshape(4, 4)
        p = np.array(mesh.GetPointsAttr().Get(time), dtype=np.float64)
        if mesh.GetNormalsInterpolation() == UsdGeom.Tokens.faceVarying:
            p = p[np.array(mesh.GetFaceVertexIndicesAttr().Get(time))]
        points[str(prim.GetPath())] = (p @ world[:3, :3] + world[3, :3]).tolist()
        n = mesh.GetNormalsAttr().Get(time)
        if n:
            n = np.array(n, dtype=np.float64) @ np.linalg.inv(world[:3, :3]).T
            normals[str(prim.GetPath())] = (n / np.linalg.norm(n, axis=1, keepdims=True)).tolist()
    return points, normals


def main(path: str, frame: float) -> None:
    """Prints the JSON object for the stage at `path` at time code `frame`."""
    time = Usd.TimeCode(frame)
    stage = Usd.Stage.Open(path)
    authored, _ = world_points(stage, time)
    stage.SetEditTarget(stage.GetSessionLayer())
    if not UsdSkel.BakeSkinning(stage.Traverse(), Gf.Interval(frame, frame)):
        sys.exit(f"{path}: UsdSkel.BakeSkinning failed at frame {frame}")
    posed, normals = world_points(stage, time)
    print(json.dumps({"posed": posed, "normals": normals, "authored": authored}))


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]))
