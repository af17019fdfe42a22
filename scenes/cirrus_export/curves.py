"""UsdGeomBasisCurves (and NurbsCurves, as their control polygon) as linear round tubes.

Cubic curves are evaluated here into linear pieces: each cubic segment is cut into N equal
parameter steps, N the smallest for which the chord error bound max|C''| / (8 N^2) stays
within a tenth of the segment's smallest radius (C'' is linear in t on a cubic, so its
largest norm is at an end), at most MAX_PIECES. Widths and primvars of `vertex`
interpolation go through the same basis weights as the points; `varying` ones are lerped
along each segment, `uniform` ones held per curve, `constant` ones everywhere. Periodic
curves are closed by repeating their first evaluated vertex; pinned bspline and catmullRom
curves get USD's phantom end points (2 P0 - P1, 2 Pn - Pn-1).
"""

import numpy as np
from pxr import Usd, UsdGeom

from .materials import NO_MATERIAL
from .round_shapes import RoundTable

# UsdGeomCurves declares no fallback for `widths`; Hydra draws unauthored widths as 1.
DEFAULT_WIDTH = 1.0
# Tolerance of the linear pieces, relative to the segment's smallest radius.
RELATIVE_TOLERANCE = 0.1
MAX_PIECES = 64

# Basis matrices: a segment's point at t is [t^3, t^2, t, 1] @ M @ (its 4 control points).
BASES = {
    "bezier": (np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 3, 0, 0], [1, 0, 0, 0]]), 3),
    "bspline": (np.array([[-1, 3, -3, 1], [3, -6, 3, 0], [-3, 0, 3, 0], [1, 4, 1, 0]]) / 6.0, 1),
    "catmullRom": (np.array([[-1, 3, -3, 1], [2, -5, 4, -1], [-1, 0, 1, 0], [0, 2, 0, 0]]) / 2.0, 1),
}


class BadCurves(Exception):
    """A curves prim that cannot be read; the message names the attribute."""


def segment_count(n: int, cubic: bool, basis: str, wrap: str) -> int:
    """Segments of a curve of n vertices, as UsdGeomBasisCurves defines them."""
    if not cubic:
        return n if wrap == "periodic" else n - 1
    step = BASES[basis][1]
    if wrap == "periodic":
        return n // step
    if wrap == "pinned" and basis != "bezier":
        return n - 1
    return (n - 4) // step + 1


