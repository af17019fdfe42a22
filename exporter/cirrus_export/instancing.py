"""Walks the composed stage and flattens every kind of instancing to one level.

Native instances (prim.IsInstance() -> prim.GetPrototype()) and PointInstancer
prototypes are exported once each as a Cirrus prototype; nested instancing is
resolved by composing transform arrays (numpy, never a Python loop per instance), so
every Cirrus instance is world-from-prototype for a prototype holding real parts.

Every copy is named as the artist authored it (docs/conventions.md, "Cryptomatte names"):
its prototype root by the instance's own prim path (`/World/teapot_3`) or its
PointInstancer's path with its index (`/World/scatter[12]`), never `/__Prototype_N`, and its
asset by the nearest `component`/`assembly` model above it.

Meshes posed by UsdSkel are placed by their skeleton (`Skinning.placed`); copies of a
prototype share a group only when their skinning signatures agree (same skeleton and
SkelAnimation), so differently animated instances get their own posed meshes.

Primvars per copy (docs/materials.md, "Primvars"): a PointInstancer's `vertex`/`varying`
primvar (one value per instance) gives each of its copies its value, a `constant`/`uniform`
one gives all of them the same, and a constant primvar on a native instance root or an
ancestor above it gives the copies below. Only the primvars the copies' materials (or
primvar RenderVars) read and their meshes lack are carried; the nearest holder wins, as
USD's primvar inheritance lets the nearest ancestor's win.
"""

from dataclasses import dataclass, field, replace

import numpy as np
from pxr import Usd, UsdGeom

from .binfile import BinWriter
from .prims import PREDICATE, asset_above, asset_within, below, inherited_primvar, numeric, prototype_path
from .prototypes import Prototypes
from .report import Report
from .skinning import Skinning
from .xforms import compose, local_transform, to_3x4

# Parts stored as meshes (whose materials' primvars instances may carry).
MESH_TYPES = {"Mesh", "Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Cylinder_1", "Capsule_1", "Plane"}
PART_TYPES = MESH_TYPES | {"Volume", "Points", "BasisCurves", "NurbsCurves"}
# Renderable prim types Cirrus does not render yet: each is warned about by name.
UNRENDERED_TYPES = {"HermiteCurves", "NurbsPatch", "TetMesh"}
# PointInstancer primvar interpolations: one value per instance, or one for all of them.
PER_INSTANCE = {UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying}
ALL_INSTANCES = {UsdGeom.Tokens.constant, UsdGeom.Tokens.uniform}


@dataclass(frozen=True)
class Name:
    """A prim path that may hold a copy's PointInstancer indices: `head`, then `[index]` when
    `indexed`, then `tail`, then for a PointInstancer nested in another's prototype
    `[inner[k % len(inner)]]` and `inner_tail`, k being the copy's position in its run (the
    manifest's NamePattern). `inner` is stored once per run, never per copy."""

    head: str = ""
    indexed: bool = False
    tail: str = ""
    inner: tuple[int, ...] | None = None
    inner_tail: str = ""

    def under(self, path: str) -> "Name":
        """This name, relative to a prim, under that prim's `path` (relative or absolute)."""
        return Name(path + self.head, self.indexed, self.tail, self.inner, self.inner_tail)

    def instanced(self, index: np.ndarray) -> "Name":
        """This name, relative to a PointInstancer prototype root, of the copies whose indices
        in that prototype are `index`, for the instancer's copies (outer-major): `[index]`
        then the name, whose own index becomes the inner one. Deeper nesting keeps the two
        outermost indices (the innermost instancer's path is kept, its index dropped)."""
        if not self.indexed:
            return Name("", True, self.head + self.tail)
        if self.inner is None:
            return Name("", True, self.head, tuple(int(i) for i in index), self.tail)
        return Name("", True, self.head, tuple(int(i) for i in index), self.tail + self.inner_tail)

    def record(self) -> dict:
        record = {"head": self.head, "indexed": self.indexed, "tail": self.tail}
        if self.inner is not None:
            record["inner"] = {"indices": list(self.inner), "tail": self.inner_tail}
        return record


