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

# Light types left out, and why. A PortalLight only guides a dome's sampling (the dome lights
# the scene the same without it), so leaving it out keeps the image.
UNEXPORTED = {
    "PortalLight": "portals do not guide dome sampling in Cirrus; left out (the dome lights the "
                   "scene as without it: same image, noisier through small openings)",
    "GeometryLight": "GeometryLight (deprecated) is not supported; apply MeshLightAPI to the "
                     "geometry instead; left out",
    "PluginLight": "plugin lights are not supported; left out",
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
    """Every light record of the manifest; light prims of the UNEXPORTED types are warned about."""
    warn_unexported(stage, time, report)
    cache = UsdGeom.XformCache(time)
    records = []
    for prim in _light_prims(stage, time, report):
        kind, extra = LIGHT_TYPES[prim.GetTypeName()]
        light = UsdLux.LightAPI(prim)
        record = {
            "type": kind,
            "path": str(prim.GetPath()),
            "transform": to_3x4_list(as_array(cache.GetLocalToWorldTransform(prim))),
            **light_inputs(light, time),
        }
        warn_unhonoured(prim, time, report)
        for key, name, convert in extra:
            record[key] = _light_input(prim, name, convert, time, resolver, report)
        shaping = _shaping(prim, time, resolver, report)
        if shaping is not None:
            record["shaping"] = shaping
        if kind == "dome":
            _dome_format(prim, record, time, report)
        records.append(record)
    return records


# Manifest key -> (ShapingAPI input, value when neither the API is applied nor the input
# authored: one that leaves emission unshaped).
SHAPING_INPUTS = {
    "cone_angle_deg": ("inputs:shaping:cone:angle", 180.0),
    "cone_softness": ("inputs:shaping:cone:softness", 0.0),
    "focus": ("inputs:shaping:focus", 0.0),
    "focus_tint": ("inputs:shaping:focusTint", (0.0, 0.0, 0.0)),
    "ies_angle_scale": ("inputs:shaping:ies:angleScale", 0.0),
    "ies_normalize": ("inputs:shaping:ies:normalize", False),
}


def _shaping(prim: Usd.Prim, time: Usd.TimeCode, resolver: AssetResolver, report: Report) -> dict | None:
    """The light's UsdLuxShapingAPI inputs (usdLux/schema.usda, ShapingAPI), when the API is
    applied or any of them is authored; None otherwise. Values are read as authored (the
    renderer clamps and warns); an IES file that does not exist is warned about here, naming
    the file and the light, and the renderer then renders the light without it."""
    attrs = {key: prim.GetAttribute(name) for key, (name, _) in SHAPING_INPUTS.items()}
    ies_attr = prim.GetAttribute("inputs:shaping:ies:file")
    applied = prim.HasAPI(UsdLux.ShapingAPI)
    if not applied and not any(a and a.HasAuthoredValue() for a in [*attrs.values(), ies_attr]):
        return None
    record = {}
    for key, (_, neutral) in SHAPING_INPUTS.items():
        value = attrs[key].Get(time) if attrs[key] else None
        value = neutral if value is None else value
        record[key] = [float(c) for c in value] if key == "focus_tint" else type(neutral)(value)
    resolved = resolver.resolve(ies_attr, time) if ies_attr else None
    record["ies_file"] = None if resolved is None else resolved[0]
    if resolved is not None and not resolved[1]:
        report.warn(f"light {prim.GetPath()}: inputs:shaping:ies:file {resolved[0]} is missing; "
                    f"the light is rendered without its IES profile")
    return record


def light_inputs(light: UsdLux.LightAPI, time: Usd.TimeCode) -> dict:
    """The LightAPI inputs every light record carries (exporter/FORMAT.md, "Light"), on every
    type alike: color, intensity, exposure, normalize, the colour temperature when enabled,
    and the diffuse and specular factors."""
    return {
        "color": [float(c) for c in light.GetColorAttr().Get(time)],
        "intensity": float(light.GetIntensityAttr().Get(time)),
        "exposure": float(light.GetExposureAttr().Get(time)),
        "normalize": bool(light.GetNormalizeAttr().Get(time)),
        "color_temperature": float(light.GetColorTemperatureAttr().Get(time))
        if light.GetEnableColorTemperatureAttr().Get(time) else None,
        "diffuse": float(light.GetDiffuseAttr().Get(time)),
        "specular": float(light.GetSpecularAttr().Get(time)),
    }


def warn_unhonoured(prim: Usd.Prim, time: Usd.TimeCode, report: Report) -> None:
    """Warns, naming prim and attribute, about the authored UsdLux inputs of a light that
    Cirrus does not honour: light filters, a CylinderLight's treatAsLine,
    DomeLight_1's poleAxis when it means +Z, and
    ShadowAPI's inputs authored away from their fallbacks (shadows are always cast, black,
    unbounded)."""
    filters = UsdLux.LightAPI(prim).GetFiltersRel()
    if filters and filters.GetTargets():
        report.approximated("light", f"light {prim.GetPath()}: light:filters is not supported; "
                                     f"the light renders unfiltered")
    pole = prim.GetAttribute("poleAxis").Get(time) if prim.GetTypeName() == "DomeLight_1" else "Y"
    if pole == "Z" or (pole == "scene" and UsdGeom.GetStageUpAxis(prim.GetStage()) == UsdGeom.Tokens.z):
        report.approximated("light", f"light {prim.GetPath()}: poleAxis {pole} (+Z) is not supported; "
                                     f"the dome's pole is its +Y axis, as DomeLight's")
    if prim.GetTypeName() == "CylinderLight" and prim.GetAttribute("treatAsLine").Get(time):
        report.approximated("light", f"light {prim.GetPath()}: treatAsLine is not supported; rendered as a "
                                     f"cylinder of its radius")
    shadow = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("ShadowAPI")
    for name in UsdLux.ShadowAPI.GetSchemaAttributeNames(False):
        attr = prim.GetAttribute(name)
        if attr.HasAuthoredValue() and attr.Get(time) != shadow.GetAttributeFallbackValue(name):
            report.approximated("light", f"light {prim.GetPath()}: {name} = {attr.Get(time)} is not supported; "
                                         f"shadows are cast as by default (black, unbounded)")


def warn_unexported(stage: Usd.Stage, time: Usd.TimeCode, report: Report) -> None:
    """Names in a warning each visible light prim of a type Cirrus leaves out (UNEXPORTED)."""
    for prim in Usd.PrimRange.Stage(stage, PREDICATE):
        why = UNEXPORTED.get(prim.GetTypeName())
        if why and UsdGeom.Imageable(prim).ComputeVisibility(time) != UsdGeom.Tokens.invisible:
            report.not_rendered(prim.GetTypeName(), f"{prim.GetTypeName()} {prim.GetPath()}: {why}")


# inputs:texture:format token -> manifest texture_format ("latlong" is the default, not written).
DOME_FORMATS = {"latlong": "latlong", "automatic": "latlong", "angular": "angular",
                "mirroredBall": "mirrored_ball"}


def _dome_format(prim: Usd.Prim, record: dict, time: Usd.TimeCode, report: Report) -> None:
    """A dome's inputs:texture:format as the record's texture_format, written when not lat-long.

    `automatic` is lat-long: none of the image files we read declares a layout we read.
    `cubeMapVerticalCross` (and any other token) is warned about; the cross leaves the dome
    untextured (its constant colour), an unknown token reads as lat-long.
    """
    token = prim.GetAttribute("inputs:texture:format").Get(time) or "automatic"
    if token == "cubeMapVerticalCross" and record["texture"] is not None:
        report.warn(f"light {prim.GetPath()}: inputs:texture:format cubeMapVerticalCross is not "
                    f"supported; texture {record['texture']} not used (constant colour)")
        record["texture"] = None
    elif token not in DOME_FORMATS and token != "cubeMapVerticalCross":
        report.warn(f"light {prim.GetPath()}: inputs:texture:format {token!r} is not one of "
                    f"{', '.join(DOME_FORMATS)}; read as latlong")
    format_ = DOME_FORMATS.get(token, "latlong")
    if format_ != "latlong":
        record["texture_format"] = format_


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
