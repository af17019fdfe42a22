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
"""

from dataclasses import dataclass

import numpy as np
from pxr import Usd, UsdGeom

from .binfile import BinWriter
from .prototypes import PREDICATE, Prototypes, asset_above, asset_within, below, prototype_path
from .report import Report
from .skinning import Skinning
from .xforms import compose, local_transform, to_3x4

PART_TYPES = {"Mesh", "Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Volume", "Points", "BasisCurves",
              "NurbsCurves"}
SKIPPED_PURPOSES = {UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy}
# Renderable prim types Cirrus does not render yet: each is warned about by name.
UNRENDERED_TYPES = {"HermiteCurves", "NurbsPatch", "TetMesh"}


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
    (None: no model between them).
    """

    prototype: int
    matrices: np.ndarray  # (n, 4, 4) float64
    index: np.ndarray  # (n,) int64
    root: Name = Name()
    asset: Name | None = None

    def placed(self, matrix: np.ndarray) -> "Leaf":
        """The same copies moved by one more (4, 4) transform."""
        return Leaf(self.prototype, self.matrices @ matrix, self.index, self.root, self.asset)

    def named_under(self, path: str, asset: str | None) -> "Leaf":
        """The same copies named under `path`, with `asset` (a path) as their asset when they
        have none nearer."""
        nearer = self.asset.under(path) if self.asset else None
        fallback = Name(asset) if asset is not None else None
        return Leaf(self.prototype, self.matrices, self.index, self.root.under(path), nearer or fallback)


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
            self.nested(prim, [Leaf(proto, np.eye(4)[None], np.zeros(1, np.int64))], matrix)

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


class Walker:
    """Depth-first traversal honouring visibility and purpose at one time code."""

    def __init__(self, prototypes: Prototypes, skinning: Skinning, report: Report, time: Usd.TimeCode) -> None:
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
        return sink

    def _renderable(self, prim: Usd.Prim) -> bool:
        """False for invisible prims and guide/proxy purpose (render and default are kept)."""
        imageable = UsdGeom.Imageable(prim)
        if not imageable:
            return True
        if imageable.GetVisibilityAttr().Get(self._time) == UsdGeom.Tokens.invisible:
            return False
        return imageable.GetPurposeAttr().Get() not in SKIPPED_PURPOSES

    def _walk(self, prim: Usd.Prim, parent: np.ndarray, sink: GroupSink | TopSink,
              apply_local: bool = True) -> None:
        """Visits `prim` with `parent` = holder-from-parent, then its children.

        A prim that resets the xform stack is placed relative to the holder (the world at
        the top level, the prototype root inside a prototype).
        """
        if not self._renderable(prim):
            return
        matrix = parent
        if apply_local:
            local, resets = local_transform(prim, self._time)
            matrix = local if resets else local @ parent
        if prim.IsInstance():
            sink.nested(prim, self._native_leaves(prim), matrix)
            return
        if prim.IsA(UsdGeom.PointInstancer):
            sink.nested(prim, self._point_instancer_leaves(prim), matrix)
            return
        if prim.GetTypeName() in PART_TYPES:
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
                leaves.insert(0, Leaf(proto, np.eye(4)[None], np.zeros(1, np.int64)))
            self._groups[key] = leaves
        return self._groups[key]

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
        transform out.
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
        proto_indices, ids = proto_indices[mask], ids[mask]
        stage = prim.GetStage()
        leaves = []
        for j, target in enumerate(targets):
            chosen = proto_indices == j
            if not chosen.any():
                continue
            root = stage.GetPrimAtPath(target)
            key = (prototype_path(root), self._skinning.signature(root))
            for leaf in self._group(key, str(target), root, [root], False):
                inner = compose(leaf.matrices, matrices[chosen])
                leaves.append(Leaf(leaf.prototype, inner, np.repeat(ids[chosen], len(leaf.index)),
                                   leaf.root.instanced(leaf.index),
                                   leaf.asset.instanced(leaf.index) if leaf.asset else None))
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
    return record, arrays["prototype"], arrays["matrices"]