@dataclass
class Leaf:
    """Copies of one Cirrus prototype: row-vector matrices into the holder's space.

    `index` is each copy's index in the outermost PointInstancer that made it (its
    `ids` when authored), 0 when no PointInstancer is involved; a nested one's index is in
    `root.inner`. `root` names the copies'
    prototype root and `asset` the nearest model above it, both relative to the holder
    (None: no model between them). `reads` are the primvars the prototype's materials (and
    primvar RenderVars) read, `lacking` (primvar, mesh prim, warning) those its meshes lack, and
    `primvars` each copy's values found so far, name -> (n, width).
    """

    prototype: int
    matrices: np.ndarray  # (n, 4, 4) float64
    index: np.ndarray  # (n,) int64
    root: Name = Name()
    asset: Name | None = None
    reads: frozenset[str] = frozenset()
    lacking: tuple[tuple[str, str, str], ...] = ()
    primvars: dict[str, np.ndarray] = field(default_factory=dict)

    def placed(self, matrix: np.ndarray) -> "Leaf":
        """The same copies moved by one more (4, 4) transform."""
        return replace(self, matrices=self.matrices @ matrix)

    def named_under(self, path: str, asset: str | None) -> "Leaf":
        """The same copies named under `path`, with `asset` (a path) as their asset when they
        have none nearer."""
        nearer = self.asset.under(path) if self.asset else None
        fallback = Name(asset) if asset is not None else None
        return replace(self, root=self.root.under(path), asset=nearer or fallback)

    def unset(self) -> list[str]:
        """The primvars read that no holder has given the copies yet, sorted."""
        return sorted(self.reads - self.primvars.keys())

    def with_primvars(self, values: dict[str, np.ndarray]) -> "Leaf":
        """The same copies with more per-copy values (those already set win)."""
        return replace(self, primvars={**values, **self.primvars}) if values else self


class GroupSink:
    """Collects the parts and nested instances found under one prototype root.

    `holder` is the prim whose space the group is in: the native instance, or the
    PointInstancer prototype root; `holder_shared` when the holder itself belongs to the
    group (a PointInstancer prototype root, unlike a native instance, which is each copy's own).
    """

    def __init__(self, holder: Usd.Prim, holder_shared: bool) -> None:
        self.holder: Usd.Prim | None = holder
        self.holder_shared = holder_shared
        self.parts: list[tuple[Usd.Prim, np.ndarray]] = []
        self.leaves: list[Leaf] = []

    def part(self, prim: Usd.Prim, matrix: np.ndarray) -> None:
        """A mesh or volume directly in the group."""
        self.parts.append((prim, matrix))

    def nested(self, prim: Usd.Prim, leaves: list[Leaf], matrix: np.ndarray) -> None:
        """An instance or PointInstancer inside the group, placed by `matrix`."""
        path = below(prim, self.holder)
        asset = asset_within(prim, self.holder, self.holder_shared)
        self.leaves.extend(leaf.placed(matrix).named_under(path, asset) for leaf in leaves)


