"""UsdLux LightAPI applied to geometry: gprims with `MeshLightAPI` (or `LightAPI`) become mesh
lights through a material record of their own, and volumes with `VolumeLightAPI` scale their
emission by the light's inputs.

A mesh light's material (exporter/FORMAT.md, "Material") emits what its `light:materialSyncMode`
asks for, times the record's `light.scale` (color x intensity x 2^exposure, divided by the
gprim's world-space area under `normalize`) and the blackbody colour of its temperature:
- `materialGlowTintsLight` (MeshLightAPI's default): the bound material's emission (its glow),
  its reflection kept;
- `independent`: emission 1 (the light's colour alone), the bound material's reflection kept;
- `noMaterialResponse` (LightAPI's default), or no Material bound: emission 1 and no reflection.
Cirrus has one emission for every ray, so camera rays see what lights the scene (the
specification lets them see the bare glow under the first two modes).
"""

import numpy as np
from pxr import Usd, UsdGeom, UsdLux

from .lights import light_inputs
from .linking import warn_unlinked
from .meshes import BadMesh, read_mesh
from .report import Report
from .shapes import tessellate
from .xforms import as_array, transform_points

# What a material record emits, by model: preview_surface's key, and open_pbr's.
WHITE = [1.0, 1.0, 1.0]
# The reflection of a light with no material response: black, no specular.
NO_RESPONSE = {"model": "preview_surface", "diffuse_color": [0.0, 0.0, 0.0], "use_specular_workflow": True,
               "specular_color": [0.0, 0.0, 0.0], "opacity": 1.0, "clearcoat": 0.0, "normal": None}


def is_light(prim: Usd.Prim) -> bool:
    """Whether the gprim or volume is a light: MeshLightAPI, VolumeLightAPI, or LightAPI
    applied directly (each of the first two applies LightAPI)."""
    return prim.HasAPI(UsdLux.LightAPI)


def world_area(prim: Usd.Prim, time: Usd.TimeCode, report: Report) -> float:
    """The gprim's surface area in world space (square scene units), triangulated as exported
    (a subdivision mesh's cage); 0 when it has no usable faces."""
    try:
        geometry = read_mesh(prim, time, report) if prim.IsA(UsdGeom.Mesh) else tessellate(prim, time)
    except BadMesh:
        return 0.0
    if geometry is None:
        return 0.0
    world = transform_points(geometry.points, as_array(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim)))
    a, b, c = (world[geometry.triangles[:, k]] for k in range(3))
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def light_material(prim: Usd.Prim, base: dict | None, time: Usd.TimeCode, report: Report) -> dict:
    """The material record of the mesh light `prim` whose bound material's record is `base`
    (None when no Material is bound): see the module doc."""
    light = UsdLux.LightAPI(prim)
    warn_unlinked(light, "mesh light", report)
    inputs = light_inputs(light, time)
    mode = str(light.GetMaterialSyncModeAttr().Get(time))
    path = prim.GetPath()
    scale = np.array(inputs["color"]) * inputs["intensity"] * 2.0 ** inputs["exposure"]
    if inputs["normalize"]:
        area = world_area(prim, time, report)
        if area > 0.0:
            scale = scale / area
        else:
            report.approximated("light", f"light {path}: inputs:normalize on geometry of zero area; not normalized")
    if base is None or mode == "noMaterialResponse":
        record = {"path": f"{path}.light", "shader": "mesh light", "skipped": [], "fallback": False,
                  **NO_RESPONSE, "emissive_color": WHITE}
    else:
        record = {**base, "path": f"{base['path']}:{path}.light"}
        glows = _glows(base)
        if mode == "independent":
            record.update(_emission(base, WHITE))
            if glows:
                report.approximated("light", f"light {path}: light:materialSyncMode independent: its material "
                                             f"{base['path']}'s glow is replaced by the light's colour for "
                                             f"every ray (Cirrus has one emission)")
        elif not glows:
            report.warn(f"light {path}: light:materialSyncMode materialGlowTintsLight and its material "
                        f"{base['path']} does not glow: the light emits nothing")
    record["light"] = {"path": str(path), "scale": [float(v) for v in scale],
                       "color_temperature": inputs["color_temperature"],
                       "diffuse": inputs["diffuse"], "specular": inputs["specular"]}
    return record


def _glows(record: dict) -> bool:
    """Whether a material record may emit (its emission is not a constant zero)."""
    if record.get("model") == "open_pbr":
        luminance = record.get("open_pbr", {}).get("emission_luminance", 0.0)
        return luminance != 0.0
    return record.get("emissive_color", [0.0, 0.0, 0.0]) != [0.0, 0.0, 0.0]


def _emission(record: dict, color: list[float]) -> dict:
    """The record's fields that set its emission to the constant `color`."""
    if record.get("model") == "open_pbr":
        return {"open_pbr": {**record.get("open_pbr", {}), "emission_luminance": 1.0, "emission_color": color}}
    return {"emissive_color": color}


def volume_light(prim: Usd.Prim, shading: dict, time: Usd.TimeCode, report: Report) -> None:
    """Scales a volume's emission (its emission field's and its temperature's, `shading`) by
    its VolumeLightAPI's intensity x 2^exposure and its emission field's colour by `color`
    (materialGlowTintsLight: the light tints the volume's glow); the inputs Cirrus cannot
    apply to a volume are warned about, naming each."""
    light = UsdLux.LightAPI(prim)
    warn_unlinked(light, "volume light", report)
    inputs = light_inputs(light, time)
    gain = inputs["intensity"] * 2.0 ** inputs["exposure"]
    shading["emission_scale"] = float(shading["emission_scale"] * gain)
    shading["heat_scale"] = float(shading["heat_scale"] * gain)
    shading["emission_color"] = [float(a * b) for a, b in zip(np.broadcast_to(shading["emission_color"], 3),
                                                              inputs["color"])]
    ignored = [name for name, unused in (
        ("inputs:color (on temperature emission)", inputs["color"] != WHITE and shading["heat_scale"] != 0.0),
        ("inputs:enableColorTemperature", inputs["color_temperature"] is not None),
        ("inputs:normalize", inputs["normalize"]),
        ("inputs:diffuse", inputs["diffuse"] != 1.0),
        ("inputs:specular", inputs["specular"] != 1.0),
        ("light:materialSyncMode", str(light.GetMaterialSyncModeAttr().Get(time)) != "materialGlowTintsLight"),
    ) if unused]
    if ignored:
        report.approximated("light", f"volume light {prim.GetPath()}: {', '.join(ignored)} not supported on "
                                     f"volumes; ignored")


def warn_round_shapes(prim: Usd.Prim, report: Report) -> None:
    """Points and curves with a LightAPI are not lights in Cirrus: warned about."""
    if is_light(prim):
        report.not_rendered("light", f"light {prim.GetPath()}: MeshLightAPI on {prim.GetTypeName()} is not "
                                     f"supported (meshes and implicit gprims only); rendered as plain geometry")
