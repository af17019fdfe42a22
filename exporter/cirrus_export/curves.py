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

from dataclasses import dataclass
from typing import Callable

import numpy as np
from pxr import Usd, UsdGeom

from .materials import NO_MATERIAL
from .round_shapes import RoundContext, RoundTable

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


@dataclass
class CurveSource:
    """What keying a curves record over the shutter needs (deforming.py): its prim, the
    frame's curveVertexCounts, widths count and interpolation, its vertices and widths as
    written (f32), and the frame's sampler, which evaluates control values at another time
    into the same pieces (same piece count per segment), so keys correspond vertex for vertex."""

    prim: Usd.Prim
    counts: np.ndarray
    widths: tuple[int, str]  # (count, interpolation); (0, "constant") when unauthored
    vertices: np.ndarray
    vertex_widths: np.ndarray
    sample: Callable[[np.ndarray, str], np.ndarray]


class CurvesTable(RoundTable):
    """The manifest's curves records, each stored once per prototype path and material;
    `sources` holds, per record, what deforming.py keys it with."""

    def __init__(self, context: RoundContext) -> None:
        super().__init__(context)
        self.sources: list[CurveSource] = []

    def _add(self, prim: Usd.Prim, key: tuple[str, int]) -> int | None:
        c = self._c
        name = f"{c.source}: {prim.GetTypeName()} {prim.GetPath()}"
        try:
            polylines = self._read(prim, name)
        except BadCurves as bad:
            c.report.warn(f"{name} skipped: {bad}")
            return None
        if polylines is None:
            c.report.warn(f"{name} skipped: no curve with a segment")
            return None
        material = key[1]
        if material == NO_MATERIAL:
            c.report.warn(f"{name} has no bound material and no displayColor: drawn with the default hair "
                          f"look (dark brown rough dielectric)")
            material = c.materials.hair()
        points, radii, vertex_counts, sample, source = polylines

        def expand(values: np.ndarray, interpolation: str) -> np.ndarray | None:
            try:
                return sample(values, interpolation)
            except (IndexError, ValueError):
                return None

        w = c.writer
        vertices, widths = points.astype(np.float32), (2 * radii).astype(np.float32)
        record = {
            "path": key[0],
            "points": w.add(vertices, "f32", 3),
            "widths": w.add(widths, "f32", 1),
            "vertex_counts": w.add(vertex_counts.astype(np.uint32), "u32", 1),
            "material": material,
            "primvars": c.primvars(prim, material, expand),
        }
        self.sources.append(CurveSource(prim, *source, vertices, widths, sample))
        return c.add(record, points, radii)

    def _read(self, prim: Usd.Prim, name: str) -> tuple | None:
        """The curves with a segment as (vertices, radii, vertex count per curve, sampler of
        per-vertex values, (curveVertexCounts, (widths count, interpolation))); None when
        no curve has a segment."""
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
        authored = (0 if widths is None else len(widths), interpolation)
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
        for i in np.flatnonzero(np.array(segments) < 1):
            n = counts[i]
            c.report.warn(f"{name}: curve {i} has {n} vertices, too few for a {'cubic ' + basis if cubic else 'linear'} "
                          f"{wrap} curve; skipped")
        if not any(s >= 1 for s in segments):
            return None
        vertices, widths, vertex_counts, sample = shape.polylines(points, widths, interpolation)
        return vertices, 0.5 * widths[:, 0], vertex_counts, sample, (counts, authored)


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

    def polylines(self, points: np.ndarray, widths: np.ndarray, interpolation: str):
        """The curves with a segment as (vertices, widths, vertex count per curve, sampler):
        the sampler maps any per-vertex, varying, uniform or constant array to the vertices.
        Vectorised over every segment of every curve: each batched product is the
        per-segment one, slice for slice (numpy's stacked matmul runs the same product per
        slice), so the output is bit for bit that of a loop over segments."""
        per_curve = np.array(self.segments, dtype=np.int64)
        first = np.concatenate([[0], np.cumsum(self.counts)[:-1]])
        varying = np.maximum(per_curve, 0) + (0 if self.wrap == "periodic" else 1)
        varying_first = np.concatenate([[0], np.cumsum(varying)[:-1]])
        kept = np.flatnonzero(per_curve >= 1)
        n_seg = per_curve[kept]
        kept_of_segment = np.repeat(np.arange(len(kept)), n_seg)
        curve = kept[kept_of_segment]
        seg = np.arange(n_seg.sum()) - np.repeat(np.cumsum(n_seg) - n_seg, n_seg)
        n = self.counts[kept]
        extra = (3 if self.cubic else 1) if self.wrap == "periodic" else 0
        pinned = self.wrap == "pinned" and self.cubic and self.basis != "bezier"
        lengths = n + extra + (2 if pinned else 0)
        starts = np.cumsum(lengths) - lengths
        local = np.arange(lengths.sum()) - np.repeat(starts, lengths)
        n_of = np.repeat(n, lengths)
        local = np.clip(local - 1, 0, n_of - 1) if pinned else local % n_of
        rows_of_controls = np.repeat(first[kept], lengths) + local

        def controls(values: np.ndarray) -> np.ndarray:
            """Every kept curve's control values from `starts`: periodic ones repeated past the end,
            pinned bspline/catmullRom ones with phantom ends (2 P0 - P1, 2 Pn - Pn-1)."""
            out = values[rows_of_controls]
            if pinned:
                f, last = first[kept], first[kept] + n - 1
                out[starts] = 2 * values[f] - values[f + 1]
                out[starts + lengths - 1] = 2 * values[last] - values[last - 1]
            return out

        def at(values: np.ndarray, interp: str, which: np.ndarray, t: np.ndarray) -> np.ndarray:
            """(len(which), len(t), width): segments `which` at parameters t."""
            shape = (len(which), len(t), values.shape[1])
            if interp == "constant":
                return np.broadcast_to(values[:1], shape)
            if interp == "uniform":
                return np.broadcast_to(values[curve[which]][:, None], shape)
            if interp == "varying":
                base, count = varying_first[curve[which]], varying[curve[which]]
                a, b = values[base + seg[which]][:, None], values[base + (seg[which] + 1) % count][:, None]
                return a + t[:, None] * (b - a)
            table, start = controls(values), starts[kept_of_segment[which]]
            if not self.cubic:
                a, b = table[start + seg[which]][:, None], table[start + seg[which] + 1][:, None]
                return a + t[:, None] * (b - a)
            matrix, step = BASES[self.basis]
            return _weights(matrix, t) @ table[(start + seg[which] * step)[:, None] + np.arange(4)]

        everything = np.arange(len(seg))
        if not self.cubic:
            pieces = np.ones(len(seg), dtype=np.int64)
        else:
            matrix, step = BASES[self.basis]
            windows = controls(points)[(starts[kept_of_segment] + seg * step)[:, None] + np.arange(4)]
            curvature = np.maximum(*(np.sqrt(np.einsum("sk,sk->s", v, v)) for v in
                                     (_second_derivative(matrix, t) @ windows for t in (0.0, 1.0))))
            if interpolation == "constant":
                r = np.full(len(seg), 0.5 * widths[0, 0])
            else:
                r = 0.5 * at(widths, interpolation, everything, np.array([0.0, 1.0])).min(axis=1)[:, 0]
            tolerance = np.maximum(RELATIVE_TOLERANCE * r, 1e-7 * np.abs(windows).max(axis=(1, 2), initial=1.0))
            pieces = np.clip(np.ceil(np.sqrt(curvature / (8 * tolerance))), 1, MAX_PIECES).astype(np.int64)
        # A curve's first segment keeps its first vertex; the others start at their second.
        opens = seg == 0
        rows = pieces + opens
        offsets = np.cumsum(rows) - rows
        groups = []
        for count, whole in set(zip(pieces.tolist(), opens.tolist())):
            t = np.linspace(0.0, 1.0, count + 1)
            groups.append((np.flatnonzero((pieces == count) & (opens == whole)), t if whole else t[1:]))

        def sample(values: np.ndarray, interp: str) -> np.ndarray:
            out = np.empty((int(rows.sum()), values.shape[1]), dtype=np.result_type(values, np.float64))
            for which, t in groups:
                part = at(values, interp, which, t)
                out[(offsets[which][:, None] + np.arange(len(t))).reshape(-1)] = part.reshape(-1, values.shape[1])
            return out

        vertex_counts = np.add.reduceat(rows, np.cumsum(n_seg) - n_seg)
        return sample(points, "vertex"), sample(widths, interpolation), vertex_counts, sample
