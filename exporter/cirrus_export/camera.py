"""The render camera and resolution: --camera, else the first render product's camera (else
its UsdRender.Settings' camera), else the first Camera, else a default.

The default camera (path null) looks at the centre of the scene bounds from the front
(along -Z for Y-up, +Y for Z-up) and DEFAULT_PITCH_DEG above, from far enough to see
all of them: a flat layout seen exactly edge-on would show nothing.
"""

import math

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdRender

from .render_settings import depth_of_field_disabled, render_products, warn_settings_without_products
from .report import ExportError, Report
from .xforms import as_array, to_3x4_list

# UsdGeomCamera schema fallbacks (millimetre-style tenths of a scene unit).
DEFAULT_FOCAL = 50.0
DEFAULT_APERTURE = (20.955, 15.2908)
# How far above the horizontal the default camera looks down at the scene, degrees.
DEFAULT_PITCH_DEG = 25.0


def chosen_camera(stage: Usd.Stage, path: str | None) -> Usd.Prim | None:
    """The Camera prim at `path` (--camera), None without one; raises ExportError, listing the
    stage's cameras, when `path` is not a camera of the stage."""
    if path is None:
        return None
    prim = stage.GetPrimAtPath(path) if Sdf.Path.IsValidPathString(path) else None
    if prim and prim.IsA(UsdGeom.Camera):
        return prim
    cameras = [str(p.GetPath()) for p in stage.Traverse() if p.IsA(UsdGeom.Camera)]
    what = "is not a camera" if prim else "is not a prim"
    listed = ", ".join(cameras) if cameras else "none"
    raise ExportError(f"--camera {path} {what} of the stage; its cameras: {listed}")


def _camera_prim(stage: Usd.Stage, settings: UsdRender.Settings | None, products: list[dict],
                 report: Report) -> Usd.Prim | None:
    """The first render product's camera (else the settings'), else the stage's first Camera."""
    if settings:
        targets = settings.GetCameraRel().GetForwardedTargets()
        camera = products[0]["camera"] if products else (str(targets[0]) if targets else None)
        if camera:
            prim = stage.GetPrimAtPath(camera)
            if prim and prim.IsA(UsdGeom.Camera):
                return prim
            report.warn(f"render settings {settings.GetPath()}: camera {camera} is not a Camera; ignored")
    for prim in stage.Traverse():
        if prim.IsA(UsdGeom.Camera):
            return prim
    return None


def export_render(stage: Usd.Stage, time: Usd.TimeCode, bounds: tuple[np.ndarray, np.ndarray],
                  report: Report, chosen: Usd.Prim | None = None,
                  settings: UsdRender.Settings | None = None) -> tuple[dict, dict]:
    """The manifest `camera` and `render` objects from `settings` (see chosen_settings);
    `chosen` (see chosen_camera) overrides the stage's camera. The settings'
    disableDepthOfField makes the camera a pinhole."""
    products = render_products(settings, time, report) if settings else []
    if settings and not products:
        warn_settings_without_products(settings, time, report)
    resolution = products[0]["resolution"] if products else \
        settings.GetResolutionAttr().Get(time) if settings else None
    render = {"resolution": [int(resolution[0]), int(resolution[1])] if resolution else None,
              "settings": str(settings.GetPath()) if settings else None,
              "products": products}
    prim = chosen or _camera_prim(stage, settings, products, report)
    if prim is None:
        return _default_camera(bounds, UsdGeom.GetStageUpAxis(stage)), render
    camera = _usd_camera(prim, time)
    if depth_of_field_disabled(settings, products, time):
        camera["f_stop"] = 0.0  # USD's "fStop infinite": a pinhole, as fStop 0 is
    return camera, render


