"""UsdGeom.Mesh to Cirrus triangles: fan triangulation, primvar unwelding, winding.

Everything is vectorised over faces and corners; no Python loop per element.
"""

from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom

from .report import Report

PER_POINT = ("vertex", "varying")


class BadMesh(ValueError):
    """A mesh whose data cannot be used (bad indices, NaN points): skipped with a warning."""


@dataclass
class MeshGeometry:
    """Triangles in the prim's object space, one normal/uv per point when present."""

    points: np.ndarray  # (n, 3) float64
    triangles: np.ndarray  # (t, 3) int64, CCW front
    normals: np.ndarray | None  # (n, 3) or None
    uvs: np.ndarray | None  # (n, 2) or None
    triangle_face: np.ndarray  # (t,) authored face index of each triangle
    # name -> (n, width): the requested primvars the mesh has
    primvars: dict[str, np.ndarray] = field(default_factory=dict)
    corner_points: np.ndarray | None = None  # (c,) point of each faceVertexIndices corner (subdivision.py)


@dataclass
class Pose:
    """A mesh's points and normals as a deformer poses them, replacing the authored ones:
    UsdSkel at the time code (skinning.py), or one motion key (deforming.py)."""

    skeleton: Usd.Prim | None  # the Skeleton whose space the pose is in (None: a motion key's)
    points: np.ndarray  # (n, 3) float64: skeleton space, or mesh space for rigid influences
    normals: tuple[np.ndarray, str] | None  # skinned normals and their interpolation
    skel_from_points: np.ndarray  # row-vector (4, 4): identity, or the rigid skinned transform


