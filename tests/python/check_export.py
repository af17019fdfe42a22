#!/usr/bin/env python3
"""Independent check of an exported Cirrus scene against usd-core's own answers.

Usage: check_export.py IN.usd OUT_DIR

Recomputes, without the exporter's code, every placed copy of every mesh/gprim/volume
(UsdGeom.XformCache through instance proxies, PointInstancer.ComputeInstanceTransformsAtTime
for instancers, nested ones included) and compares with scene.json/scene.bin read back with
numpy: copy counts per instance source; world transforms within 1e-5 relative to their
scale; for up to 64 copies per (source, part): object-space points against usd-core's
computed extent (1e-4 relative), world points inside UsdGeom.BBoxCache's world box and the
manifest bounds, materials against UsdShade's binding resolution. Also checks every array
reference and index. Prints one summary line; exits 1 on any mismatch.
"""

import json
import re
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from pxr import Usd, UsdGeom, UsdShade

PREDICATE = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
PART_TYPES = {"Mesh", "Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Plane", "Volume"}
NO_MATERIAL = 0xFFFFFFFF
MATRIX_TOL = 1e-5
BOUNDS_TOL = 1e-4


class Scene:
    """scene.json plus typed views of scene.bin, every array reference validated."""

    def __init__(self, out_dir: Path, errors: list[str]) -> None:
        self.manifest = json.loads((out_dir / "scene.json").read_text())
        self.blob = (out_dir / "scene.bin").read_bytes()
        self.errors = errors

    def array(self, ref: dict | None, what: str) -> np.ndarray | None:
        """The referenced array as (count, width), or None for a null reference."""
        if ref is None:
            return None
        dtype = {"f32": "<f4", "u32": "<u4"}[ref["type"]]
        size = ref["count"] * ref["width"] * 4
        if ref["offset"] % 16 or ref["offset"] + size > len(self.blob):
            self.errors.append(f"{what}: bad array reference {ref} for {len(self.blob)}-byte scene.bin")
            return np.zeros((0, ref["width"]))
        values = np.frombuffer(self.blob, dtype, ref["count"] * ref["width"], ref["offset"])
        return values.reshape(ref["count"], ref["width"])


def row_vector(m34: np.ndarray) -> np.ndarray:
    """Cirrus (..., 12) column-vector 3x4 rows as USD row-vector (..., 4, 4) float64."""
    m = np.zeros(m34.shape[:-1] + (4, 4))
    m[..., :, :3] = np.swapaxes(m34.reshape(m34.shape[:-1] + (3, 4)), -1, -2)
    m[..., 3, 3] = 1.0
    return m


def gf(matrix) -> np.ndarray:
    """A Gf.Matrix4d as a (4, 4) array."""
    return np.array(matrix, dtype=np.float64).reshape(4, 4)


