"""UsdSkel: meshes bound to a Skeleton under a SkelRoot, posed at the exported time code.

usd-core does the posing, as usdview does: `UsdSkel.Cache` resolves the bindings of each
SkelRoot (through instance proxies); blend shapes come first (`BlendShapeQuery` with the
SkelAnimation's `blendShapeWeights`), then the skeleton's skinning transforms at the time
code (`SkeletonQuery.ComputeSkinningTransforms`: the SkelAnimation, else the rest pose) are
applied with `geomBindTransform` by `SkinningQuery.ComputeSkinnedPoints` (linear blend or
dual quaternion, as `skel:skinningMethod` says), or as one transform for constant
influences (`ComputeSkinnedTransform`). Authored normals are skinned by `UsdSkel.SkinNormals`
with the inverse transposes of the same transforms, as UsdSkelImaging does.

The result is in skeleton space: UsdSkel ignores a skinned prim's own transform, so a posed
part is placed by its Skeleton's transform (times the rigid transform), not by the mesh's.

A binding usd-core complains about, or that fails a check below (joints, bindTransforms,
restTransforms, the animation's joints, the influence primvars), is one warning naming the
prim and attribute, and its meshes are exported as authored (bind pose): never half posed.
"""

import copy
from dataclasses import dataclass

import numpy as np
from pxr import Gf, Tf, Usd, UsdGeom, UsdSkel, Vt

from .meshes import Pose, read_normals
from .prims import PREDICATE, prototype_path
from .report import Report
from .xforms import as_array

RIGID = UsdGeom.Tokens.constant
# Normal interpolations that follow a deformation: one normal per point or per face corner.
SKINNED_NORMALS = ("vertex", "varying", "faceVarying")
# The kind `cirrus info` counts skins left in their bind pose under.
BIND_POSE = "bind-pose skins"


@dataclass
class _Binding:
    """A skinnable prim's checked binding: its Skeleton (the instance proxy inside an
    instance, whose space places the pose), the skeleton's query and its own."""

    skeleton: Usd.Prim
    skel: UsdSkel.SkeletonQuery
    query: UsdSkel.SkinningQuery


def _usd_text(error: Tf.ErrorException) -> str:
    """A Tf error's text on one line."""
    return " ".join(str(error).split())