def _weights(matrix: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(len(t), 4) basis weights at the parameters t."""
    return np.stack([t ** 3, t ** 2, t, np.ones_like(t)], axis=1) @ matrix


def _second_derivative(matrix: np.ndarray, t: float) -> np.ndarray:
    """(4,) weights of C'' at t."""
    return np.array([6 * t, 2, 0, 0]) @ matrix


class CurvesTable(RoundTable):
    """The manifest's curves records, each stored once per prototype path and material."""

    def _add(self, prim: Usd.Prim, key: tuple[str, int]) -> int | None:
        c = self._c
        name = f"{c.source}: {prim.GetTypeName()} {prim.GetPath()}"
        try:
            polylines = self._read(prim, name)
        except BadCurves as bad:
            c.report.warn(f"{name} skipped: {bad}")
            return None
        if not polylines:
            c.report.warn(f"{name} skipped: no curve with a segment")
            return None
        material = key[1]
        if material == NO_MATERIAL:
            c.report.warn(f"{name} has no bound material and no displayColor: drawn with the default hair "
                          f"look (dark brown rough dielectric)")
            material = c.materials.hair()
        points = np.concatenate([p for p, _, _ in polylines])
        radii = 0.5 * np.concatenate([r for _, r, _ in polylines])
        sample = [s for _, _, s in polylines]

        def expand(values: np.ndarray, interpolation: str) -> np.ndarray | None:
            try:
                return np.concatenate([s(values, interpolation) for s in sample])
            except (IndexError, ValueError):
                return None

        w = c.writer
        record = {
            "path": key[0],
            "points": w.add(points.astype(np.float32), "f32", 3),
            "widths": w.add((2 * radii).astype(np.float32), "f32", 1),
            "vertex_counts": w.add(np.array([len(p) for p, _, _ in polylines], dtype=np.uint32), "u32", 1),
            "material": material,
            "primvars": c.primvars(prim, material, expand),
        }
        return c.add(record, points, radii)

    def _read(self, prim: Usd.Prim, name: str) -> list:
        """Each curve as (vertices, widths, sampler of per-vertex values)."""
        c, geom = self._c, UsdGeom.Curves(prim)
        points = np.asarray(geom.GetPointsAttr().Get(c.time) or [], dtype=np.float64).reshape(-1, 3)
        counts = np.asarray(geom.GetCurveVertexCountsAttr().Get(c.time) or [], dtype=np.int64)
        if counts.sum() != len(points) or (counts < 0).any():
            raise BadCurves(f"curveVertexCounts sums to {counts.sum()} but points has {len(points)} values")
        if not np.isfinite(points).all():
            raise BadCurves("points has values that are not finite")
        if prim.IsA(UsdGeom.BasisCurves):
            curves = UsdGeom.BasisCurves(prim)
            cubic = curves.GetTypeAttr().Get(c.time) == "cubic"
            basis = str(curves.GetBasisAttr().Get(c.time) or "bezier")
            wrap = str(curves.GetWrapAttr().Get(c.time) or "nonperiodic")
            if cubic and basis not in BASES:
                raise BadCurves(f"basis {basis} is not bezier, bspline or catmullRom")
        else:
            c.report.approximated("NurbsCurves", f"{name}: NURBS curves are drawn as their control polygon "
                                  f"(linear), not the NURBS curve")
            cubic, basis, wrap = False, "bezier", "nonperiodic"
        segments = [segment_count(int(n), cubic, basis, wrap) for n in counts]
        widths = geom.GetWidthsAttr().Get(c.time)
        interpolation = str(geom.GetWidthsInterpolation())
        if widths is None or len(widths) == 0:
            c.report.warn(f"{name} has no widths; drawn with USD's (Hydra's) default diameter {DEFAULT_WIDTH:g}")
            widths, interpolation = [DEFAULT_WIDTH], "constant"
        widths = np.asarray(widths, dtype=np.float64).reshape(-1, 1)
        if not (np.isfinite(widths).all() and (widths >= 0).all()):
            raise BadCurves("widths has negative or non-finite values")
        shape = Shape(cubic, basis, wrap, counts, segments)
        if not shape.fits(len(widths), interpolation):
            raise BadCurves(f"widths has {len(widths)} {interpolation} values, which do not fit "
                            f"curveVertexCounts")
        out = []
        first, varying_first = 0, 0
        for i, (n, segs) in enumerate(zip(counts, segments)):
            if segs < 1:
                c.report.warn(f"{name}: curve {i} has {n} vertices, too few for a {'cubic ' + basis if cubic else 'linear'} "
                              f"{wrap} curve; skipped")
            else:
                out.append(shape.polyline(i, points, widths, interpolation, first, varying_first))
            first += int(n)
            varying_first += shape.varying_count(segs)
        return out


class Shape:
    """The curves' type, basis and wrap, and how their values are evaluated."""

    def __init__(self, cubic: bool, basis: str, wrap: str, counts: np.ndarray, segments: list[int]) -> None:
        self.cubic, self.basis, self.wrap, self.counts, self.segments = cubic, basis, wrap, counts, segments

    def varying_count(self, segments: int) -> int:
        return max(segments, 0) + (0 if self.wrap == "periodic" else 1)

    def fits(self, count: int, interpolation: str) -> bool:
        want = {"constant": 1, "uniform": len(self.counts), "vertex": int(self.counts.sum()),
                "varying": sum(self.varying_count(s) for s in self.segments)}
        return want.get(interpolation) == count

    def _controls(self, values: np.ndarray) -> np.ndarray:
        """A curve's control values with wrap applied: periodic ones repeated past the end,
        pinned bspline/catmullRom ones with phantom ends."""
        if self.wrap == "periodic":
            extra = 3 if self.cubic else 1
            return np.concatenate([values, values[:extra]])
        if self.wrap == "pinned" and self.cubic and self.basis != "bezier":
            return np.concatenate([2 * values[:1] - values[1:2], values, 2 * values[-1:] - values[-2:-1]])
        return values

    def polyline(self, i: int, points, widths, interpolation: str, first: int, varying_first: int):
        """Curve i as (vertices, widths, sampler): the sampler maps any per-vertex, varying,
        uniform or constant array to the polyline's vertices."""
        n, segs = int(self.counts[i]), self.segments[i]
        controls = self._controls(points[first:first + n])
        if not self.cubic:
            pieces = [(s, np.array([0.0, 1.0])) for s in range(segs)]
        else:
            matrix, step = BASES[self.basis]
            raw_w = widths if interpolation == "constant" else None
            pieces = []
            for s in range(segs):
                p = controls[s * step:s * step + 4]
                curvature = max(np.linalg.norm(_second_derivative(matrix, t) @ p) for t in (0.0, 1.0))
                r = 0.5 * (raw_w[0, 0] if raw_w is not None else self._sample(widths, interpolation, i, first,
                                                                             varying_first, s, np.array([0.0, 1.0])).min())
                tolerance = max(RELATIVE_TOLERANCE * r, 1e-7 * np.abs(p).max(initial=1.0))
                count = int(np.clip(np.ceil(np.sqrt(curvature / (8 * tolerance))), 1, MAX_PIECES))
                pieces.append((s, np.linspace(0.0, 1.0, count + 1)))

        def sample(values: np.ndarray, interp: str) -> np.ndarray:
            rows = [self._sample(values, interp, i, first, varying_first, s, t if k == 0 else t[1:])
                    for k, (s, t) in enumerate(pieces)]
            return np.concatenate(rows)

        return sample(points, "vertex"), sample(widths, interpolation)[:, 0], sample

    def _sample(self, values, interp: str, i: int, first: int, varying_first: int, s: int, t: np.ndarray):
        """Values of segment s of curve i at parameters t, by interpolation."""
        if interp == "constant":
            return np.repeat(values[:1], len(t), axis=0)
        if interp == "uniform":
            return np.repeat(values[i:i + 1], len(t), axis=0)
        if interp == "varying":
            ends = values[varying_first:varying_first + self.varying_count(self.segments[i])]
            a, b = ends[s], ends[(s + 1) % len(ends)]
            return a + t[:, None] * (b - a)
        controls = self._controls(values[first:first + int(self.counts[i])])
        if not self.cubic:
            a, b = controls[s], controls[s + 1]
            return a + t[:, None] * (b - a)
        matrix, step = BASES[self.basis]
        return _weights(matrix, t) @ controls[s * step:s * step + 4]
