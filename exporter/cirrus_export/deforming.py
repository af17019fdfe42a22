"""Deforming meshes, moving points and deforming curves over the shutter: each mesh's
points (and normals), each Points prim's centres and each curves prim's vertices (and
their widths), at motion keys.

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
or whose points there are not finite, is warned about and exported as it is at the frame.
A rigidly skinned mesh (constant influences: UsdSkel moves it by one transform M(t), and
its placement holds M(frame)) is keyed at the same times, each key its points through
M(t) M(frame)^-1 (normals through the inverse transpose). Only meshes whose key points
differ from the frame's get `motion`: static exports are unchanged.

A UsdGeomPoints prim is keyed the same way (time-sampled points, else velocities and
accelerations), at its points kept at the frame (`points.py`); its widths are keyed too
when they are time-sampled (their samples inside the shutter become keys), else the
frame's hold. A prim whose point count changes, or whose keyed centres or widths are not
finite (widths negative), is warned about and left as it is at the frame.

Curves (BasisCurves, NurbsCurves) are keyed as Points are, their control points (and
widths) at each key evaluated into the frame's pieces (curves.py `CurveSource.sample`: the
same piece count per segment, so key k's vertex i follows the frame's vertex i); a change
of curveVertexCounts over the shutter, points that are not finite, or keyed widths that no
longer fit are warned about and the curves left as they are at the frame.
"""

import numpy as np
from pxr import Usd, UsdGeom

from .curves import CurveSource
from .meshes import BadMesh, MeshGeometry, Pose, read_mesh, read_normals
from .report import Report
from .skinning import Skinning

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
                record["motion"] = _record(motion, ("normals", 3), frame_time, writer)


def points_motion(points, stage: Usd.Stage, frame_time: float, shutter: tuple[float, float],
                  writer, reports: tuple[Report, Report]) -> None:
    """Adds `motion` to every points record (of `points`, the export's PointsTable) whose
    centres or widths move over the shutter [start, end] (absolute time codes)."""
    context = _Context(stage, frame_time, shutter, reports, None)
    for record, source in zip(points.records, points.sources):
        keyed = context.point_keys(*source)
        if keyed is not None:
            record["motion"] = _record(keyed, ("widths", 1), frame_time, writer)


def curves_motion(curves, stage: Usd.Stage, frame_time: float, shutter: tuple[float, float],
                  writer, reports: tuple[Report, Report]) -> None:
    """Adds `motion` to every curves record (of `curves`, the export's CurvesTable) whose
    vertices or widths move over the shutter [start, end] (absolute time codes)."""
    context = _Context(stage, frame_time, shutter, reports, None)
    for record, source in zip(curves.records, curves.sources):
        keyed = context.curve_keys(source)
        if keyed is not None:
            record["motion"] = _record(keyed, ("widths", 1), frame_time, writer)


