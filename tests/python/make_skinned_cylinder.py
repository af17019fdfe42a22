"""Writes a skinned cylinder stage for the UsdSkel tests (usd-core, run by the venv's Python).

usage: make_skinned_cylinder.py OUT.usda [MODE]

/World (an Xform: translated, rotated, scaled 1.5) holds the SkelRoot /World/Character:
- Skel: joints Root and Root/Elbow, 2 units apart along +Y, the skeleton itself moved
  and turned about Y; bind and rest poses agree.
- Anim: the elbow turns about Z by 0, 45 and 90 degrees at frames 1, 2 and 3; the blend
  shape weight `bulge` goes 0, 0.5, 1.
- Tube: an open cylinder, 8 rings x 12 segments, radius 0.5, y -2..2 in its own space,
  geomBindTransform lifting it to y 0..4, vertex normals, two influences per point
  blended over y 1.5..2.5, and a BlendShape `Bulge` pushing the two middle rings out.
  Its own translate (10, 0, 0) has no effect: UsdSkel renders skinned prims in skeleton
  space.
- Hand: a box rigidly bound (constant influences) to the elbow.
A fixed camera (/Camera, looking down -Z at the character whatever its pose) and a distant
light (/Sun) make the renders of two frames comparable.

MODE (default `posed`) breaks one thing:
  rest         no animation source: UsdSkel shows the rest pose
  bad_indices  Tube's primvars:skel:jointIndices is one entry short
  bad_anim     Anim's joints are named A and A/B, which the skeleton does not have
  no_joints    Skel authors no joints
or changes how the tube is described without changing its pose:
  corners      faceVarying normals, and the tube's own skel:joints order (the skeleton's
               reversed) that its jointIndices refer to
or makes a crowd of the character instead (defined once, as the class /Asset, without an
animation source), its members /World/Crowd/C1..C4 side by side: C1 and C2 bound to the
animation /Anims/Bend (the one above), C3 to /Anims/Wave (the elbow turning the other way,
no bulge), C4 to none (rest pose), each binding on the member prim, inherited by its Skel:
  crowd        members are instanceable references to /Asset (native instances)
  crowd_flat   the same members, not instanceable
"""
import math
import sys

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdSkel, Vt

RINGS, SEGMENTS, RADIUS = 8, 12, 0.5
JOINTS = ["Root", "Root/Elbow"]
ELBOW = Gf.Matrix4d().SetTranslate((0, 2, 0))
ANGLES = {1: 0.0, 2: 45.0, 3: 90.0}
BULGE = {1: 0.0, 2: 0.5, 3: 1.0}
WAVE = {1: -20.0, 2: -50.0, 3: -80.0}
NO_BULGE = {1: 0.0, 2: 0.0, 3: 0.0}


def tube() -> tuple[np.ndarray, np.ndarray, list[list[int]]]:
    """Points, radial normals and quads of the open cylinder, in the mesh's own space."""
    angle = np.linspace(0.0, 2.0 * math.pi, SEGMENTS, endpoint=False)
    y = np.linspace(-2.0, 2.0, RINGS)
    radial = np.stack([np.cos(angle), np.zeros(SEGMENTS), np.sin(angle)], axis=1)
    normals = np.tile(radial, (RINGS, 1))
    points = normals * RADIUS + np.repeat(y, SEGMENTS)[:, None] * [0.0, 1.0, 0.0]
    quads = [[r * SEGMENTS + s, (r + 1) * SEGMENTS + s, (r + 1) * SEGMENTS + (s + 1) % SEGMENTS,
              r * SEGMENTS + (s + 1) % SEGMENTS] for r in range(RINGS - 1) for s in range(SEGMENTS)]
    return points, normals, quads


def define_mesh(stage: Usd.Stage, path: str, points: np.ndarray, quads: list[list[int]]) -> UsdGeom.Mesh:
    """A polygon mesh (subdivisionScheme none) from points and quads."""
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr([len(q) for q in quads])
    mesh.CreateFaceVertexIndicesAttr([i for q in quads for i in q])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return mesh


def skeleton(stage: Usd.Stage, root: str, mode: str) -> UsdSkel.Skeleton:
    """The two-joint skeleton, moved and turned inside the SkelRoot."""
    skel = UsdSkel.Skeleton.Define(stage, f"{root}/Skel")
    if mode != "no_joints":
        skel.CreateJointsAttr(JOINTS)
    skel.CreateBindTransformsAttr([Gf.Matrix4d(1), ELBOW])
    skel.CreateRestTransformsAttr([Gf.Matrix4d(1), ELBOW])
    api = UsdGeom.XformCommonAPI(skel)
    api.SetTranslate((0.5, -1.0, 0.25))
    api.SetRotate((0.0, 30.0, 0.0))
    return skel


def animation(stage: Usd.Stage, path: str, mode: str, angles: dict = ANGLES,
              bulge: dict = BULGE) -> UsdSkel.Animation:
    """The elbow bend and the bulge weight, sampled at frames 1..3."""
    anim = UsdSkel.Animation.Define(stage, path)
    anim.CreateJointsAttr(["A", "A/B"] if mode == "bad_anim" else JOINTS)
    anim.CreateTranslationsAttr(Vt.Vec3fArray([(0, 0, 0), (0, 2, 0)]))
    anim.CreateScalesAttr(Vt.Vec3hArray([(1, 1, 1), (1, 1, 1)]))
    anim.CreateBlendShapesAttr(["bulge"])
    rotations, weights = anim.CreateRotationsAttr(), anim.CreateBlendShapeWeightsAttr()
    for frame, degrees in angles.items():
        bend = Gf.Quatf(Gf.Rotation(Gf.Vec3d(0, 0, 1), degrees).GetQuat())
        rotations.Set(Vt.QuatfArray([Gf.Quatf(1), bend]), frame)
        weights.Set(Vt.FloatArray([bulge[frame]]), frame)
    return anim


