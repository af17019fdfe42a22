"""The control cage of a subdivision surface (FORMAT.md, Mesh.subdivision).

USD's `subdivisionScheme` defaults to `catmullClark`: every Mesh that does not say `none`
is a cage, and the renderer refines it with OpenSubdiv at load. This module writes what
it needs beside the triangulated cage (kept as the fallback when OpenSubdiv refuses the
topology): faces, creases and corners as vertex pairs and sharpnesses, holes, the tags,
and `corner_points`, which ties each face corner to the mesh's exported points so every
per-point array (texture coordinates, other primvars) is refined as face-varying data.
Each tag we cannot honour is warned about by prim and attribute, never dropped silently.
"""

import numpy as np
from pxr import Usd, UsdGeom

from .binfile import BinWriter
from .meshes import MeshGeometry
from .report import Report

# USD token -> the value the manifest writes (serde names in src/subdivision/mod.rs).
SCHEMES = {"catmullClark": "catmullClark", "loop": "loop", "bilinear": "bilinear"}
TAGS = {
    "interpolateBoundary": ("edgeAndCorner", {"none", "edgeOnly", "edgeAndCorner"}),
    "faceVaryingLinearInterpolation": (
        "cornersPlus1", {"none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all"}),
    "triangleSubdivisionRule": ("catmullClark", {"catmullClark", "smooth"}),
}
# The per-mesh level primvar; --subdiv-level does not override it.
LEVEL_PRIMVAR = "cirrus:subdivisionLevel"


def scheme(prim: Usd.Prim, time: Usd.TimeCode) -> str | None:
    """The mesh's scheme as the manifest names it, or None for `none` (and non-meshes)."""
    if not prim.IsA(UsdGeom.Mesh):
        return None
    token = UsdGeom.Mesh(prim).GetSubdivisionSchemeAttr().Get(time)
    return None if token == UsdGeom.Tokens.none else SCHEMES.get(str(token), "catmullClark")


def _array(attr: Usd.Attribute, time: Usd.TimeCode, dtype) -> np.ndarray:
    values = attr.Get(time)
    return np.array(values if values is not None else [], dtype=dtype)