class TopSink:
    """Collects world-space instances, each tagged with the stage prim that produced it."""

    def __init__(self, prototypes: Prototypes) -> None:
        self.holder: Usd.Prim | None = None  # the world
        self.sources: list[str] = []
        self.placed: list[tuple[int, Leaf]] = []  # names absolute
        self._prototypes = prototypes

    def part(self, prim: Usd.Prim, matrix: np.ndarray) -> None:
        """A plain prim: its own prototype, one instance at its world transform."""
        proto = self._prototypes.add(str(prim.GetPath()), [(prim, np.eye(4))], prim, False)
        if proto is not None:
            self.nested(prim, [group_leaf(self._prototypes, proto, [prim])], matrix)

    def nested(self, prim: Usd.Prim, leaves: list[Leaf], matrix: np.ndarray) -> None:
        """All copies made by one native instance or PointInstancer of the stage."""
        if not leaves:
            return
        path = str(prim.GetPath())
        self.sources.append(path)
        asset = asset_above(prim)
        self.placed.extend((len(self.sources) - 1, leaf.placed(matrix).named_under(path, asset))
                           for leaf in leaves)

    def arrays(self) -> dict[str, np.ndarray]:
        """The Instances structure of arrays: prototype, transform (n, 12), source, source_index."""
        leaves = [leaf for _, leaf in self.placed]
        counts = [len(leaf.index) for leaf in leaves]
        return {
            "prototype": np.repeat([leaf.prototype for leaf in leaves], counts).astype(np.uint32),
            "matrices": np.concatenate([leaf.matrices for leaf in leaves]) if leaves else np.zeros((0, 4, 4)),
            "source": np.repeat([source for source, _ in self.placed], counts).astype(np.uint32),
            "source_index": np.concatenate([leaf.index for leaf in leaves]) if leaves else np.zeros(0),
        }

    def names(self) -> list[dict]:
        """The Instances `names` runs: one per placed leaf, in instance order."""
        return [{"count": len(leaf.index), "root": leaf.root.record(),
                 "asset": leaf.asset.record() if leaf.asset else None} for _, leaf in self.placed]

    def primvars(self, writer: BinWriter) -> dict[str, list[dict]]:
        """The Instances `primvars` runs: per name, one per placed leaf that carries it."""
        runs: dict[str, list[dict]] = {}
        first = 0
        for _, leaf in self.placed:
            for name, values in sorted(leaf.primvars.items()):
                runs.setdefault(name, []).append(
                    {"first": first, "values": writer.add(values, "f32", values.shape[1])})
            first += len(leaf.index)
        return runs

    def warn_lacking(self, report: Report) -> None:
        """One warning per mesh and primvar its material reads that some copies get from
        neither the mesh nor an instance (naming those copies when the mesh's path, that of
        the first copy met, does not): they read the reader's fallback."""
        for _, leaf in self.placed:
            for name, path, warning in leaf.lacking:
                if name not in leaf.primvars:
                    copies = leaf.root.head + ("[i]" if leaf.root.indexed else "")
                    report.warn(warning if path.startswith(leaf.root.head) else f"{warning} in copies {copies}")


def group_leaf(prototypes, proto: int, prims: list[Usd.Prim]) -> Leaf:
    """The one copy of prototype `proto` made of the parts `prims`, with what their meshes'
    materials read and lack."""
    meshes = [prim for prim in prims if prim.GetTypeName() in MESH_TYPES]
    return Leaf(proto, np.eye(4)[None], np.zeros(1, np.int64), reads=prototypes.meshes.reads(meshes),
                lacking=prototypes.meshes.lacking(meshes))


def constant_primvars(prim: Usd.Prim, names: list[str], time: Usd.TimeCode) -> dict[str, np.ndarray]:
    """The (1, width) values of the constant primvars `names` that `prim` or an ancestor up to
    the nearest instance or PointInstancer holds (the nearest wins)."""
    found = {name: inherited_primvar(prim, name, time) for name in names}
    return {name: value for name, value in found.items() if value is not None}


def deactivated(stage: Usd.Stage, path) -> bool:
    """Whether the prim at `path` or an ancestor is inactive (an inactive prim's descendants
    are not on the composed stage at all)."""
    return any(not prim.IsActive() for prim in map(stage.GetPrimAtPath, path.GetPrefixes()) if prim)