class Skinning:
    """Poses of the skinned meshes of one export, resolved lazily per SkelRoot."""

    def __init__(self, report: Report, time: Usd.TimeCode) -> None:
        self._report, self._time = report, time
        self._cache = UsdSkel.Cache()
        self._xforms = UsdGeom.XformCache(time)
        self._roots: set[str] = set()
        self._bindings: dict[str, _Binding] = {}  # bindings that passed every check
        self._warned: set[tuple] = set()
        self._poses: dict[str, Pose | None] = {}
        self._has_skel_root: dict[str, bool] = {}

    def placed(self, prim: Usd.Prim, holder: Usd.Prim | None, matrix: np.ndarray) -> np.ndarray:
        """Holder-from-part for a part found at holder-from-prim `matrix`: the skeleton's
        placement for a posed mesh, `matrix` for everything else.

        `holder` is the prim whose space the walk is in (None: the world). A skinned mesh
        whose skeleton lies outside it (a native instance or PointInstancer prototype bound
        to a Skeleton outside the prototype) cannot be placed there: warned, bind pose.
        """
        pose = self.pose(prim)
        if pose is None:
            return matrix
        skeleton = pose.skeleton
        if holder is None:
            holder_from_skel = as_array(self._xforms.GetLocalToWorldTransform(skeleton))
        elif skeleton.GetPath().HasPrefix(holder.GetPath()):
            holder_from_skel = as_array(self._xforms.ComputeRelativeTransform(skeleton, holder)[0])
        else:
            self._report.approximated(BIND_POSE, f"{prim.GetPath()}: skel:skeleton {skeleton.GetPath()} lies outside "
                              f"{holder.GetPath()}, the instanced prototype holding the mesh: rendered in its "
                              "bind pose")
            self._poses[str(prim.GetPath())] = None
            return matrix
        return pose.skel_from_points @ holder_from_skel

    def placed_at(self, time: Usd.TimeCode) -> "Skinning":
        """These poses (still the frame's: motion keys pose them at other times), placed by
        the skeletons' transforms at `time`: the walks at the shutter's keys use it, so a
        SkelRoot or Skeleton moving by its transform moves its meshes."""
        moved = copy.copy(self)
        moved._xforms = UsdGeom.XformCache(time)
        return moved

    def pose(self, prim: Usd.Prim) -> Pose | None:
        """The prim posed by UsdSkel, or None when it is not skinned or cannot be (warned)."""
        path = str(prim.GetPath())
        if path not in self._poses:
            binding = self._binding(prim)
            self._poses[path] = None if binding is None else self._compute(prim, binding)
        return self._poses[path]

    def animation(self, prim: Usd.Prim) -> tuple[list[float], bool] | None:
        """For a posed mesh: every time sample of its SkelAnimation's joint transforms and
        blend shape weights (empty when it does not move), and whether UsdSkel deforms it
        rigidly (one transform, not posed per point); None when the prim is not posed."""
        if self.pose(prim) is None:
            return None
        binding = self._bindings[str(prim.GetPath())]
        anim = binding.skel.GetAnimQuery()
        times = set(anim.GetJointTransformTimeSamples()) | set(anim.GetBlendShapeWeightTimeSamples()) \
            if anim else set()
        return sorted(times), binding.query.IsRigidlyDeformed()

    def signature(self, root: Usd.Prim) -> tuple:
        """What the poses under `root` depend on beyond its prototype: each skinned prim's
        skeleton and animation. Copies of a prototype with equal signatures pose alike
        (same skeleton, same SkelAnimation, same time code) and may share meshes."""
        if not self._may_skin(root):
            return ()
        signature = []
        for prim in Usd.PrimRange(root, PREDICATE):
            binding = self._binding(prim)
            if binding is not None:
                anim = binding.skel.GetAnimQuery()
                signature.append((prototype_path(prim), prototype_path(binding.skeleton),
                                  prototype_path(anim.GetPrim()) if anim else None))
        return tuple(signature)

    def _may_skin(self, root: Usd.Prim) -> bool:
        """Whether a SkelRoot is at or above `root`, or anywhere in its prototype."""
        if UsdSkel.Root.Find(root):
            return True
        key = str(root.GetPrototype().GetPath()) if root.IsInstance() else prototype_path(root)
        if key not in self._has_skel_root:
            self._has_skel_root[key] = any(p.IsA(UsdSkel.Root) for p in Usd.PrimRange(root, PREDICATE))
        return self._has_skel_root[key]

    def _binding(self, prim: Usd.Prim) -> _Binding | None:
        """The prim's skeleton binding when it is a valid one, resolving its SkelRoot once."""
        root = UsdSkel.Root.Find(prim)
        if not root:
            return None
        if str(root.GetPath()) not in self._roots:
            self._populate(root)
        return self._bindings.get(str(prim.GetPath()))

    def _populate(self, root: UsdSkel.Root) -> None:
        """Resolves a SkelRoot's bindings and keeps those that pass every check.

        usd-core's complaints while resolving are folded into the checks' warnings: those
        naming a skeleton fail it; the others are warned about on their own only when no
        check under this root failed (that check's warning names the attribute). Inside
        instances a fault of the prototype is warned about once, at its first instance.
        """
        self._roots.add(str(root.GetPath()))
        with Report.usd_messages() as messages:
            self._cache.Populate(root, PREDICATE)
            bindings = self._cache.ComputeSkelBindings(root, PREDICATE)
        failed = False
        for binding in bindings:
            skeleton = binding.GetSkeleton().GetPrim()  # an instance proxy inside instances
            skel = self._cache.GetSkelQuery(binding.GetSkeleton())
            named = (f"{skeleton.GetPath()} -- ", f"{skel.GetPrim().GetPath()} -- ")
            said = [m.split(" -- ", 1)[1].rstrip(".") for m in messages if m.startswith(named)]
            problem = "; ".join(said) or self._skeleton_problem(skel, skeleton)
            targets = binding.GetSkinningTargets()
            if problem:
                failed = True
                self._warn_once((prototype_path(skeleton), problem),
                                f"Skeleton {skeleton.GetPath()}: {problem}; the {len(targets)} prims bound to it "
                                f"(first {targets[0].GetPrim().GetPath() if targets else 'none'}) are rendered "
                                "in their bind pose")
                continue
            for query in targets:
                prim = query.GetPrim()
                influence = self._influence_problem(query, skel)
                if influence:
                    failed = True
                    self._warn_once((prototype_path(prim), influence),
                                    f"{prim.GetPath()}: {influence}; rendered in its bind pose")
                else:
                    self._bindings[str(prim.GetPath())] = _Binding(skeleton, skel, query)
        if not failed:
            for message in messages:
                self._report.warn(f"SkelRoot {root.GetPath()}: usd: {message}")

    def _warn_once(self, key: tuple, message: str) -> None:
        """Warns about a fault the first time it is seen (instances of one prototype share it)."""
        if key not in self._warned:
            self._warned.add(key)
            self._report.approximated(BIND_POSE, message)

    def _skeleton_problem(self, skel: UsdSkel.SkeletonQuery, prim: Usd.Prim) -> str | None:
        """Why the skeleton cannot be posed (naming the attribute), or None."""
        skeleton = UsdSkel.Skeleton(prim)
        joints = list(skeleton.GetJointsAttr().Get() or [])
        if not joints:
            return "joints is empty"
        valid, why = UsdSkel.Topology(joints).Validate()
        if not valid:
            return f"joints: {why}"
        for attr in (skeleton.GetBindTransformsAttr(), skeleton.GetRestTransformsAttr()):
            count = len(attr.Get() or [])
            if count != len(joints):
                return f"{attr.GetName()} has {count} entries for {len(joints)} joints"
        return self._animation_problem(skel, prim, joints)

    def _animation_problem(self, skel: UsdSkel.SkeletonQuery, prim: Usd.Prim, joints: list[str]) -> str | None:
        """Why the skeleton's SkelAnimation cannot drive it (naming the attribute), or None."""
        anim = skel.GetAnimQuery()
        targets = UsdSkel.BindingAPI(prim).GetAnimationSourceRel().GetForwardedTargets()
        if not anim:
            return f"skel:animationSource targets {targets[0]}, which is not a SkelAnimation" if targets else None
        order = list(anim.GetJointOrder())
        if order and not set(order) & set(joints):
            return (f"its SkelAnimation {anim.GetPrim().GetPath()}: joints {order[:3]} name none of the "
                    "skeleton's joints")
        animation = UsdSkel.Animation(anim.GetPrim())
        for attr in (animation.GetTranslationsAttr(), animation.GetRotationsAttr(), animation.GetScalesAttr()):
            count = len(attr.Get(self._time) or [])
            if not count and self._time.IsDefault() and attr.GetNumTimeSamples():
                return (f"its SkelAnimation {anim.GetPrim().GetPath()}: {attr.GetName()} has time samples only, "
                        "and the default time code was exported (no --frame, no startTimeCode)")
            if order and count != len(order):
                return (f"its SkelAnimation {anim.GetPrim().GetPath()}: {attr.GetName()} has {count} entries "
                        f"for {len(order)} joints")
        return None

    def _influence_problem(self, query: UsdSkel.SkinningQuery, skel: UsdSkel.SkeletonQuery) -> str | None:
        """Why the prim's joint influences cannot be used (naming the primvar), or None."""
        prim = query.GetPrim()
        if not prim.IsA(UsdGeom.Mesh):
            return f"{prim.GetTypeName()} is bound to a Skeleton, but only Mesh prims are posed"
        indices_pv, weights_pv = query.GetJointIndicesPrimvar(), query.GetJointWeightsPrimvar()
        if not indices_pv or not weights_pv:
            return "primvars:skel:jointIndices and primvars:skel:jointWeights must both be authored"
        indices = np.array(indices_pv.Get(self._time) or [], dtype=np.int64)
        weights = np.array(weights_pv.Get(self._time) or [], dtype=np.float64)
        interpolation, size = indices_pv.GetInterpolation(), indices_pv.GetElementSize()
        if (weights_pv.GetInterpolation(), weights_pv.GetElementSize()) != (interpolation, size):
            return (f"primvars:skel:jointIndices ({interpolation}, elementSize {size}) and "
                    f"primvars:skel:jointWeights ({weights_pv.GetInterpolation()}, elementSize "
                    f"{weights_pv.GetElementSize()}) disagree")
        if interpolation not in (UsdGeom.Tokens.vertex, RIGID):
            return f"primvars:skel:jointIndices has {interpolation} interpolation; UsdSkel allows vertex or constant"
        if indices.size != weights.size:
            return (f"primvars:skel:jointIndices has {indices.size} entries but primvars:skel:jointWeights "
                    f"has {weights.size}")
        points = len(UsdGeom.Mesh(prim).GetPointsAttr().Get(self._time) or [])
        expected = size * (points if interpolation == UsdGeom.Tokens.vertex else 1)
        if indices.size != expected:
            return (f"primvars:skel:jointIndices has {indices.size} entries for {points} points x elementSize "
                    f"{size} ({interpolation})")
        joints = len(query.GetJointOrder() or skel.GetJointOrder())
        if indices.size and (indices.min() < 0 or indices.max() >= joints):
            bad = indices[(indices < 0) | (indices >= joints)][0]
            return f"primvars:skel:jointIndices holds {bad}, outside 0..{joints - 1}"
        if not np.isfinite(weights).all():
            return "primvars:skel:jointWeights holds NaN or infinite weights"
        return None

    def _compute(self, prim: Usd.Prim, binding: _Binding) -> Pose | None:
        """Poses a checked binding; anything usd-core says while doing so is a failure."""
        try:
            with Report.usd_messages() as messages:
                pose = self._posed(prim, binding)
        except Tf.ErrorException as error:
            messages, pose = [_usd_text(error)], None
        if messages or pose is None:
            reason = "; ".join(messages) or "no reason given"
            self._report.approximated(BIND_POSE, f"{prim.GetPath()}: UsdSkel cannot pose it ({reason}); rendered in its bind pose")
            return None
        return pose

    def _posed(self, prim: Usd.Prim, binding: _Binding) -> Pose | None:
        """Blend shapes, then skinning, of the mesh's points and normals at the time code."""
        skel, query, time = binding.skel, binding.query, self._time
        xforms = skel.ComputeSkinningTransforms(time)
        if len(xforms) != len(skel.GetJointOrder()):
            return None
        mesh = UsdGeom.Mesh(prim)
        points = mesh.GetPointsAttr().Get(time) or Vt.Vec3fArray()
        self._blend(prim, binding, points)
        normals = read_normals(mesh, time)
        if query.IsRigidlyDeformed():
            rigid = as_array(query.ComputeSkinnedTransform(xforms, time))
            return Pose(binding.skeleton, np.array(points, dtype=np.float64), normals, rigid)
        if not query.ComputeSkinnedPoints(xforms, points, time):
            return None
        if normals is not None and normals[1] not in SKINNED_NORMALS:
            self._report.warn(f"{prim.GetPath()}: normals have {normals[1]} interpolation, which cannot follow "
                              "the skinning; dropped, so the posed faces' geometric normals are used")
            normals = None
        if normals is not None:
            normals = self._skinned_normals(prim, query, xforms, normals)
            if normals is None:
                return None
        return Pose(binding.skeleton, np.array(points, dtype=np.float64), normals, np.eye(4))

    def _blend(self, prim: Usd.Prim, binding: _Binding, points: Vt.Vec3fArray) -> None:
        """Applies the mesh's blend shapes at the animation's weights, in place."""
        anim = binding.skel.GetAnimQuery()
        if not binding.query.HasBlendShapes() or not anim:
            return
        weights = anim.ComputeBlendShapeWeights(self._time)
        if not weights:
            return
        mapper = UsdSkel.AnimMapper(anim.GetBlendShapeOrder(), binding.query.GetBlendShapeOrder())
        shapes = UsdSkel.BlendShapeQuery(UsdSkel.BindingAPI(prim))
        sub_weights, shape_indices, sub_indices = shapes.ComputeSubShapeWeights(mapper.Remap(weights))
        shapes.ComputeDeformedPoints(sub_weights, shape_indices, sub_indices,
                                     shapes.ComputeBlendShapePointIndices(),
                                     shapes.ComputeSubShapePointOffsets(), points)
        for i in range(shapes.GetNumBlendShapes()):
            shape = shapes.GetBlendShape(i)
            if shape.GetNormalOffsetsAttr().HasAuthoredValue():
                self._report.warn(f"{shape.GetPrim().GetPath()}: normalOffsets are not applied (usd-core deforms "
                                  "points only); the normals follow the skinning alone")

    def _skinned_normals(self, prim: Usd.Prim, query: UsdSkel.SkinningQuery, xforms: Vt.Matrix4dArray,
                         normals: tuple[np.ndarray, str]) -> tuple[np.ndarray, str] | None:
        """Per-point or per-corner normals through the skinning transforms' inverse transposes
        (UsdSkel.SkinNormals); a corner takes its point's influences. None when usd-core fails."""
        values, interpolation = normals
        indices, weights = query.ComputeJointInfluences(self._time)
        size = query.GetNumInfluencesPerComponent()
        if interpolation == UsdGeom.Tokens.faceVarying:
            corners = np.array(UsdGeom.Mesh(prim).GetFaceVertexIndicesAttr().Get(self._time), dtype=np.int64)
            indices = np.array(indices).reshape(-1, size)[corners].reshape(-1)
            weights = np.array(weights).reshape(-1, size)[corners].reshape(-1)
        mapper = query.GetJointMapper()
        if mapper:
            xforms = mapper.RemapTransforms(xforms, Vt.Matrix4dArray())
        inverse_transposed = Vt.Matrix3dArray([m.ExtractRotationMatrix().GetInverse().GetTranspose() for m in xforms])
        bind = Gf.Matrix3d(query.GetGeomBindTransform(self._time).ExtractRotationMatrix()).GetInverse().GetTranspose()
        skinned = Vt.Vec3fArray.FromNumpy(values.astype(np.float32))
        if not UsdSkel.SkinNormals(query.GetSkinningMethod(), bind, inverse_transposed,
                                   Vt.IntArray.FromNumpy(np.asarray(indices, dtype=np.int32)),
                                   Vt.FloatArray.FromNumpy(np.asarray(weights, dtype=np.float32)), size, skinned):
            return None
        return np.array(skinned, dtype=np.float64), interpolation