def bind_tube(stage: Usd.Stage, root: str, skel: UsdSkel.Skeleton, mode: str) -> None:
    """Tube: blended two-joint influences, geomBindTransform and the Bulge blend shape."""
    points, normals, quads = tube()
    mesh = define_mesh(stage, f"{root}/Tube", points, quads)
    corners = mode == "corners"
    per_corner = normals[[i for q in quads for i in q]]
    mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy((per_corner if corners else normals).astype(np.float32)))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.faceVarying if corners else UsdGeom.Tokens.vertex)
    UsdGeom.XformCommonAPI(mesh).SetTranslate((10.0, 0.0, 0.0))
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    bind_y = points[:, 1] + 2.0
    elbow = np.clip(bind_y - 1.5, 0.0, 1.0)
    indices = [0, 1] * len(points)
    if corners:
        binding.CreateJointsAttr(JOINTS[::-1])
        indices = [1, 0] * len(points)
    if mode == "bad_indices":
        indices = indices[:-1]
    binding.CreateJointIndicesPrimvar(False, 2).Set(indices)
    binding.CreateJointWeightsPrimvar(False, 2).Set(
        Vt.FloatArray.FromNumpy(np.stack([1.0 - elbow, elbow], axis=1).reshape(-1).astype(np.float32)))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d().SetTranslate((0, 2, 0)))
    middle = np.arange(3 * SEGMENTS, 5 * SEGMENTS)
    shape = UsdSkel.BlendShape.Define(stage, f"{root}/Tube/Bulge")
    shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy((normals[middle] * 0.2).astype(np.float32)))
    shape.CreatePointIndicesAttr(Vt.IntArray.FromNumpy(middle.astype(np.int32)))
    binding.CreateBlendShapesAttr(["bulge"])
    binding.CreateBlendShapeTargetsRel().SetTargets([shape.GetPath()])


def bind_hand(stage: Usd.Stage, root: str, skel: UsdSkel.Skeleton) -> None:
    """Hand: a 0.4-unit box rigidly bound to the elbow, its bind placing it at the tube's end."""
    corners = np.array([[x, y, z] for x in (-0.2, 0.2) for y in (0.0, 0.4) for z in (-0.2, 0.2)])
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    mesh = define_mesh(stage, f"{root}/Hand", corners, quads)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateSkeletonRel().SetTargets([skel.GetPath()])
    binding.CreateJointIndicesPrimvar(True, 1).Set([1])
    binding.CreateJointWeightsPrimvar(True, 1).Set([1.0])
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d().SetTranslate((0, 4, 0)))


def character(stage: Usd.Stage, root: str, mode: str) -> UsdSkel.Skeleton:
    """The SkelRoot at `root` with its Skel, Tube and Hand."""
    UsdSkel.Root.Define(stage, root)
    skel = skeleton(stage, root, mode)
    bind_tube(stage, root, skel, mode)
    bind_hand(stage, root, skel)
    return skel


def crowd(stage: Usd.Stage, instanced: bool) -> None:
    """/Asset (a class) referenced by four members, animated per member."""
    character(stage, "/Asset", "crowd")
    stage.GetPrimAtPath("/Asset").SetSpecifier(Sdf.SpecifierClass)
    anims = {"Bend": animation(stage, "/Anims/Bend", "crowd"),
             "Wave": animation(stage, "/Anims/Wave", "crowd", WAVE, NO_BULGE)}
    for i, anim in enumerate(["Bend", "Bend", "Wave", None]):
        member = stage.DefinePrim(f"/World/Crowd/C{i + 1}")
        member.GetReferences().AddInternalReference("/Asset")
        member.SetInstanceable(instanced)
        UsdGeom.XformCommonAPI(member).SetTranslate((4.0 * i, 0.0, 0.0))
        if anim is not None:
            UsdSkel.BindingAPI.Apply(member).CreateAnimationSourceRel().SetTargets([anims[anim].GetPath()])


def main(out: str, mode: str) -> None:
    """Writes the stage for MODE to OUT."""
    stage = Usd.Stage.CreateNew(out)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(3)
    world = UsdGeom.XformCommonAPI(UsdGeom.Xform.Define(stage, "/World"))
    world.SetTranslate((1.0, 2.0, -3.0))
    world.SetRotate((10.0, 0.0, 20.0))
    world.SetScale((1.5, 1.5, 1.5))
    camera = UsdGeom.Camera.Define(stage, "/Camera")
    camera.CreateFocalLengthAttr(35.0)
    UsdGeom.XformCommonAPI(camera).SetTranslate((0.6, 3.3, 20.0))
    UsdLux.DistantLight.Define(stage, "/Sun").CreateIntensityAttr(3.0)
    if mode.startswith("crowd"):
        crowd(stage, mode == "crowd")
    else:
        skel = character(stage, "/World/Character", mode)
        if mode != "rest":
            anim = animation(stage, "/World/Character/Anim", mode)
            UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    stage.GetRootLayer().Save()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "posed")