class Walker:
    """Depth-first traversal honouring visibility and purpose at one time code: `purposes`
    are the render settings' includedPurposes (render_settings.included_purposes)."""

    def __init__(self, prototypes: Prototypes, skinning: Skinning, report: Report, time: Usd.TimeCode,
                 purposes: frozenset[str]) -> None:
        self._purposes = purposes
        self._prototypes = prototypes
        self._skinning = skinning
        self._report = report
        self._time = time
        self._groups: dict[tuple, list[Leaf]] = {}

    def walk_stage(self, stage: Usd.Stage) -> TopSink:
        """Every renderable prim of the stage, as world-space instances."""
        sink = TopSink(self._prototypes)
        for child in stage.GetPseudoRoot().GetFilteredChildren(PREDICATE):
            self._walk(child, np.eye(4), sink)
        sink.warn_lacking(self._report)
        return sink

    def _invisible(self, prim: Usd.Prim) -> bool:
        """Whether `prim` is invisible at the time: it and everything below it go unrendered."""
        imageable = UsdGeom.Imageable(prim)
        return bool(imageable) and imageable.GetVisibilityAttr().Get(self._time) == UsdGeom.Tokens.invisible

    def _included(self, prim: Usd.Prim) -> bool:
        """Whether the gprim's computed purpose (its own authored one, else its nearest
        ancestor's: UsdGeomImageable.ComputePurpose) is among the included purposes."""
        return UsdGeom.Imageable(prim).ComputePurpose() in self._purposes

    def _walk(self, prim: Usd.Prim, parent: np.ndarray, sink: GroupSink | TopSink,
              apply_local: bool = True) -> None:
        """Visits `prim` with `parent` = holder-from-parent, then its children.

        A prim that resets the xform stack is placed relative to the holder (the world at
        the top level, the prototype root inside a prototype).
        """
        if self._invisible(prim):
            return
        matrix = parent
        if apply_local:
            local, resets = local_transform(prim, self._time)
            matrix = local if resets else local @ parent
        if prim.IsInstance():
            sink.nested(prim, self._inheriting(prim, self._native_leaves(prim)), matrix)
            return
        if prim.IsA(UsdGeom.PointInstancer):
            sink.nested(prim, self._inheriting(prim, self._point_instancer_leaves(prim)), matrix)
            return
        if prim.GetTypeName() in PART_TYPES:
            if self._included(prim):
                sink.part(prim, self._skinning.placed(prim, sink.holder, matrix))
        elif prim.GetTypeName() in UNRENDERED_TYPES:
            self._report.not_rendered(prim.GetTypeName(), f"{prim.GetTypeName()} {prim.GetPath()} is not rendered: "
                                      f"{prim.GetTypeName()} prims are not supported yet")
        for child in prim.GetFilteredChildren(PREDICATE):
            self._walk(child, matrix, sink)

    def _group(self, key: tuple, name: str, holder: Usd.Prim, roots: list[Usd.Prim],
               apply_local: bool) -> list[Leaf]:
        """Copies of everything under `roots`, in `holder`'s space; built once per key."""
        if key not in self._groups:
            # A native instance's group leaves its own xform out (apply_local) and its own
            # kind too (each copy's, named above); a PointInstancer prototype root is shared.
            sink = GroupSink(holder, holder_shared=not apply_local)
            for root in roots:
                self._walk(root, np.eye(4), sink, apply_local)
            leaves = list(sink.leaves)
            proto = self._prototypes.add(name, sink.parts, holder, not apply_local) if sink.parts else None
            if proto is not None:
                leaves.insert(0, group_leaf(self._prototypes, proto, [prim for prim, _ in sink.parts]))
            self._groups[key] = leaves
        return self._groups[key]

    def _inheriting(self, prim: Usd.Prim, leaves: list[Leaf]) -> list[Leaf]:
        """The copies made by the instance or PointInstancer `prim`, given the constant primvars
        they still lack from `prim` and its ancestors (up to the nearest holder)."""
        result = []
        for leaf in leaves:
            found = constant_primvars(prim, leaf.unset(), self._time)
            n = len(leaf.index)
            result.append(leaf.with_primvars({name: np.repeat(v, n, axis=0) for name, v in found.items()}))
        return result

    def _instancer_primvars(self, prim: Usd.Prim, names: set[str], count: int) -> dict[str, np.ndarray]:
        """A PointInstancer's primvars among `names`, (count, width) each: one value per instance
        (vertex, varying) or one for all (constant, uniform). A wrong length, another
        interpolation or a value no input can read is warned about and ignored."""
        found = {}
        for name in sorted(names):
            primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
            if not primvar or not primvar.HasValue():
                continue
            interpolation = primvar.GetInterpolation()
            values = numeric(primvar.ComputeFlattened(self._time))
            want = count if interpolation in PER_INSTANCE else 1
            if values is None or interpolation not in PER_INSTANCE | ALL_INSTANCES or len(values) != want:
                got = "no numeric values of width 1 to 4" if values is None else f"{len(values)} values"
                self._report.warn(f"PointInstancer {prim.GetPath()}: primvars:{name} ({interpolation}) has {got}, "
                                  f"expected {want} (one per instance for vertex or varying, one for constant "
                                  f"or uniform); ignored")
                continue
            found[name] = values if want == count else np.repeat(values, count, axis=0)
        return found

    def _native_leaves(self, prim: Usd.Prim) -> list[Leaf]:
        """A native instance's prototype, in the instance prim's space (its xform excluded).

        Instances share one group unless their material bindings or skinning differ.
        """
        key = (str(prim.GetPrototype().GetPath()), self._prototypes.meshes.signature(prim),
               self._skinning.signature(prim))
        return self._group(key, str(prim.GetPath()), prim, list(prim.GetFilteredChildren(PREDICATE)), True)

    def _point_instancer_leaves(self, prim: Usd.Prim) -> list[Leaf]:
        """Every instance of a PointInstancer, in the instancer's space.

        Instance transforms come from ComputeInstanceTransformsAtTime (prototype root
        xform included, mask applied), so each prototype group leaves its root's own
        transform out. Instances of an inactive prototype are not rendered (deactivating is
        authored intent, as for any prim); those of a target that is no prim are warned about.
        """
        instancer = UsdGeom.PointInstancer(prim)
        matrices = np.array(instancer.ComputeInstanceTransformsAtTime(self._time, self._time),
                            dtype=np.float64).reshape(-1, 4, 4)
        proto_indices = np.array(instancer.GetProtoIndicesAttr().Get(self._time) or [], dtype=np.int64)
        ids = np.array(instancer.GetIdsAttr().Get(self._time) or np.arange(proto_indices.size), dtype=np.int64)
        mask = np.array(instancer.ComputeMaskAtTime(self._time) or np.ones(proto_indices.size, bool), dtype=bool)
        targets = instancer.GetPrototypesRel().GetForwardedTargets()
        if mask.size != proto_indices.size or ids.size != proto_indices.size or \
                matrices.shape[0] != int(mask.sum()) or (proto_indices >= len(targets)).any():
            self._report.warn(f"PointInstancer {prim.GetPath()}: protoIndices, ids, mask and transforms "
                              f"disagree in length or index range; skipped")
            return []
        stage = prim.GetStage()
        groups = {}
        for j, target in enumerate(targets):
            root = stage.GetPrimAtPath(target)
            if not (proto_indices[mask] == j).any() or deactivated(stage, target):
                continue
            if not root.IsValid():
                self._report.warn(f"PointInstancer {prim.GetPath()}: prototypes target {target} is not a "
                                  f"prim; its instances are skipped")
                continue
            key = (prototype_path(root), self._skinning.signature(root))
            groups[j] = self._group(key, str(target), root, [root], False)
        wanted = {name for group in groups.values() for leaf in group for name in leaf.unset()}
        per_instance = {name: values[mask] for name, values in
                        self._instancer_primvars(prim, wanted, proto_indices.size).items()}
        proto_indices, ids = proto_indices[mask], ids[mask]
        leaves = []
        for j, group in groups.items():
            chosen = proto_indices == j
            for leaf in group:
                inner = compose(leaf.matrices, matrices[chosen])
                m = len(leaf.index)
                # Copies are outer-major (compose): the leaf's own values repeat per instance,
                # the instancer's repeat per copy within one instance.
                own = {name: np.tile(v, (int(chosen.sum()), 1)) for name, v in leaf.primvars.items()}
                given = {name: np.repeat(per_instance[name][chosen], m, axis=0)
                         for name in leaf.unset() if name in per_instance}
                leaves.append(replace(leaf, matrices=inner, index=np.repeat(ids[chosen], m),
                                      root=leaf.root.instanced(leaf.index),
                                      asset=leaf.asset.instanced(leaf.index) if leaf.asset else None,
                                      primvars={**given, **own}))
        return leaves


def instance_records(sink: TopSink, writer: BinWriter) -> tuple[dict, np.ndarray, np.ndarray]:
    """The manifest `instances` object, plus the prototype and world matrices per instance."""
    arrays = sink.arrays()
    record = {
        "count": int(arrays["prototype"].size),
        "prototype": writer.add(arrays["prototype"], "u32", 1),
        "transform": writer.add(to_3x4(arrays["matrices"]), "f32", 12),
        "source": writer.add(arrays["source"], "u32", 1),
        "source_index": writer.add(arrays["source_index"], "u32", 1),
        "instance_sources": sink.sources,
        "names": sink.names(),
    }
    primvars = sink.primvars(writer)
    if primvars:
        record["primvars"] = primvars
    return record, arrays["prototype"], arrays["matrices"]
