"""Motion over the shutter: instance and camera transforms keyed at times in the interval.

The shutter is the camera's `shutter:open`/`shutter:close` (frames relative to the time
code exported; USD's default 0, 0 is no blur), or the exporter's --shutter. When it is
open, the stage is walked again at every key time: the interval's ends, every authored
time sample of a transform (xformOps, PointInstancer positions/orientations/scales) inside
it, and midpoints wherever a moving instance or the camera turns by more than
MAX_KEY_ROTATION_DEG between keys (the renderer lerps matrices, which cuts a rotation's
arc to its chord; see src/motion.rs). Only what moves is written: a static scene, or any
scene with a closed shutter, exports byte-identical to one exported without this module.
"""

import math

import numpy as np
from pxr import Gf, Usd, UsdGeom

from .deforming import curves_motion, mesh_motion, points_motion
from .lights import add_light_motion
from .report import Report
from .xforms import as_array, to_3x4, to_3x4_list

# Largest rotation of an instance or the camera between neighbouring keys, degrees:
# matrix lerp then strays at most 1 - cos(2.5 deg) = 0.095% of the radius from the arc.
MAX_KEY_ROTATION_DEG = 5.0
# Most keys one export writes; past it, rotations between keys may exceed the limit.
MAX_KEYS = 65


class Recorder:
    """Wraps Prototypes during the first walk, recording what each add returned, so the
    walks at other times replay the same prototype indices without storing anything."""

    def __init__(self, prototypes) -> None:
        self._prototypes = prototypes
        self.meshes = prototypes.meshes
        self.results: list = []

    def add(self, path: str, parts: list, root, root_included: bool) -> int | None:
        """Prototypes.add, recorded."""
        result = self._prototypes.add(path, parts, root, root_included)
        self.results.append((path, result))
        return result


class StructureChanged(Exception):
    """A walk at another time met different prototypes than the walk at the frame."""


class _Replay:
    """Stands in for Prototypes in the walks at other times: the first walk's answers."""

    def __init__(self, recorder: Recorder) -> None:
        self.meshes = recorder.meshes
        self._results = iter(recorder.results)

    def add(self, path: str, parts: list, root, root_included: bool) -> int | None:
        """The index the first walk got for this prototype, in the same order."""
        recorded = next(self._results, None)
        if recorded is None or recorded[0] != path:
            raise StructureChanged(path)
        return recorded[1]


def shutter(camera_prim: Usd.Prim | None, time: Usd.TimeCode, override: tuple | None) -> tuple:
    """(open, close) in frames: --shutter, else the camera's attributes, else (0, 0)."""
    if override is not None:
        return override
    if camera_prim is None:
        return 0.0, 0.0
    camera = UsdGeom.Camera(camera_prim)
    return float(camera.GetShutterOpenAttr().Get(time)), float(camera.GetShutterCloseAttr().Get(time))


def scan(stage: Usd.Stage, start: float, end: float) -> list[float]:
    """One walk over the stage for the shutter [start, end] (absolute time codes): the
    transform key times, i.e. the interval's ends and every authored transform time sample
    strictly inside it (xformOps and PointInstancer positions/orientations/scales). What
    deforms is keyed by deforming.py, lights by lights.py."""
    times = {start, end}
    interval = Gf.Interval(start, end)
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()):
        xformable = UsdGeom.Xformable(prim)
        if xformable:
            times.update(xformable.GetTimeSamplesInInterval(interval))
        if prim.IsA(UsdGeom.PointInstancer):
            instancer = UsdGeom.PointInstancer(prim)
            for attr in (instancer.GetPositionsAttr(), instancer.GetOrientationsAttr(),
                         instancer.GetScalesAttr()):
                times.update(attr.GetTimeSamplesInInterval(interval))
    return sorted(t for t in times if start <= t <= end)