class Expected:
    """Every placed copy the stage should produce: (source, prim name) -> [(prim, worlds (n, 4, 4))]."""

    def __init__(self, stage: Usd.Stage, time: Usd.TimeCode) -> None:
        self.time = time
        self.cache = UsdGeom.XformCache(time)
        self.copies: dict[tuple[str, str], list[tuple[Usd.Prim, np.ndarray]]] = defaultdict(list)
        self._scan(stage.GetPseudoRoot(), None)

    def _hidden(self, prim: Usd.Prim) -> bool:
        """Invisible (with everything below it): not rendered."""
        img = UsdGeom.Imageable(prim)
        return bool(img) and img.GetVisibilityAttr().Get(self.time) == UsdGeom.Tokens.invisible

    @staticmethod
    def _part(prim: Usd.Prim) -> bool:
        """A gprim rendered by default: its computed purpose is default or render."""
        return prim.GetTypeName() in PART_TYPES and \
            UsdGeom.Imageable(prim).ComputePurpose() in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render)

    def _scan(self, root: Usd.Prim, source: str | None) -> None:
        """Copies under a stage prim at their XformCache world transforms."""
        it = iter(Usd.PrimRange(root, PREDICATE))
        for prim in it:
            if prim == root and root.IsPseudoRoot():
                continue
            if self._hidden(prim):
                it.PruneChildren()
                continue
            here = source or (str(prim.GetPath()) if prim.IsInstance() else None)
            if prim.IsA(UsdGeom.PointInstancer):
                it.PruneChildren()
                world = gf(self.cache.GetLocalToWorldTransform(prim))
                self._instancer(prim, world[None], here or str(prim.GetPath()))
            elif prim.IsInstance():
                it.PruneChildren()
                self._scan_instance(prim, here)
            elif self._part(prim):
                world = gf(self.cache.GetLocalToWorldTransform(prim))
                self.copies[(here or str(prim.GetPath()), prim.GetName())].append((prim, world[None]))

    def _scan_instance(self, prim: Usd.Prim, source: str) -> None:
        """A native instance's proxies (their XformCache transforms are world already)."""
        for child in prim.GetFilteredChildren(PREDICATE):
            self._scan(child, source)

    def _instancer(self, prim: Usd.Prim, worlds: np.ndarray, source: str) -> None:
        """A PointInstancer placed at each of `worlds` (k, 4, 4): its prototypes' copies."""
        pi = UsdGeom.PointInstancer(prim)
        xforms = np.array(pi.ComputeInstanceTransformsAtTime(self.time, self.time)).reshape(-1, 4, 4)
        indices = np.array(pi.GetProtoIndicesAttr().Get(self.time) or [], dtype=np.int64)
        mask = pi.ComputeMaskAtTime(self.time)
        if mask:
            indices = indices[np.array(mask, dtype=bool)]
        stage = prim.GetStage()
        for j, target in enumerate(pi.GetPrototypesRel().GetForwardedTargets()):
            chosen = xforms[indices == j]
            if len(chosen) == 0:
                continue
            placed = np.einsum("aij,bjk->baik", chosen, worlds).reshape(-1, 4, 4)
            self._prototype(stage.GetPrimAtPath(target), placed, source)

    def _prototype(self, root: Usd.Prim, placed: np.ndarray, source: str) -> None:
        """Copies under a PointInstancer prototype root placed at `placed` (root xform included)."""
        it = iter(Usd.PrimRange(root, PREDICATE))
        for prim in it:
            if self._hidden(prim):
                it.PruneChildren()
                continue
            rel = np.eye(4) if prim == root else gf(self.cache.ComputeRelativeTransform(prim, root)[0])
            if prim.IsA(UsdGeom.PointInstancer):
                it.PruneChildren()
                self._instancer(prim, rel @ placed, source)
            elif self._part(prim):
                self.copies[(source, prim.GetName())].append((prim, rel @ placed))


def exported_copies(scene: Scene) -> dict[tuple[str, str], list[tuple[int, np.ndarray]]]:
    """Every exported (source, part name) -> [(mesh index or -1 for a volume, worlds (n, 4, 4))]."""
    m = scene.manifest
    inst = m["instances"]
    protos = scene.array(inst["prototype"], "instances.prototype")[:, 0].astype(np.int64)
    worlds = row_vector(scene.array(inst["transform"], "instances.transform").astype(np.float64))
    sources = scene.array(inst["source"], "instances.source")[:, 0].astype(np.int64)
    if (protos >= len(m["prototypes"])).any() or (sources >= len(inst["instance_sources"])).any():
        scene.errors.append("instances: prototype or source index out of range")
        return {}
    copies = defaultdict(list)
    pairs, which = np.unique(np.stack([protos, sources], axis=1), axis=0, return_inverse=True)
    for group, (p, s) in enumerate(pairs):
        chosen = worlds[which.reshape(-1) == group]
        proto = m["prototypes"][p]
        for kind, table in (("mesh", "meshes"), ("volume", "volumes")):
            for part in proto[table]:
                name = m[table][part[kind]]["path"].rsplit("/", 1)[-1]
                local = row_vector(np.array(part["transform"], dtype=np.float64))
                mesh = part[kind] if kind == "mesh" else -1
                copies[(inst["instance_sources"][s], name)].append((mesh, local @ chosen))
    return copies


def sort_key(matrices: np.ndarray, scale: float) -> np.ndarray:
    """A stable order of matrices: lexicographic on coarsely rounded entries."""
    rounded = np.round(matrices.reshape(len(matrices), 16) / (scale * 1e-3))
    return np.lexsort(rounded.T[::-1])