class CageWriter:
    """Builds Mesh.subdivision records, warning about each tag it cannot use."""

    def __init__(self, writer: BinWriter, report: Report, time: Usd.TimeCode, source: str) -> None:
        self._w, self._report, self._time, self._source = writer, report, time, source

    def _warn(self, prim: Usd.Prim, message: str) -> None:
        self._report.approximated("subdivision tags", f"{self._source}: mesh {prim.GetPath()}: {message}")

    def record(self, prim: Usd.Prim, geometry: MeshGeometry, face_materials: np.ndarray) -> dict:
        """The `subdivision` record of a cage whose triangulation is `geometry`."""
        mesh, t = UsdGeom.Mesh(prim), self._time
        token = str(mesh.GetSubdivisionSchemeAttr().Get(t))
        if token not in SCHEMES:
            self._warn(prim, f"subdivisionScheme '{token}' is unknown; refined as catmullClark")
        counts = _array(mesh.GetFaceVertexCountsAttr(), t, np.int64)
        indices = _array(mesh.GetFaceVertexIndicesAttr(), t, np.int64)
        n_points = len(mesh.GetPointsAttr().Get(t) or [])
        corner_points = geometry.corner_points
        if mesh.GetOrientationAttr().Get(t) == UsdGeom.Tokens.leftHanded:
            order = _reversed_corners(counts)
            indices, corner_points = indices[order], corner_points[order]
        if geometry.normals is not None:
            self._warn(prim, "normals are ignored on a subdivision surface (its limit normals are used)")
        pairs, sharp = self._creases(prim, mesh, n_points)
        if len(sharp) and SCHEMES.get(token) == "bilinear":
            self._warn(prim, "creaseSharpnesses have no effect under the bilinear scheme")
        corners, corner_sharp = self._corners(prim, mesh, n_points)
        holes = _array(mesh.GetHoleIndicesAttr(), t, np.int64)
        if holes.size and (holes.min() < 0 or holes.max() >= counts.size):
            self._warn(prim, f"holeIndices outside 0..{counts.size - 1}; holes ignored")
            holes = holes[:0]
        w = self._w
        return {
            "scheme": SCHEMES.get(token, "catmullClark"),
            **{_snake(tag): self._tag(prim, tag) for tag in TAGS},
            "level": self._level(prim),
            "vertex_count": n_points,
            "face_counts": w.add(counts, "u32", 1),
            "face_indices": w.add(indices, "u32", 1),
            "corner_points": w.add(corner_points, "u32", 1),
            "face_materials": w.add(face_materials, "u32", 1),
            "crease_pairs": w.add(pairs, "u32", 1),
            "crease_sharpness": w.add(sharp, "f32", 1),
            "corners": w.add(corners, "u32", 1),
            "corner_sharpness": w.add(corner_sharp, "f32", 1),
            "holes": w.add(holes, "u32", 1),
        }

    def _tag(self, prim: Usd.Prim, tag: str) -> str:
        default, known = TAGS[tag]
        attr = prim.GetAttribute(tag)
        value = str(attr.Get(self._time)) if attr and attr.HasAuthoredValue() else default
        if value not in known:
            self._warn(prim, f"{tag} '{value}' is not a USD value; '{default}' used")
            return default
        return value

    def _level(self, prim: Usd.Prim) -> int | None:
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(LEVEL_PRIMVAR)
        if not primvar or not primvar.HasValue():
            return None
        value = primvar.Get(self._time)
        if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= 0:
            return int(value)
        self._warn(prim, f"primvars:{LEVEL_PRIMVAR} = {value!r} is not a level (an int >= 0); ignored")
        return None

    def _creases(self, prim: Usd.Prim, mesh: UsdGeom.Mesh, n_points: int) -> tuple[np.ndarray, np.ndarray]:
        """Crease chains as (edge vertex pairs, sharpness per edge); ignored with a warning when
        creaseIndices, creaseLengths and creaseSharpnesses do not fit together."""
        t = self._time
        indices = _array(mesh.GetCreaseIndicesAttr(), t, np.int64)
        lengths = _array(mesh.GetCreaseLengthsAttr(), t, np.int64)
        sharp = _array(mesh.GetCreaseSharpnessesAttr(), t, np.float64)
        none = (np.zeros(0, np.int64), np.zeros(0, np.float64))
        if not indices.size and not lengths.size and not sharp.size:
            return none
        edges = int((lengths - 1).sum()) if lengths.size else 0
        problem = None
        if (lengths < 2).any() or lengths.sum() != indices.size:
            problem = f"creaseLengths sum to {lengths.sum()} (each at least 2) for {indices.size} creaseIndices"
        elif sharp.size not in (lengths.size, edges):
            problem = (f"creaseSharpnesses has {sharp.size} values for {lengths.size} creases "
                       f"({edges} edges)")
        elif indices.min() < 0 or indices.max() >= n_points:
            problem = f"creaseIndices outside 0..{n_points - 1}"
        elif not np.isfinite(sharp).all():
            problem = "creaseSharpnesses are not finite"
        if problem:
            self._warn(prim, f"{problem}; creases ignored")
            return none
        starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
        chain = np.repeat(np.arange(lengths.size), lengths - 1)
        step = np.arange(edges) - np.repeat(np.cumsum(lengths - 1) - (lengths - 1), lengths - 1)
        first = starts[chain] + step
        pairs = np.stack([indices[first], indices[first + 1]], axis=1).reshape(-1)
        return pairs, (sharp[chain] if sharp.size == lengths.size and sharp.size != edges else sharp)

    def _corners(self, prim: Usd.Prim, mesh: UsdGeom.Mesh, n_points: int) -> tuple[np.ndarray, np.ndarray]:
        t = self._time
        corners = _array(mesh.GetCornerIndicesAttr(), t, np.int64)
        sharp = _array(mesh.GetCornerSharpnessesAttr(), t, np.float64)
        if corners.size != sharp.size or (corners.size and (corners.min() < 0 or corners.max() >= n_points)):
            self._warn(prim, f"cornerIndices ({corners.size}) and cornerSharpnesses ({sharp.size}) do not "
                             f"match or index outside 0..{n_points - 1}; corners ignored")
            return np.zeros(0, np.int64), np.zeros(0, np.float64)
        return corners, sharp


def _snake(tag: str) -> str:
    """`interpolateBoundary` -> `interpolate_boundary`."""
    return "".join(f"_{c.lower()}" if c.isupper() else c for c in tag)


def _reversed_corners(counts: np.ndarray) -> np.ndarray:
    """Corner order that reverses each face (leftHanded to counter-clockwise)."""
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    face = np.repeat(np.arange(counts.size), counts)
    k = np.arange(counts.sum()) - starts[face]
    return starts[face] + np.where(k == 0, 0, counts[face] - k)
