"""Deforming meshes over the shutter: each mesh's points (and normals) at motion keys.

A mesh deforms when its `points` are time-sampled, when it authors `velocities` (and
`accelerations`), or when UsdSkel poses it with an animated SkelAnimation. Its keys are the
shutter's ends plus every authored sample inside (points, or the animation's), each read
as the frame is (`read_mesh`: the same unwelding and winding), so key k's point i is the
frame's point i at that time. Velocities follow USD's rule (UsdGeomPointBased::
ComputePointsAtTime): from the `points` sample at or before the frame, s,

    p(t) = p(s) + scale * dt * (v + 0.5 * dt * a),  dt = (t - s) / timeCodesPerSecond,

when `velocities` (sampled at s, or unsampled) has one value per point; else the points'
own samples are interpolated. A quadratic path (non-zero accelerations) gets
ACCELERATION_SEGMENTS equal steps, as the renderer lerps between keys. Velocities or
accelerations of the wrong length are ignored with a warning naming the prim; NaN or
infinite ones are zeroed, counted and warned about. A mesh whose topology changes at a key,
or whose points there are not finite, is warned about and exported as it is at the frame;
so is a rigidly skinned mesh (UsdSkel moves it by one transform, which is not carried).
Only meshes whose key points differ from the frame's get `motion`: static exports are
unchanged.
"""

import numpy as np
from pxr import Usd, UsdGeom

from .meshes import BadMesh, MeshGeometry, read_mesh, read_normals
from .report import Report
from .skinning import Pose, Skinning

# Equal steps of the shutter keyed for a mesh with non-zero accelerations: lerping a
# parabola over n steps strays at most a * (shutter / n)^2 / 8 from it.
ACCELERATION_SEGMENTS = 8


def mesh_motion(meshes, skinning: Skinning, stage: Usd.Stage, frame_time: float,
                shutter: tuple[float, float], writer, reports: tuple[Report, Report]) -> None:
    """Adds `motion` to every mesh record (of `meshes`, the export's MeshTable, posed by
    `skinning`) that deforms over the shutter [start, end] (absolute time codes); `reports`
    are the export's and one that swallows the repeated warnings of reads at other times."""
    context = _Context(stage, frame_time, shutter, reports, skinning)
    for record, source in zip(meshes.records, meshes.sources):
        if source[0].IsA(UsdGeom.Mesh):
            motion = context.motion(record, *source)
            if motion is not None:
                times, points, normals = motion
                record["motion"] = {
                    "times": [float(np.float32(t - frame_time)) for t in times],
                    "points": writer.add(points, "f32", 3),
                    "normals": None if normals is None else writer.add(normals, "f32", 3),
                }