def check_mesh_arrays(scene: Scene) -> list[np.ndarray]:
    """Validates each mesh's arrays and indices; returns its points."""
    points_of = []
    n_mat = len(scene.manifest["materials"])
    for i, mesh in enumerate(scene.manifest["meshes"]):
        pts = scene.array(mesh["points"], f"meshes[{i}].points")
        tris = scene.array(mesh["triangles"], f"meshes[{i}].triangles")
        mats = scene.array(mesh["triangle_materials"], f"meshes[{i}].triangle_materials")
        if tris.size and tris.max() >= len(pts):
            scene.errors.append(f"meshes[{i}].triangles: index {tris.max()} >= {len(pts)} points")
        if len(mats) != len(tris) or ((mats >= n_mat) & (mats != NO_MATERIAL)).any():
            scene.errors.append(f"meshes[{i}].triangle_materials: wrong length or index")
        for name, width in (("normals", 3), ("uvs", 2)):
            arr = scene.array(mesh[name], f"meshes[{i}].{name}")
            if arr is not None and arr.shape != (len(pts), width):
                scene.errors.append(f"meshes[{i}].{name}: {arr.shape} for {len(pts)} points")
        if not np.isfinite(pts).all():
            scene.errors.append(f"meshes[{i}].points: not finite")
        points_of.append(pts.astype(np.float64))
    return points_of


def check_bounds(scene: Scene, bbox: UsdGeom.BBoxCache, prim: Usd.Prim, points: np.ndarray,
                 mine: np.ndarray, theirs: np.ndarray, label: str) -> None:
    """Exported points vs the prim's extent computed by usd-core (authored extents can be
    stale, as in cubeShaded.usda), and the world copy inside BBoxCache's world box."""
    extent = UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(prim), bbox.GetTime())
    lo, hi = np.array(extent[0]), np.array(extent[1])
    tol = BOUNDS_TOL * max(float(np.abs(np.concatenate([lo, hi])).max()), 1e-12)
    if np.abs(points.min(axis=0) - lo).max() > tol or np.abs(points.max(axis=0) - hi).max() > tol:
        scene.errors.append(f"{label}: object-space points {points.min(axis=0)}..{points.max(axis=0)} "
                            f"!= usd-core extent {lo}..{hi}")
        return
    box = bbox.ComputeUntransformedBound(prim).ComputeAlignedRange()
    lo, hi = np.minimum(lo, box.GetMin()), np.maximum(hi, box.GetMax())
    world_pts = points @ mine[:3, :3] + mine[3, :3]
    corners = np.array([[(hi if i >> k & 1 else lo)[k] for k in range(3)] for i in range(8)])
    world_box = corners @ theirs[:3, :3] + theirs[3, :3]
    wtol = BOUNDS_TOL * max(float(np.abs(world_box).max()), 1e-12)
    if (world_pts.min(axis=0) < world_box.min(axis=0) - wtol).any() or \
            (world_pts.max(axis=0) > world_box.max(axis=0) + wtol).any():
        scene.errors.append(f"{label}: world points leave BBoxCache's world box")
    bounds = scene.manifest["bounds"]
    if (world_pts.min(axis=0) < np.array(bounds["min"]) - wtol).any() or \
            (world_pts.max(axis=0) > np.array(bounds["max"]) + wtol).any():
        scene.errors.append(f"{label}: world points leave the manifest's bounds")


def without_prototype(path: str | None) -> str | None:
    """A path with its /__Prototype_N root cut off: prototype numbering differs between stages."""
    return re.sub(r"^/__Prototype_\d+", "<prototype>", path) if path else None


def material_path(prim: Usd.Prim) -> str | None:
    """usd-core's bound material for final renders (purpose full, falling back to
    allPurpose) as a prototype-relative path; the binding's target when it does not compose
    into a Material; None when unbound."""
    material, relationship = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(UsdShade.Tokens.full)
    if material:
        m = material.GetPrim()
        return without_prototype(str(m.GetPrimInPrototype().GetPath() if m.IsInstanceProxy() else m.GetPath()))
    return str(relationship.GetTargets()[0]) if relationship else None