def _usd_camera(prim: Usd.Prim, time: Usd.TimeCode) -> dict:
    """A UsdGeom.Camera's record at `time`."""
    camera = UsdGeom.Camera(prim)

    def value(attr: Usd.Attribute) -> float:
        """An attribute at `time` as a JSON float."""
        return float(attr.Get(time))

    near, far = camera.GetClippingRangeAttr().Get(time)
    world = as_array(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim))
    record = {
        "path": str(prim.GetPath()),
        "transform": to_3x4_list(world),
        "projection": str(camera.GetProjectionAttr().Get(time)),
        "focal_length": value(camera.GetFocalLengthAttr()),
        "horizontal_aperture": value(camera.GetHorizontalApertureAttr()),
        "vertical_aperture": value(camera.GetVerticalApertureAttr()),
        "horizontal_aperture_offset": value(camera.GetHorizontalApertureOffsetAttr()),
        "vertical_aperture_offset": value(camera.GetVerticalApertureOffsetAttr()),
        "clipping_range": [float(near), float(far)],
        "f_stop": value(camera.GetFStopAttr()),
        "focus_distance": value(camera.GetFocusDistanceAttr()),
    }
    exposure = _exposure_scale(camera, time)
    if exposure != 1.0:
        record["exposure_scale"] = exposure
    return record


def _exposure_scale(camera: UsdGeom.Camera, time: Usd.TimeCode) -> float:
    """UsdGeomCamera's linear exposure scale, by which the image's brightness is multiplied
    ("Camera Exposure Model"): responsivity x time x (iso / 100) x 2^exposure / fStop^2
    (ComputeLinearExposureScale; 1 with the attributes' fallbacks). Raises ExportError,
    naming the camera and attribute, for a non-finite attribute or a scale that is not
    positive and finite."""
    where = f"camera {camera.GetPath()}"
    for attr in (camera.GetExposureAttr(), camera.GetExposureTimeAttr(), camera.GetExposureIsoAttr(),
                 camera.GetExposureFStopAttr(), camera.GetExposureResponsivityAttr()):
        value = float(attr.Get(time))
        if not math.isfinite(value):
            raise ExportError(f"{where}: {attr.GetName()} is {value}; the image cannot be exposed (it must be finite)")
    scale = float(camera.ComputeLinearExposureScale(time))
    if not (math.isfinite(scale) and scale > 0.0):
        raise ExportError(f"{where}: exposure scale {scale} (exposure:responsivity x exposure:time x "
                          f"exposure:iso / 100 x 2^exposure / exposure:fStop^2) must be positive and finite")
    return scale


def _default_camera(bounds: tuple[np.ndarray, np.ndarray], up_axis: str) -> dict:
    """A perspective camera framing `bounds` whole, looking down at their centre from the
    front at DEFAULT_PITCH_DEG."""
    lo, hi = bounds
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-6)
    half_fov = math.atan(0.5 * DEFAULT_APERTURE[1] / DEFAULT_FOCAL)
    distance = 1.1 * radius / math.sin(half_fov)
    # Rows are the camera's axes in Y-up world space (row vectors): +X right, +Y up,
    # +Z backwards, tilted about +X so the camera looks down.
    pitch = math.radians(DEFAULT_PITCH_DEG)
    rotation = np.array([[1.0, 0, 0], [0, math.cos(pitch), -math.sin(pitch)],
                         [0, math.sin(pitch), math.cos(pitch)]])
    if up_axis == UsdGeom.Tokens.z:
        # Y-up to Z-up: world +Y -> +Z, +Z (towards the viewer) -> -Y.
        rotation = rotation @ np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])
    world = np.eye(4)
    world[:3, :3] = rotation
    world[3, :3] = centre + rotation[2] * distance
    return {
        "path": None,
        "transform": to_3x4_list(world),
        "projection": "perspective",
        "focal_length": DEFAULT_FOCAL,
        "horizontal_aperture": DEFAULT_APERTURE[0],
        "vertical_aperture": DEFAULT_APERTURE[1],
        "horizontal_aperture_offset": 0.0,
        "vertical_aperture_offset": 0.0,
        "clipping_range": [max(distance - radius, 0.0) * 0.5 + 1e-4, distance + 2.0 * radius],
        "f_stop": 0.0,
        "focus_distance": distance,
    }
