"""Transform conversions: USD row-vector 4x4 (double) to Cirrus column-vector 3x4.

USD composes `p' = p M` with the translation in the last row; Cirrus stores
`p' = M[:, :3] p + M[:, 3]`, i.e. the transpose, cut to 3 rows, rounded to f32
only here, after composing in double precision.
"""

import numpy as np
from pxr import Gf, Usd, UsdGeom


def as_array(matrix: Gf.Matrix4d) -> np.ndarray:
    """A Gf.Matrix4d as a (4, 4) float64 array, row-vector convention kept."""
    return np.array(matrix, dtype=np.float64).reshape(4, 4)


def to_3x4(matrices: np.ndarray) -> np.ndarray:
    """Row-vector (..., 4, 4) matrices as Cirrus (..., 12) rows of [R | t], f32."""
    cols = np.swapaxes(matrices, -1, -2)[..., :3, :]
    return cols.reshape(*matrices.shape[:-2], 12).astype(np.float32)


def to_3x4_list(matrix: np.ndarray) -> list[float]:
    """One row-vector 4x4 as the 12-float JSON list of the manifest."""
    return [float(v) for v in to_3x4(matrix)]


def local_transform(prim: Usd.Prim, time: Usd.TimeCode) -> tuple[np.ndarray, bool]:
    """The prim's own xformOps at `time`, and whether it resets the xform stack."""
    xformable = UsdGeom.Xformable(prim)
    if not xformable:
        return np.eye(4), False
    return as_array(xformable.GetLocalTransformation(time)), xformable.GetResetXformStack()


def compose(inner: np.ndarray, outer: np.ndarray) -> np.ndarray:
    """Every inner (m, 4, 4) placed by every outer (n, 4, 4): (n * m, 4, 4), outer-major."""
    return np.matmul(inner[None, :, :, :], outer[:, None, :, :]).reshape(-1, 4, 4)


def transform_points(points: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """(n, 3) points through one row-vector 4x4."""
    return points @ matrix[:3, :3] + matrix[3, :3]


def box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The 8 corners of an axis-aligned box, (8, 3)."""
    pick = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)
    return np.where(pick, hi, lo)