def check_materials(scene: Scene, prim: Usd.Prim, mesh: int, label: str) -> None:
    """The exported per-triangle materials are the prim's binding and its GeomSubsets' bindings
    (the displayColor look standing for no binding)."""
    subsets = UsdGeom.Subset.GetGeomSubsets(UsdGeom.Imageable(prim), UsdGeom.Tokens.face,
                                            UsdShade.Tokens.materialBind)
    allowed = {material_path(p) for p in [prim, *(s.GetPrim() for s in subsets)]}
    records = scene.manifest["materials"]
    ref = scene.manifest["meshes"][mesh]["triangle_materials"]
    # A mesh without a material is shaded by its displayColor (a record the exporter makes, as
    # Hydra does): usd-core binds nothing there.
    used = {None if i == NO_MATERIAL or records[i].get("shader") == "displayColor"
            else without_prototype(records[i]["path"])
            for i in np.unique(scene.array(ref, "triangle_materials"))}
    if not used <= allowed or (not subsets and used != allowed):
        scene.errors.append(f"{label}: materials {sorted(map(str, used))}, usd-core binds {sorted(map(str, allowed))}")


def skipped_names(scene: Scene) -> set[str]:
    """Prim names the exporter warned it skipped (bad meshes, volumes with missing files)."""
    names = set()
    for warning in scene.manifest["warnings"]:
        if "skipped" in warning:
            for word in warning.split():
                if word.startswith("/"):
                    names.add(word.rstrip(":,;").rsplit("/", 1)[-1])
    return names


def stacked(chunks: list[tuple[object, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """All matrices of a list of (payload, (n, 4, 4)) chunks, and each row's chunk index."""
    matrices = np.concatenate([m for _, m in chunks])
    return matrices, np.repeat(np.arange(len(chunks)), [len(m) for _, m in chunks])


def compare(scene: Scene, expected: Expected) -> int:
    """Compares copies per (source, name); returns how many copies matched."""
    got = exported_copies(scene)
    points_of = check_mesh_arrays(scene)
    bbox = UsdGeom.BBoxCache(expected.time, [UsdGeom.Tokens.default_, UsdGeom.Tokens.render])
    skipped = skipped_names(scene)
    matched = 0
    for key in sorted(set(got) | set(expected.copies)):
        want, have = expected.copies.get(key, []), got.get(key, [])
        n_want, n_have = sum(len(m) for _, m in want), sum(len(m) for _, m in have)
        if not n_have and key[1] in skipped:
            continue
        if n_want != n_have:
            scene.errors.append(f"source {key[0]} part {key[1]}: {n_have} copies exported, usd-core says {n_want}")
            continue
        a, a_chunk = stacked(want)
        b, b_chunk = stacked(have)
        scale = max(1.0, float(np.abs(a).max()))
        a_order, b_order = sort_key(a, scale), sort_key(b, scale)
        diff = np.abs(a[a_order] - b[b_order]).max()
        if diff > MATRIX_TOL * scale:
            scene.errors.append(f"source {key[0]} part {key[1]}: transforms differ by {diff:.3g} (scale {scale:.3g})")
            continue
        matched += n_want
        for ia, ib in list(zip(a_order, b_order))[:64]:
            prim, mesh = want[a_chunk[ia]][0], have[b_chunk[ib]][0]
            if mesh >= 0:
                label = f"source {key[0]} mesh {prim.GetPath()}"
                check_bounds(scene, bbox, prim, points_of[mesh], b[ib], a[ia], label)
                check_materials(scene, prim, mesh, label)
    return matched


def main(argv: list[str]) -> int:
    """Runs every check and prints one summary line."""
    if len(argv) != 2:
        print("usage: check_export.py IN.usd OUT_DIR", file=sys.stderr)
        return 2
    errors: list[str] = []
    scene = Scene(Path(argv[1]), errors)
    stage = Usd.Stage.Open(argv[0], Usd.Stage.LoadAll)
    code = scene.manifest["source"]["time_code"]
    time = Usd.TimeCode.Default() if code is None else Usd.TimeCode(code)
    expected = Expected(stage, time)
    matched = compare(scene, expected)
    for error in errors[:20]:
        print(f"mismatch: {error}", file=sys.stderr)
    sources = len(scene.manifest["instances"]["instance_sources"])
    status = "FAILED" if errors else "OK"
    print(f"check_export {status}: {argv[0]}: {sources} sources, {matched} copies matched, "
          f"{len(scene.manifest['meshes'])} meshes, {len(errors)} mismatches")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