def _rotation_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per pair of (n, 4, 4) row-vector matrices, the angle of the rotation from a's to b's
    rotation part (polar decomposition, so scales and shears do not count), degrees."""
    def rotation(m: np.ndarray) -> np.ndarray:
        u, _, vt = np.linalg.svd(m[:, :3, :3])
        return u @ vt
    relative = np.swapaxes(rotation(a), -1, -2) @ rotation(b)
    cos = (np.trace(relative, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


class MotionSampler:
    """World matrices of every instance and of the camera at key times of the shutter."""

    def __init__(self, walk, camera_prim: Usd.Prim | None, frame: np.ndarray,
                 camera_frame: np.ndarray | None) -> None:
        """`walk(time)` returns the instances' (n, 4, 4) world matrices at a time code
        (raising StructureChanged when the stage's structure differs); `frame` and
        `camera_frame` are the matrices at the frame itself."""
        self._walk = walk
        self._camera = camera_prim
        self.frame = frame
        self.camera_frame = camera_frame
        self.instances: dict[float, np.ndarray] = {}
        self.cameras: dict[float, np.ndarray] = {}

    def sample(self, time: float) -> None:
        """Walks the stage and reads the camera at `time` (absolute time code)."""
        if time in self.instances:
            return
        self.instances[time] = self._walk(Usd.TimeCode(time))
        if self._camera is not None:
            cache = UsdGeom.XformCache(Usd.TimeCode(time))
            self.cameras[time] = as_array(cache.GetLocalToWorldTransform(self._camera))

    def refine(self, times: list[float]) -> list[float]:
        """`times`, sampled, with midpoints added until no instance or camera turns by
        more than MAX_KEY_ROTATION_DEG between neighbouring keys (or MAX_KEYS is reached)."""
        for t in times:
            self.sample(t)
        while len(times) < MAX_KEYS:
            split = [a for a, b in zip(times, times[1:]) if self._turn(a, b) > MAX_KEY_ROTATION_DEG]
            if not split:
                break
            for a in split[:MAX_KEYS - len(times)]:
                b = times[times.index(a) + 1]
                self.sample(0.5 * (a + b))
                times = sorted(set(times) | {0.5 * (a + b)})
        return times

    def _turn(self, a: float, b: float) -> float:
        """The largest rotation between keys a and b of any finite instance or the camera."""
        pairs = [(self.instances[a], self.instances[b])]
        if self._camera is not None:
            pairs.append((self.cameras[a][None], self.cameras[b][None]))
        worst = 0.0
        for ma, mb in pairs:
            finite = np.isfinite(ma).all(axis=(1, 2)) & np.isfinite(mb).all(axis=(1, 2))
            if finite.any():
                worst = max(worst, float(_rotation_deg(ma[finite], mb[finite]).max()))
        return worst


def instance_motion(sampler: MotionSampler, times: list[float], frame_time: float,
                    sources: list[str], source: np.ndarray, writer, report: Report) -> dict | None:
    """The manifest's `instances.motion` (None when no instance moves). An instance with a
    non-finite transform at some key is warned about by its source prim and left still."""
    keys = np.stack([to_3x4(sampler.instances[t]) for t in times], axis=1)  # (n, k, 12)
    frame = to_3x4(sampler.frame)[:, None, :]
    finite = np.isfinite(keys).all(axis=(1, 2))
    for prim in sorted({sources[s] for s in source[~finite]}):
        report.warn(f"{prim}: a transform over the shutter is not finite; exported without motion blur")
    moving = np.flatnonzero(finite & (keys != frame).any(axis=(1, 2)))
    if moving.size == 0:
        return None
    return {
        "times": [float(np.float32(t - frame_time)) for t in times],
        "instance": writer.add(moving.astype(np.uint32), "u32", 1),
        "transform": writer.add(keys[moving], "f32", 12),
    }


def camera_motion(sampler: MotionSampler, times: list[float], frame_time: float) -> dict | None:
    """The camera record's `motion` (None when it does not move)."""
    if sampler.camera_frame is None:
        return None
    keys = [to_3x4_list(sampler.cameras[t]) for t in times]
    frame = to_3x4_list(sampler.camera_frame)
    if all(k == frame for k in keys) or not all(math.isfinite(v) for k in keys for v in k):
        return None
    return {"times": [float(np.float32(t - frame_time)) for t in times], "transforms": keys}


class _Silent(Report):
    """The walks at other times repeat the frame's warnings: drop them."""

    def warn(self, message: str) -> None:
        """Nothing: the walk at the frame reported it already."""


def add_motion(stage: Usd.Stage, time: Usd.TimeCode, override: tuple | None, walker_at,
               records: tuple[dict, dict], frame: tuple[np.ndarray, np.ndarray],
               writer, report: Report, deforming: tuple | None = None,
               lights: list[dict] = ()) -> None:
    """Adds `shutter` and `motion` to the camera record, `motion` to the instances record
    (`records`), to each deforming mesh and moving points record and to the moving `lights` where the shutter
    is open and something moves.

    `walker_at(time_code)` walks the stage at another time and returns its TopSink;
    `frame` holds the instances' world matrices and source indices at the frame;
    `deforming` the export's (MeshTable, Skinning, PointsTable, CurvesTable), whose
    meshes and curves may deform and whose points may move."""
    camera, instances = records
    prim = stage.GetPrimAtPath(camera["path"]) if camera["path"] else None
    open_, close = shutter(prim, time, override)
    if (open_, close) == (0.0, 0.0):
        return
    where = f"camera {camera['path']}" if prim else "--shutter"
    if not (math.isfinite(open_) and math.isfinite(close)) or close < open_:
        from .report import ExportError
        raise ExportError(f"{where}: shutter {open_},{close}: close must be finite and not before open")
    camera["shutter"] = [open_, close]
    if time.IsDefault():
        report.warn(f"{where}: shutter {open_},{close} at the default time code has no frame to "
                    f"blur around; exported without motion (pass --frame or author startTimeCode)")
        return
    t0 = time.GetValue()
    transform_keys = scan(stage, t0 + open_, t0 + close)
    if deforming is not None:
        meshes, skinning, points, curves = deforming
        keys = (stage, t0, (t0 + open_, t0 + close), writer, (report, _Silent()))
        mesh_motion(meshes, skinning, *keys)
        points_motion(points, *keys)
        curves_motion(curves, *keys)
    matrices, source = frame
    reference = walker_at(time)

    def walk(at: Usd.TimeCode) -> np.ndarray:
        sink = walker_at(at)
        if sink.sources != reference.sources or \
                not np.array_equal(sink.arrays()["prototype"], reference.arrays()["prototype"]):
            raise StructureChanged(str(at))
        return sink.arrays()["matrices"]

    camera_frame = as_array(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim)) if prim else None
    sampler = MotionSampler(walk, prim, matrices, camera_frame)
    try:
        times = sampler.refine(transform_keys)
    except StructureChanged:
        report.warn(f"{where}: prims appear, disappear or change prototype over the shutter "
                    f"{open_},{close}; exported without motion")
        return
    moving = instance_motion(sampler, times, t0, reference.sources, source, writer, report)
    if moving is not None:
        instances["motion"] = moving
    add_light_motion(stage, lights, times, t0, report)
    camera_keys = camera_motion(sampler, times, t0)
    if camera_keys is not None:
        camera["motion"] = camera_keys


def replaying_walker(walker_type, recorder: Recorder, skinning, stage: Usd.Stage):
    """`walker_at(time_code)` for add_motion: a walk of `stage` at another time that
    replays the frame's prototypes and reports nothing."""
    def walker_at(at: Usd.TimeCode):
        return walker_type(_Replay(recorder), skinning.placed_at(at), _Silent(), at).walk_stage(stage)
    return walker_at
