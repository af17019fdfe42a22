"""Unique geometry (meshes, volumes) and the Cirrus prototypes that group it.

A mesh is keyed by its path inside its USD prototype, so every instance of a native
prototype or PointInstancer prototype shares one copy; a mesh posed by UsdSkel is keyed
by its own path (the walker decides which instances may share its pose).

A primvar a mesh's material reads and the mesh lacks is inherited, as USD inherits
primvars, from the nearest ancestor with a constant one, up to the nearest native instance
or PointInstancer (`prims.inherited_primvar`); above that it differs per copy and is carried per
instance (instancing.py). A primvar still missing is warned about once the walk knows
whether every copy's instance carries it (`missing`), unless the material reading it falls
back to the unbound look (an unbound mesh's instance displayColor, `holders_display`).
"""

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

from .binfile import BinWriter
from .geometry_lights import is_light
from .materials import DISPLAY_INPUTS, NO_MATERIAL, MaterialTable
from .meshes import BadMesh, MeshGeometry, read_mesh
from .prims import PREDICATE, asset_within, below, inherited_primvar, prototype_path
from .report import Report
from .shapes import tessellate
from .skinning import Skinning
from .subdivision import CageWriter, scheme
from .xforms import box_corners, to_3x4_list, transform_points

EMPTY_BOX = (np.full(3, np.inf), np.full(3, -np.inf))


def holders_display(stage: Usd.Stage) -> frozenset[str]:
    """The display primvars (displayColor, displayOpacity) that some PointInstancer or native
    instance root, or an ancestor of one, authors: those the copies of unbound meshes may get
    from their instances (docs/materials.md, "Primvars")."""
    found = set()
    for root in (stage.GetPseudoRoot(), *stage.GetPrototypes()):
        for prim in Usd.PrimRange(root):
            at = prim if prim.IsInstance() or prim.IsA(UsdGeom.PointInstancer) else None
            while at and not at.IsPseudoRoot():
                api = UsdGeom.PrimvarsAPI(at)
                found.update(name for name, _, _ in DISPLAY_INPUTS if api.GetPrimvar(name).HasValue())
                at = at.GetParent()
    return frozenset(found)


def _optional(writer: BinWriter, values: np.ndarray | None, width: int) -> dict | None:
    """An f32 array reference, or None for an absent attribute."""
    return None if values is None else writer.add(values, "f32", width)


