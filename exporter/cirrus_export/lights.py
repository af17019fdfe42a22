"""UsdLux lights: common LightAPI inputs plus each type's own, at world transforms."""

import math

import numpy as np
from pxr import Usd, UsdGeom, UsdLux

from .assets import AssetResolver
from .prims import PREDICATE
from .report import Report
from .xforms import as_array, to_3x4_list

# USD type name -> (manifest type, [(manifest key, USD input, JSON kind)]).
LIGHT_TYPES = {
    "DistantLight": ("distant", [("angle_deg", "inputs:angle", float)]),
    "SphereLight": ("sphere", [("radius", "inputs:radius", float), ("treat_as_point", "treatAsPoint", bool)]),
    "RectLight": ("rect", [("width", "inputs:width", float), ("height", "inputs:height", float),
                           ("texture", "inputs:texture:file", "asset")]),
    "DiskLight": ("disk", [("radius", "inputs:radius", float)]),
    "CylinderLight": ("cylinder", [("radius", "inputs:radius", float), ("length", "inputs:length", float)]),
    "DomeLight": ("dome", [("texture", "inputs:texture:file", "asset")]),
    "DomeLight_1": ("dome", [("texture", "inputs:texture:file", "asset")]),
}


def _light_prims(stage: Usd.Stage, time: Usd.TimeCode, report: Report):
    """Visible UsdLux lights of the stage, instance proxies included.

    PointInstancer prototypes are not walked: a light there would need one copy per
    instance, which the format does not model; such lights are warned about.
    """
    prims = iter(Usd.PrimRange.Stage(stage, PREDICATE))
    for prim in prims:
        if prim.IsA(UsdGeom.PointInstancer):
            prims.PruneChildren()
            if any(p.GetTypeName() in LIGHT_TYPES for p in Usd.PrimRange(prim, PREDICATE)):
                report.warn(f"PointInstancer {prim.GetPath()}: lights inside its prototypes are not exported")
        elif prim.GetTypeName() in LIGHT_TYPES and \
                UsdGeom.Imageable(prim).ComputeVisibility(time) != UsdGeom.Tokens.invisible:
            yield prim


def export_lights(stage: Usd.Stage, time: Usd.TimeCode, resolver: AssetResolver, report: Report) -> list[dict]:
    """Every light record of the manifest."""
    cache = UsdGeom.XformCache(time)
    records = []
    for prim in _light_prims(stage, time, report):
        kind, extra = LIGHT_TYPES[prim.GetTypeName()]
        light = UsdLux.LightAPI(prim)
        record = {
            "type": kind,
            "path": str(prim.GetPath()),
            "transform": to_3x4_list(as_array(cache.GetLocalToWorldTransform(prim))),
            "color": [float(c) for c in light.GetColorAttr().Get(time)],
            "intensity": float(light.GetIntensityAttr().Get(time)),
            "exposure": float(light.GetExposureAttr().Get(time)),
            "normalize": bool(light.GetNormalizeAttr().Get(time)),
            "color_temperature": float(light.GetColorTemperatureAttr().Get(time))
            if light.GetEnableColorTemperatureAttr().Get(time) else None,
        }
        for key, name, convert in extra:
            record[key] = _light_input(prim, name, convert, time, resolver, report)
        _warn_shadow_inputs(prim, time, report)
        records.append(record)
    return records


def _warn_shadow_inputs(prim: Usd.Prim, time: Usd.TimeCode, report: Report) -> None:
    """Warns of each UsdLuxShadowAPI input authored away from its fallback: none is honoured."""
    shadow = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("ShadowAPI")
    for name in UsdLux.ShadowAPI.GetSchemaAttributeNames(False):
        attr = prim.GetAttribute(name)
        if attr.HasAuthoredValue() and attr.Get(time) != shadow.GetAttributeFallbackValue(name):
            report.warn(f"light {prim.GetPath()}: {name} = {attr.Get(time)} is ignored (shadows as by default)")


def _light_input(prim: Usd.Prim, name: str, convert, time: Usd.TimeCode,
                 resolver: AssetResolver, report: Report):
    """One type-specific input: a number, a bool, or an absolute texture path (or None)."""
    attr = prim.GetAttribute(name)
    if convert != "asset":
        return convert(attr.Get(time))
    resolved = resolver.resolve(attr, time)
    if resolved is None:
        return None
    if not resolved[1]:
        report.warn(f"light {prim.GetPath()}: texture {resolved[0]} is missing; constant colour used")
    return resolved[0]


def add_light_motion(stage: Usd.Stage, records: list[dict], times: list[float], frame_time: float,
                     report: Report) -> None:
    """Adds `motion` (world-from-light at every key time, frames relative to the frame) to
    the records of the lights whose transform changes over the shutter (the renderer moves
    bounded lights rigidly and turns distant and dome lights); a light with a non-finite
    transform at some key is warned about and left still."""
    caches = [UsdGeom.XformCache(Usd.TimeCode(t)) for t in times]
    for record in records:
        prim = stage.GetPrimAtPath(record["path"])
        keys = [to_3x4_list(as_array(c.GetLocalToWorldTransform(prim))) for c in caches]
        if all(k == record["transform"] for k in keys):
            continue
        if not all(math.isfinite(v) for k in keys for v in k):
            report.warn(f"{record['path']}: the light's transform over the shutter is not finite; "
                        f"exported without motion blur")
            continue
        record["motion"] = {"times": [float(np.float32(t - frame_time)) for t in times],
                            "transforms": keys}