class _Context:
    """What reading one export's deforming meshes shares: the stage, shutter and reports,
    and the UsdSkel poses at each key time."""

    def __init__(self, stage: Usd.Stage, frame_time: float, shutter: tuple[float, float],
                 reports: tuple[Report, Report], skinning: Skinning) -> None:
        self.frame_time, self.shutter = frame_time, shutter
        self.report, self.quiet = reports
        self.seconds_per_code = 1.0 / (stage.GetTimeCodesPerSecond() or 24.0)
        self.skinning = skinning
        self._poses: dict[float, Skinning] = {}

    def motion(self, record: dict, prim: Usd.Prim, uv_name: str,
               primvars: tuple[str, ...]) -> tuple[list[float], np.ndarray, np.ndarray | None] | None:
        """(key times, (k * n, 3) points, normals or None) of a mesh that deforms, else None."""
        frame = Usd.TimeCode(self.frame_time)
        read = lambda time, pose: read_mesh(prim, time, self.quiet, uv_name, pose, primvars)  # noqa: E731
        keyed = self._keyed(prim, frame)
        if keyed is None:
            return None
        times, pose_at = keyed
        path = prim.GetPath()
        poses = [pose_at(t) for t in times]
        if self.skinning.pose(prim) is not None and any(p is None for p in poses):
            self.report.warn(f"{path}: UsdSkel cannot pose it at every key over the shutter; exported as "
                             "posed at the frame")
            return None
        try:
            still = read(frame, self.skinning.pose(prim))
            keys = [read(frame if at is not None else Usd.TimeCode(t), at) for t, at in zip(times, poses)]
        except BadMesh as bad:
            self.report.warn(f"{path}: points over the shutter are unusable ({bad}); exported as it is at the frame")
            return None
        if any(not _same_topology(k, still) for k in keys):
            self.report.warn(f"{path}: its topology changes over the shutter; exported as it is at the frame "
                             "(deforming motion blur needs the same faces at every key)")
            return None
        points = np.stack([k.points for k in keys]).astype(np.float32)
        if (points == still.points.astype(np.float32)[None]).all():
            return None
        if record["normals"] is None:
            return times, points.reshape(-1, 3), None
        normals = [k.normals if k.normals is not None and k.normals.shape == still.normals.shape
                   else still.normals for k in keys]
        return times, points.reshape(-1, 3), np.concatenate(normals)

    def _keyed(self, prim: Usd.Prim, frame: Usd.TimeCode):
        """(key times, time -> pose override or None to read the points at that time) for
        a mesh that may deform, else None."""
        start, end = self.shutter
        inside = lambda samples: [t for t in samples if start < t < end]  # noqa: E731
        skinned = self.skinning.animation(prim)
        if skinned is not None:
            samples, rigid = skinned
            if not samples:
                return None
            if rigid:
                self.report.warn(f"{prim.GetPath()}: rigidly skinned by an animated SkelAnimation; its motion "
                                 "is not blurred (rendered as posed at the frame)")
                return None
            return sorted({start, *inside(samples), end}), self._pose_at(prim)
        mesh = UsdGeom.Mesh(prim)
        driven = self._velocity_driven(mesh, frame)
        if driven is not None:
            return driven
        points = mesh.GetPointsAttr()
        if points.GetNumTimeSamples() < 2:
            return None
        return sorted({start, *inside(points.GetTimeSamples()), end}), lambda t: None

    def _pose_at(self, prim: Usd.Prim):
        """time -> the prim's UsdSkel pose at that time code."""
        def pose(time: float) -> Pose | None:
            if time not in self._poses:
                self._poses[time] = Skinning(self.quiet, Usd.TimeCode(time))
            return self._poses[time].pose(prim)
        return pose

    def _velocity_driven(self, mesh: UsdGeom.Mesh, frame: Usd.TimeCode):
        """Keys and poses from `velocities` (and `accelerations`) by USD's rule, or None when
        the mesh has none that may be used (warned about when their length is wrong)."""
        points_attr, velocities_attr = mesh.GetPointsAttr(), mesh.GetVelocitiesAttr()
        if not velocities_attr.HasAuthoredValue():
            return None
        bracket = points_attr.GetBracketingTimeSamples(self.frame_time)
        base_time = bracket[0] if bracket else self.frame_time
        base = Usd.TimeCode(base_time)
        if velocities_attr.GetNumTimeSamples() and \
                velocities_attr.GetBracketingTimeSamples(self.frame_time)[:1] != (base_time,):
            return None  # USD interpolates the points when velocities are sampled elsewhere
        positions = np.array(points_attr.Get(base) or [], dtype=np.float64).reshape(-1, 3)
        path = mesh.GetPath()
        velocities = self._per_point(path, velocities_attr, base, len(positions))
        if velocities is None:
            return None
        accelerations = self._per_point(path, mesh.GetAccelerationsAttr(), base, len(positions))
        if accelerations is None:
            accelerations = np.zeros_like(velocities)
        start, end = self.shutter
        times = sorted({start, end})
        if accelerations.any() and end > start:
            times = [float(t) for t in np.linspace(start, end, ACCELERATION_SEGMENTS + 1)]
        scale = UsdGeom.MotionAPI(mesh.GetPrim()).ComputeVelocityScale(frame)
        normals = read_normals(mesh, base)

        def pose(time: float) -> Pose:
            dt = (time - base_time) * self.seconds_per_code
            moved = positions + scale * dt * (velocities + 0.5 * dt * accelerations)
            return Pose(None, moved, normals, np.eye(4))
        return times, pose

    def _per_point(self, path, attr: Usd.Attribute, time: Usd.TimeCode, count: int) -> np.ndarray | None:
        """An authored per-point vector attribute at `time`, its non-finite entries zeroed
        (counted, warned); None when unauthored or of the wrong length (warned)."""
        if not attr.HasAuthoredValue():
            return None
        values = np.array(attr.Get(time) or [], dtype=np.float64).reshape(-1, 3)
        name = attr.GetName()
        if len(values) != count:
            self.report.warn(f"{path}: {name} has {len(values)} values for {count} points; ignored")
            return None
        bad = ~np.isfinite(values).all(axis=1)
        if bad.any():
            self.report.warn(f"{path}: {int(bad.sum())} {name} are NaN or infinite; zeroed")
            values[bad] = 0.0
        return values


def _same_topology(key: MeshGeometry, still: MeshGeometry) -> bool:
    """Whether a key's triangles and point count are the frame's."""
    return key.points.shape == still.points.shape and np.array_equal(key.triangles, still.triangles)
