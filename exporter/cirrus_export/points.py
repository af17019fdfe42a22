"""UsdGeomPoints as spheres: one centre and one diameter (`widths`) per point."""

import numpy as np
from pxr import Usd, UsdGeom

from .round_shapes import RoundContext, RoundTable

# UsdGeomPoints declares no fallback for `widths`; Hydra (UsdImaging's points adapter) draws
# unauthored widths as 1, which we follow, with a warning.
DEFAULT_WIDTH = 1.0


class PointsTable(RoundTable):
    """The manifest's points records, each stored once per prototype path and material;
    `sources` holds, per record, its prim, the mask of points kept and their centres at the
    frame (deforming.py keys them over the shutter)."""

    def __init__(self, context: RoundContext) -> None:
        super().__init__(context)
        self.sources: list[tuple[Usd.Prim, np.ndarray, np.ndarray]] = []

    def _add(self, prim: Usd.Prim, key: tuple[str, int]) -> int | None:
        c, geom, name = self._c, UsdGeom.Points(prim), f"{self._c.source}: Points {prim.GetPath()}"
        points = np.asarray(geom.GetPointsAttr().Get(c.time) or [], dtype=np.float64).reshape(-1, 3)
        widths = geom.GetWidthsAttr().Get(c.time)
        if widths is None or len(widths) == 0:
            c.report.warn(f"{name} has no widths; drawn with USD's (Hydra's) default diameter "
                          f"{DEFAULT_WIDTH:g}")
            widths = [DEFAULT_WIDTH]
        widths = np.asarray(widths, dtype=np.float64)
        if len(widths) != 1 and len(widths) != len(points):
            c.report.warn(f"{name} skipped: widths has {len(widths)} values for {len(points)} points "
                          f"(expected 1 or one per point)")
            return None
        per_point = np.broadcast_to(widths, len(points))
        keep = np.isfinite(points).all(axis=1) & np.isfinite(per_point) & (per_point >= 0)
        if not keep.all():
            c.report.warn(f"{name}: {int((~keep).sum())} of {len(points)} points skipped: widths negative "
                          f"or not finite, or points not finite")
        if not keep.any():
            c.report.warn(f"{name} skipped: no point left to render")
            return None
        material = key[1]

        def expand(values: np.ndarray, interpolation: str) -> np.ndarray | None:
            if len(values) == 1:
                return np.repeat(values, keep.sum(), axis=0)
            return values[keep] if len(values) == len(points) else None

        w = c.writer
        kept_widths = per_point[keep] if len(widths) != 1 else widths
        record = {
            "path": key[0],
            "points": w.add(points[keep].astype(np.float32), "f32", 3),
            "widths": w.add(np.asarray(kept_widths, dtype=np.float32), "f32", 1),
            "material": material,
            "primvars": c.primvars(prim, material, expand),
        }
        self.sources.append((prim, keep, points[keep]))
        return c.add(record, points[keep], 0.5 * per_point[keep])