class MeshTable:
    """Meshes of the manifest, each stored once, with their object-space bounds."""

    def __init__(self, writer: BinWriter, materials: MaterialTable, skinning: Skinning, report: Report,
                 time: Usd.TimeCode, source: str, aov_primvars: tuple[str, ...] = ()) -> None:
        self.records: list[dict] = []
        # What primvar RenderVars read: carried by every mesh that has them, beside its materials'.
        self._aov_primvars = aov_primvars
        self.boxes: list[tuple[np.ndarray, np.ndarray]] = []
        # Per record, what read it: (prim, uv primvar, material primvars), for deforming.py.
        self.sources: list[tuple[Usd.Prim, str, tuple[str, ...]]] = []
        # Per record index: (primvar, prim path, warning) for each primvar its materials read
        # and it lacks.
        self.missing: dict[int, list[tuple[str, str, str]]] = {}
        # The display primvars instances may give unbound meshes (holders_display), found once.
        self._holders_display: frozenset[str] | None = None
        self._cages = CageWriter(writer, report, time, source)
        self._by_path: dict[tuple, int | None] = {}
        self._writer, self._materials, self._skinning, self._report = writer, materials, skinning, report
        self._time, self._source = time, source

    def index(self, prim: Usd.Prim) -> int | None:
        """The mesh index of a Mesh or implicit gprim, or None when it was skipped.

        Meshes are shared by prototype path and materials: instances of one prototype
        whose bindings differ (bound outside the prototype) get their own copy. A posed
        mesh is keyed by its own path.
        """
        materials = self.material_key(prim)
        posed = self._skinning.pose(prim) is not None
        key = (str(prim.GetPath()) if posed else prototype_path(prim), materials)
        if key not in self._by_path:
            self._by_path[key] = self._add(prim, key[0], materials)
        return self._by_path[key]

    def _subsets(self, prim: Usd.Prim) -> list[UsdGeom.Subset]:
        """The prim's face GeomSubsets of the materialBind family."""
        return UsdGeom.Subset.GetGeomSubsets(UsdGeom.Imageable(prim), UsdGeom.Tokens.face,
                                             UsdShade.Tokens.materialBind)

    def material_key(self, prim: Usd.Prim) -> tuple[int, ...]:
        """Material indices a gprim uses: its own binding, then each materialBind subset's; a
        mesh light's own materials over them (geometry_lights.py)."""
        subsets = [s.GetPrim() for s in self._subsets(prim)]
        own = self._materials.bound_index(prim)
        own = self._materials.display_color(prim) if own == NO_MATERIAL else own
        if own == NO_MATERIAL:
            if self._holders_display is None:
                self._holders_display = holders_display(prim.GetStage())
            own = self._materials.instance_display(self._holders_display) if self._holders_display else own
        key = (own, *(self._materials.bound_index(p) for p in subsets))
        return tuple(self._materials.mesh_light(prim, m) for m in key) if is_light(prim) else key

    def reads(self, prims: list[Usd.Prim]) -> frozenset[str]:
        """The primvars the materials bound to these gprims read, and those primvar RenderVars
        read: what their instances may carry."""
        bound = {m for prim in prims for m in self.material_key(prim) if m != NO_MATERIAL}
        return frozenset(self._aov_primvars).union(*(self._materials.primvars(m) for m in bound))

    def lacking(self, prims: list[Usd.Prim]) -> tuple[tuple[str, str, str], ...]:
        """(primvar, prim path, warning) for each primvar these gprims' meshes lack but their
        materials read."""
        indices = {self.index(prim) for prim in prims}
        return tuple(found for index in sorted(i for i in indices if i is not None)
                     for found in self.missing.get(index, ()))

    def signature(self, root: Usd.Prim) -> tuple:
        """Every material binding under `root`: equal for instances that can share parts."""
        return tuple(self.material_key(p) for p in Usd.PrimRange(root, PREDICATE) if p.IsA(UsdGeom.Gprim))

    def _add(self, prim: Usd.Prim, key: str, materials: tuple[int, ...]) -> int | None:
        """Reads, validates and stores one mesh; a bad one is warned about and skipped."""
        bound = [m for m in materials if m != NO_MATERIAL]
        uv_name = self._materials.uv_primvar(bound[0]) if bound else "st"
        # A primvar some warned-about material reads names that one (silent ones come first).
        loud_last = sorted(bound, key=lambda m: m not in self._materials.silent)
        primvars = {name: m for m in loud_last for name in self._materials.primvars(m)}
        wanted = tuple(sorted(set(primvars) | set(self._aov_primvars)))
        try:
            geometry = read_mesh(prim, self._time, self._report, uv_name, self._skinning.pose(prim),
                                 wanted) if prim.IsA(UsdGeom.Mesh) else tessellate(prim, self._time)
        except BadMesh as bad:
            self._report.warn(f"{self._source}: mesh {prim.GetPath()} skipped: {bad}")
            return None
        if geometry is None or len(geometry.triangles) == 0:
            self._report.warn(f"{self._source}: {prim.GetTypeName()} {prim.GetPath()} has no triangles; skipped")
            return None
        for name in sorted(set(wanted) - set(geometry.primvars)):
            value = inherited_primvar(prim, name, self._time)
            if value is not None:
                geometry.primvars[name] = np.broadcast_to(value, (len(geometry.points), value.shape[1]))
        self.missing[len(self.records)] = [
            (name, str(prim.GetPath()), f"{self._source}: mesh {prim.GetPath()} has no primvar {name} (read by "
                                        f"material {self._materials.materials[primvars[name]]['path']}); its "
                                        f"fallback is used")
            for name in sorted(set(primvars) - set(geometry.primvars))
            if primvars[name] not in self._materials.silent]
        self.records.append(self._record(prim, key, geometry, materials))
        self.sources.append((prim, uv_name, tuple(sorted(primvars))))
        self.boxes.append((geometry.points.min(axis=0), geometry.points.max(axis=0)))
        return len(self.records) - 1

    def _face_materials(self, prim: Usd.Prim, faces: np.ndarray, materials: tuple[int, ...]) -> np.ndarray:
        """Material per entry of `faces` (authored face indices, one per triangle or per cage
        face): the prim's binding, overridden by materialBind GeomSubsets."""
        result = np.full(len(faces), materials[0], dtype=np.uint32)
        for subset, material in zip(self._subsets(prim), materials[1:]):
            indices = np.array(subset.GetIndicesAttr().Get(self._time) or [], dtype=np.int64)
            result[np.isin(faces, indices)] = material
        return result

    def _record(self, prim: Usd.Prim, key: str, geometry: MeshGeometry,
                materials: tuple[int, ...]) -> dict:
        """The manifest Mesh record, arrays written to scene.bin."""
        w = self._writer
        cage = None
        if scheme(prim, self._time) is not None:
            n_faces = len(UsdGeom.Mesh(prim).GetFaceVertexCountsAttr().Get(self._time) or [])
            cage = self._cages.record(prim, geometry,
                                      self._face_materials(prim, np.arange(n_faces), materials))
        return {
            "path": key,
            "points": w.add(geometry.points, "f32", 3),
            "triangles": w.add(geometry.triangles, "u32", 3),
            "normals": _optional(w, geometry.normals, 3),
            "uvs": _optional(w, geometry.uvs, 2),
            "primvars": {name: w.add(values, "f32", values.shape[1]) for name, values in geometry.primvars.items()},
            "triangle_materials": w.add(self._face_materials(prim, geometry.triangle_face, materials), "u32", 1),
            "double_sided": bool(UsdGeom.Gprim(prim).GetDoubleSidedAttr().Get(self._time)),
            "subdivision": cage,
        }


