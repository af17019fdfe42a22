"""What points and curves prims share: their material (bound, else displayColor) and the
primvars that material reads, carried per point or per curve vertex."""

from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom

from .geometry_lights import warn_round_shapes
from .materials import NO_MATERIAL, MaterialTable
from .prims import prototype_path
from .report import Report


@dataclass
class RoundContext:
    """The shared state of the points and curves tables."""
    writer: object  # BinWriter
    materials: MaterialTable
    report: Report
    time: Usd.TimeCode
    source: str
    records: list[dict] = field(default_factory=list)
    boxes: list = field(default_factory=list)
    # What primvar RenderVars read: carried by every prim that has them, beside its material's.
    aov_primvars: tuple[str, ...] = ()

    def material(self, prim: Usd.Prim) -> int:
        """The bound material, else the displayColor one, else NO_MATERIAL."""
        own = self.materials.bound_index(prim)
        return self.materials.display_color(prim) if own == NO_MATERIAL else own

    def key(self, prim: Usd.Prim) -> tuple[str, int]:
        """Shared by prototype path and material, as meshes are."""
        return prototype_path(prim), self.material(prim)

    def primvar(self, prim: Usd.Prim, name: str, expand, read: bool = True) -> np.ndarray | None:
        """Primvar `name` as (n, width) f32, `expand` turning (values, interpolation) into one
        row per point or vertex; None (with a warning) when it does not fit, or when it is
        missing and `read` by the material."""
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(name)
        values = primvar.ComputeFlattened(self.time) if primvar and primvar.HasValue() else None
        if values is None or len(values) == 0:
            if read:
                self.report.warn(f"{self.source}: {prim.GetTypeName()} {prim.GetPath()} has no primvar "
                                 f"{name} (read by its material); its fallback is used")
            return None
        array = np.asarray(values, dtype=np.float64)
        array = array.reshape(len(array), -1)
        expanded = expand(array, str(primvar.GetInterpolation()))
        if expanded is None:
            self.report.warn(f"{self.source}: {prim.GetTypeName()} {prim.GetPath()} primvars:{name}: "
                             f"{len(array)} {primvar.GetInterpolation()} values do not fit; its fallback is used")
            return None
        return expanded.astype(np.float32)

    def primvars(self, prim: Usd.Prim, material: int, expand) -> dict:
        """The manifest primvars record: every primvar the material reads or a RenderVar asks
        for that fits."""
        out = {}
        read = self.materials.primvars(material) if material != NO_MATERIAL else set()
        for name in sorted(read | set(self.aov_primvars)):
            values = self.primvar(prim, name, expand, name in read)
            if values is not None:
                out[name] = self.writer.add(values, "f32", values.shape[1])
        return out

    def add(self, record: dict, points: np.ndarray, radii: np.ndarray) -> int:
        """Stores a record with its object-space box (points grown by their radii)."""
        self.records.append(record)
        self.boxes.append(((points - radii[:, None]).min(axis=0), (points + radii[:, None]).max(axis=0)))
        return len(self.records) - 1


class RoundTable:
    """A table of points or curves records, each prim stored once per prototype path and
    material; subclasses read one prim in `_add`."""

    def __init__(self, context: RoundContext) -> None:
        self._c = context
        self._by_key: dict[tuple, int | None] = {}

    @property
    def records(self) -> list[dict]:
        return self._c.records

    @property
    def boxes(self) -> list:
        return self._c.boxes

    def index(self, prim: Usd.Prim) -> int | None:
        """The record index of a prim, reading it the first time; None when it was skipped."""
        key = self._c.key(prim)
        if key not in self._by_key:
            warn_round_shapes(prim, self._c.report)
            self._by_key[key] = self._add(prim, key)
        return self._by_key[key]

    def _add(self, prim: Usd.Prim, key: tuple[str, int]) -> int | None:
        raise NotImplementedError