def fan_triangulate(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fan triangles over faces given their vertex counts.

    Returns (corners (t, 3): indices into faceVertexIndices, face (t,): face of each
    triangle). Faces with fewer than 3 vertices produce no triangle.
    """
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    per_face = np.where(counts >= 3, counts - 2, 0).astype(np.int64)
    face = np.repeat(np.arange(counts.size), per_face)
    first = np.repeat(np.cumsum(per_face) - per_face, per_face)
    k = np.arange(face.size) - first
    base = starts[face]
    return np.stack([base, base + k + 1, base + k + 2], axis=1), face


def _corner_values(values: np.ndarray, interpolation: str, indices: np.ndarray,
                   corner_face: np.ndarray) -> np.ndarray:
    """A primvar expanded to one value per face-vertex corner, whatever its interpolation."""
    if interpolation in PER_POINT:
        return values[indices]
    if interpolation == "faceVarying":
        return values
    if interpolation == "uniform":
        return values[corner_face]
    return np.broadcast_to(values[:1], (indices.size, values.shape[1]))


def _expected_length(interpolation: str, n_points: int, n_corners: int, n_faces: int) -> int:
    """How many values a primvar of this interpolation must hold."""
    return {"vertex": n_points, "varying": n_points, "faceVarying": n_corners,
            "uniform": n_faces}.get(interpolation, 1)


def _read_primvar(prim: Usd.Prim, name: str, time: Usd.TimeCode) -> tuple[np.ndarray, str] | None:
    """A primvar's flattened values and interpolation, or None when unauthored."""
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
    if not primvar or not primvar.HasValue():
        return None
    values = primvar.ComputeFlattened(time)
    if values is None or len(values) == 0:
        return None
    return np.array(values, dtype=np.float64).reshape(len(values), -1), primvar.GetInterpolation()


def read_normals(mesh: UsdGeom.Mesh, time: Usd.TimeCode) -> tuple[np.ndarray, str] | None:
    """`primvars:normals` if authored (it wins, as in USD), else the `normals` attribute."""
    found = _read_primvar(mesh.GetPrim(), "normals", time)
    if found is not None:
        return found
    normals = mesh.GetNormalsAttr().Get(time)
    if not normals:
        return None
    return np.array(normals, dtype=np.float64), mesh.GetNormalsInterpolation()


def _validated(points, counts, indices) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, counts and indices as arrays, or BadMesh naming what is wrong."""
    if points is None or counts is None or indices is None or len(points) == 0:
        raise BadMesh("no points or faces")
    points = np.array(points, dtype=np.float64).reshape(-1, 3)
    counts = np.array(counts, dtype=np.int64)
    indices = np.array(indices, dtype=np.int64)
    if not np.isfinite(points).all():
        raise BadMesh(f"{int((~np.isfinite(points).all(axis=1)).sum())} points are NaN or infinite")
    if counts.sum() != indices.size or (counts < 0).any():
        raise BadMesh(f"faceVertexCounts sum {counts.sum()} != {indices.size} faceVertexIndices")
    if indices.size and (indices.min() < 0 or indices.max() >= len(points)):
        bad = indices[(indices < 0) | (indices >= len(points))][0]
        raise BadMesh(f"faceVertexIndices holds {bad}, outside 0..{len(points) - 1}")
    return points, counts, indices


def read_mesh(prim: Usd.Prim, time: Usd.TimeCode, report: Report, uv_name: str = "st",
              pose: Pose | None = None, primvars: tuple[str, ...] = ()) -> MeshGeometry:
    """A UsdGeom.Mesh as triangles; per-corner vertices are unwelded when a primvar needs it.

    `uv_name` is the primvar the mesh's material reads as texture coordinates, `primvars`
    the others its materials read (any interpolation; constant ones broadcast). A `pose`
    (UsdSkel's) replaces the authored points and normals.
    """
    mesh = UsdGeom.Mesh(prim)
    path = prim.GetPath()
    points, counts, indices = _validated(mesh.GetPointsAttr().Get(time) if pose is None else pose.points,
                                         mesh.GetFaceVertexCountsAttr().Get(time),
                                         mesh.GetFaceVertexIndicesAttr().Get(time))
    if (counts < 3).any():
        report.warn(f"{path}: {int((counts < 3).sum())} faces with fewer than 3 vertices skipped")
    corners, face = fan_triangulate(counts)
    holes = np.array(mesh.GetHoleIndicesAttr().Get(time) or [], dtype=np.int64)
    if ((holes < 0) | (holes >= counts.size)).any() and \
            mesh.GetSubdivisionSchemeAttr().Get(time) == UsdGeom.Tokens.none:  # a cage's are warned of there
        report.warn(f"{path}: holeIndices outside 0..{counts.size - 1} ignored")
    drawn = ~np.isin(face, holes)
    corners, face = corners[drawn], face[drawn]
    corner_face = np.repeat(np.arange(counts.size), counts)
    shape = (len(points), indices.size, counts.size)
    attrs = {"normals": read_normals(mesh, time) if pose is None else pose.normals,
             "st": _read_primvar(prim, uv_name, time),
             **{f"primvars:{name}": _read_primvar(prim, name, time) for name in primvars}}
    for name, found in list(attrs.items()):
        if found is not None and len(found[0]) != _expected_length(found[1], *shape):
            report.warn(f"{path}: {name} has {len(found[0])} values, wrong for "
                        f"{found[1]} interpolation; ignored")
            attrs[name] = None
    welded = all(found is None or found[1] in (*PER_POINT, "constant") for found in attrs.values())
    if welded:
        triangles = indices[corners]
        per_point = {k: None if v is None else v[0] if v[1] in PER_POINT else
                     np.broadcast_to(v[0][:1], (len(points), v[0].shape[1])) for k, v in attrs.items()}
    else:
        triangles = corners
        points = points[indices]
        per_point = {k: None if v is None else _corner_values(v[0], v[1], indices, corner_face)
                     for k, v in attrs.items()}
    if mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded:
        triangles = triangles[:, [0, 2, 1]]
    extra = {name: per_point[f"primvars:{name}"] for name in primvars if per_point[f"primvars:{name}"] is not None}
    return MeshGeometry(points, triangles, per_point["normals"], per_point["st"], face, extra,
                        indices if welded else np.arange(indices.size))