class Prototypes:
    """Cirrus prototypes: parts (mesh or volume + transform) in the prototype's space."""

    def __init__(self, meshes: MeshTable, volumes, round_shapes: dict | None = None) -> None:
        self.records: list[dict] = []
        self.boxes: list[tuple[np.ndarray, np.ndarray]] = []
        self.meshes, self._volumes = meshes, volumes
        # Prim type -> (table, manifest list and key): Points, BasisCurves, NurbsCurves.
        self._round = round_shapes or {}

    def add(self, path: str, parts: list[tuple[Usd.Prim, np.ndarray]], root: Usd.Prim,
            root_included: bool) -> int | None:
        """A prototype from (prim, prototype-from-part matrix) parts under `root` (whose own kind
        counts when `root_included`); None when all were skipped. Mesh, points and curves parts
        carry their names below the root and the asset they belong to inside the prototype."""
        record = {"path": path, "meshes": [], "volumes": [], "points": [], "curves": []}
        lo, hi = EMPTY_BOX
        for prim, matrix in parts:
            kind = prim.GetTypeName()
            table, (field, key) = {"Volume": (self._volumes, ("volumes", "volume"))}.get(
                kind, self._round.get(kind, (self.meshes, ("meshes", "mesh"))))
            index = table.index(prim)
            if index is None:
                continue
            part = {key: index, "transform": to_3x4_list(matrix)}
            if field != "volumes":
                part.update(name=below(prim, root), asset=asset_within(prim, root, root_included))
            record[field].append(part)
            box = table.boxes[index]
            if box is not None:
                corners = transform_points(box_corners(*box), matrix)
                lo, hi = np.minimum(lo, corners.min(axis=0)), np.maximum(hi, corners.max(axis=0))
        if not any(record[field] for field in ("meshes", "volumes", "points", "curves")):
            return None
        self.records.append(record)
        self.boxes.append((lo, hi))
        return len(self.records) - 1