def _record(keys: tuple, extra: tuple[str, int], frame_time: float, writer) -> dict:
    """The `motion` record of (key times, points, `extra`'s values or None): times relative
    to the frame, points and the optional `extra` (name, width) written as f32."""
    times, points, values = keys
    name, width = extra
    return {
        "times": [float(np.float32(t - frame_time)) for t in times],
        "points": writer.add(points, "f32", 3),
        name: None if values is None else writer.add(values, "f32", width),
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

    def point_keys(self, prim: Usd.Prim, keep: np.ndarray, still: np.ndarray):
        """(key times, (k * n, 3) f32 centres, (k * n,) f32 widths or None) of a Points prim
        whose kept points (`keep`, at the frame `still`) move over the shutter, else None."""
        geom, path = UsdGeom.Points(prim), prim.GetPath()
        moving = self._moving(geom)
        if moving is None:
            return None
        times, at, widths_attr = moving
        keys = [at(t).reshape(-1, 3) for t in times]
        if any(len(k) != len(keep) for k in keys):
            self.report.warn(f"{path}: its point count changes over the shutter; rendered as it is at the frame")
            return None
        centres = np.stack(keys)[:, keep].astype(np.float32)
        if not np.isfinite(centres).all():
            self.report.warn(f"{path}: points over the shutter are not finite; rendered as it is at the frame")
            return None
        widths = None
        if widths_attr is not None:
            read = [np.asarray(widths_attr.Get(Usd.TimeCode(t)) or [], np.float64) for t in times]
            if any(len(w) not in (1, len(keep)) for w in read) or not _usable_widths(read):
                self.report.warn(f"{path}: widths over the shutter do not fit its points or are negative or "
                                 f"not finite; rendered as it is at the frame")
                return None
            widths = np.stack([np.broadcast_to(w, len(keep))[keep] for w in read]).astype(np.float32)
        still_widths = widths is None
        if widths is not None:
            now = np.asarray(widths_attr.Get(Usd.TimeCode(self.frame_time)) or [], np.float64)
            still_widths = len(now) in (1, len(keep)) and \
                bool((widths == np.broadcast_to(now, len(keep))[keep].astype(np.float32)[None]).all())
        if still_widths and (centres == still.astype(np.float32)[None]).all():
            return None
        return times, centres.reshape(-1, 3), None if widths is None else widths.reshape(-1)

    def curve_keys(self, source: CurveSource):
        """(key times, (k * n, 3) f32 vertices, (k * n,) f32 widths or None) of a curves
        record whose control points (or widths) move over the shutter, else None: each
        key's controls evaluated into the frame's pieces (`source.sample`)."""
        geom, path = UsdGeom.Curves(source.prim), source.prim.GetPath()
        moving = self._moving(geom)
        if moving is None:
            return None
        times, at, widths_attr = moving
        keys = [at(t).reshape(-1, 3) for t in times]
        counts = [np.asarray(geom.GetCurveVertexCountsAttr().Get(Usd.TimeCode(t)) or [], np.int64) for t in times]
        if any(len(k) != source.counts.sum() or not np.array_equal(n, source.counts) for k, n in zip(keys, counts)):
            self.report.warn(f"{path}: its vertex count changes over the shutter; rendered as it is at the frame")
            return None
        if not np.isfinite(np.stack(keys)).all():
            self.report.warn(f"{path}: points over the shutter are not finite; rendered as it is at the frame")
            return None
        vertices = np.stack([source.sample(k, "vertex") for k in keys]).astype(np.float32)
        widths = None
        if widths_attr is not None:
            read = [np.asarray(widths_attr.Get(Usd.TimeCode(t)) or [], np.float64).reshape(-1, 1) for t in times]
            if not source.widths[0] or any(len(w) != source.widths[0] for w in read) or not _usable_widths(read):
                self.report.warn(f"{path}: widths over the shutter do not fit its curves or are negative or "
                                 f"not finite; rendered as it is at the frame")
                return None
            widths = np.stack([source.sample(w, source.widths[1])[:, 0] for w in read]).astype(np.float32)
            if (widths == source.vertex_widths[None]).all():
                widths = None
        if widths is None and (vertices == source.vertices[None]).all():
            return None
        return times, vertices.reshape(-1, 3), None if widths is None else widths.reshape(-1)

    def _moving(self, geom: UsdGeom.PointBased):
        """(key times, time -> (n, 3) points, the `widths` attribute when it is keyed too,
        else None) of a points or curves prim whose points or widths may move, else None:
        velocities (USD's rule), else time-sampled points, else time-sampled widths alone."""
        frame = Usd.TimeCode(self.frame_time)
        driven = self._velocity_path(geom, frame)
        points_attr, widths_attr = geom.GetPointsAttr(), geom.GetWidthsAttr()
        if driven is not None:
            times, _, at = driven
        elif points_attr.GetNumTimeSamples() >= 2:
            times = self._sampled(points_attr)
            at = lambda t: np.array(points_attr.Get(Usd.TimeCode(t)) or [], np.float64)  # noqa: E731
        elif widths_attr.GetNumTimeSamples() >= 2:  # still centres, growing or shrinking
            times = self._sampled(widths_attr)
            at = lambda t: np.array(points_attr.Get(frame) or [], np.float64)  # noqa: E731
        else:
            return None
        if widths_attr.GetNumTimeSamples() < 2:
            return times, at, None
        return sorted({*times, *self._sampled(widths_attr)}), at, widths_attr

    def _sampled(self, attr: Usd.Attribute) -> list[float]:
        """The shutter's ends and `attr`'s time samples strictly inside it."""
        start, end = self.shutter
        return sorted({start, *(t for t in attr.GetTimeSamples() if start < t < end), end})

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
            times = sorted({start, *inside(samples), end})
            if not rigid:
                return times, self._pose_at(prim)
            try:
                frame_inverse = np.linalg.inv(self.skinning.pose(prim).skel_from_points)
            except np.linalg.LinAlgError:
                self.report.warn(f"{prim.GetPath()}: its rigid skinning transform at the frame is singular; "
                                 "rendered as posed at the frame, not blurred")
                return None
            return times, self._rigid_pose_at(prim, frame_inverse)
        mesh = UsdGeom.Mesh(prim)
        driven = self._velocity_driven(mesh, frame)
        if driven is not None:
            return driven
        points = mesh.GetPointsAttr()
        if points.GetNumTimeSamples() < 2:
            return None
        return self._sampled(points), lambda t: None

    def _pose_at(self, prim: Usd.Prim):
        """time -> the prim's UsdSkel pose at that time code."""
        def pose(time: float) -> Pose | None:
            if time not in self._poses:
                self._poses[time] = Skinning(self.quiet, Usd.TimeCode(time))
            return self._poses[time].pose(prim)
        return pose

    def _rigid_pose_at(self, prim: Usd.Prim, frame_inverse: np.ndarray):
        """time -> a rigidly skinned prim at that time code in the space its frame's pose
        is placed from: UsdSkel moves it by one transform M(t) (`Pose.skel_from_points`,
        row vectors), and the placement holds M(frame) (`frame_inverse` is its inverse), so
        a key's points are its own through M(t) M(frame)^-1, its normals through that
        matrix's inverse transpose (its cofactors where it is singular)."""
        posed = self._pose_at(prim)

        def pose(time: float) -> Pose | None:
            at = posed(time)
            if at is None:
                return None
            relative = at.skel_from_points @ frame_inverse
            linear = relative[:3, :3]
            normals = at.normals
            if normals is not None:
                cofactors = np.stack([np.cross(linear[1], linear[2]), np.cross(linear[2], linear[0]),
                                      np.cross(linear[0], linear[1])])
                det = float(np.linalg.det(linear))
                normals = normals[0] @ (cofactors / det if det else cofactors), normals[1]
            return Pose(None, at.points @ linear + relative[3, :3], normals, np.eye(4))
        return pose

    def _velocity_driven(self, mesh: UsdGeom.Mesh, frame: Usd.TimeCode):
        """Keys and poses from `velocities` (and `accelerations`) by USD's rule, or None when
        the mesh has none that may be used (warned about when their length is wrong)."""
        driven = self._velocity_path(mesh, frame)
        if driven is None:
            return None
        times, base_time, at = driven
        normals = read_normals(mesh, Usd.TimeCode(base_time))
        return times, lambda time: Pose(None, at(time), normals, np.eye(4))

    def _velocity_path(self, geom: UsdGeom.PointBased, frame: Usd.TimeCode):
        """(key times, base sample time, time -> (n, 3) points) from `velocities` (and
        `accelerations`) by USD's rule, or None when the prim has none that may be used
        (warned about when their length is wrong)."""
        points_attr, velocities_attr = geom.GetPointsAttr(), geom.GetVelocitiesAttr()
        if not velocities_attr.HasAuthoredValue():
            return None
        bracket = points_attr.GetBracketingTimeSamples(self.frame_time)
        base_time = bracket[0] if bracket else self.frame_time
        base = Usd.TimeCode(base_time)
        if velocities_attr.GetNumTimeSamples() and \
                velocities_attr.GetBracketingTimeSamples(self.frame_time)[:1] != (base_time,):
            return None  # USD interpolates the points when velocities are sampled elsewhere
        positions = np.array(points_attr.Get(base) or [], dtype=np.float64).reshape(-1, 3)
        path = geom.GetPath()
        velocities = self._per_point(path, velocities_attr, base, len(positions))
        if velocities is None:
            return None
        accelerations = self._per_point(path, geom.GetAccelerationsAttr(), base, len(positions))
        if accelerations is None:
            accelerations = np.zeros_like(velocities)
        start, end = self.shutter
        times = sorted({start, end})
        if accelerations.any() and end > start:
            times = [float(t) for t in np.linspace(start, end, ACCELERATION_SEGMENTS + 1)]
        scale = UsdGeom.MotionAPI(geom.GetPrim()).ComputeVelocityScale(frame)

        def at(time: float) -> np.ndarray:
            dt = (time - base_time) * self.seconds_per_code
            return positions + scale * dt * (velocities + 0.5 * dt * accelerations)
        return times, base_time, at

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


def _usable_widths(widths: list[np.ndarray]) -> bool:
    """Whether every key's widths are finite and not negative."""
    return all(np.isfinite(w).all() and (w >= 0).all() for w in widths)


def _same_topology(key: MeshGeometry, still: MeshGeometry) -> bool:
    """Whether a key's triangles and point count are the frame's."""
    return key.points.shape == still.points.shape and np.array_equal(key.triangles, still.triangles)
