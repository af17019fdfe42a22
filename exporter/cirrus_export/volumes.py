"""UsdVol.Volume prims with OpenVDBAsset fields, and their constant shading primvars.

Shading follows docs/conventions.md, "Shading primvars": constant primvars on the
Volume prim, each unauthored one replaced by its default and reported once per volume.
"""

import numpy as np
from pxr import Usd, UsdGeom, UsdShade, UsdVol

from .assets import AssetResolver
from .geometry_lights import is_light, volume_light
from .prims import prototype_path
from .report import Report
from .vdb_header import grid_bounds, grid_class

# Manifest key, primvar name, default (docs/conventions.md, "Shading primvars": densityScale 1,
# albedo 1, anisotropy 0, no emission).
# USD field relationship name -> manifest field key; "heat" is the openusd assets' name, "vel"
# and "v" Houdini's for velocity (docs/conventions.md, "Velocity fields").
FIELD_KEYS = {"density": "density", "temperature": "temperature", "heat": "temperature",
              "emission": "emission", "velocity": "velocity", "vel": "velocity", "v": "velocity"}

# What _field returns for a level-set field (refused with a warning; the volume goes on without it).
LEVEL_SET: dict = {}

# Emission parameters by the field that uses them, reported as defaulted only for volumes with that field.
EMISSION_PRIMVARS = {"temperature": {"heatScale", "temperatureOffset", "temperatureScale"},
                     "emission": {"emissionScale", "emissionColor"}}

SHADING_PRIMVARS = [
    ("density_scale", "densityScale", 1.0),
    ("albedo", "albedo", [1.0, 1.0, 1.0]),
    ("anisotropy", "anisotropy", 0.0),
    ("heat_scale", "heatScale", 0.0),
    ("temperature_offset", "temperatureOffset", 0.0),
    ("temperature_scale", "temperatureScale", 1.0),
    ("emission_scale", "emissionScale", 1.0),
    ("emission_color", "emissionColor", [1.0, 1.0, 1.0]),
]


# Primvars that may be a float (grey) or a color3f (per RGB channel): a colour densityScale
# makes extinction chromatic; written as three numbers, a float stays one number.
GREY_OR_RGB = {"densityScale"}


def _shading_value(primvar: UsdGeom.Primvar, default, time: Usd.TimeCode):
    """A constant primvar as JSON; a float albedo becomes a grey triple."""
    value = primvar.Get(time)
    is_triple = hasattr(value, "__len__")
    if isinstance(default, list) or (is_triple and primvar.GetPrimvarName() in GREY_OR_RGB):
        return [float(v) for v in value] if is_triple else [float(value)] * 3
    return float(value)


class VolumeTable:
    """Volumes of the manifest, each stored once, with their object-space bounds."""

    def __init__(self, resolver: AssetResolver, report: Report, time: Usd.TimeCode, frame_label: str) -> None:
        self.records: list[dict] = []
        self.boxes: list[tuple[np.ndarray, np.ndarray] | None] = []
        self._by_path: dict[str, int | None] = {}
        self._resolver, self._report, self._time = resolver, report, time
        self._frame = frame_label

    def index(self, prim: Usd.Prim) -> int | None:
        """The volume index of a Volume prim, or None when it was skipped."""
        key = prototype_path(prim)
        if key not in self._by_path:
            self._by_path[key] = self._add(prim, key)
        return self._by_path[key]

    def _field(self, volume: Usd.Prim, field: Usd.Prim) -> dict | None:
        """One OpenVDBAsset field; None (with a warning) when its file is missing, LEVEL_SET (with a
        warning naming field and prim) for a level set, by its `fieldClass` or its VDB grid class:
        its values are signed distances, which are never read as densities."""
        asset = UsdVol.OpenVDBAsset(field)
        if not asset:
            self._report.warn(f"volume {volume.GetPath()}: field {field.GetPath()} is a "
                              f"{field.GetTypeName() or 'typeless prim'}, not an OpenVDBAsset; ignored")
            return None
        if UsdGeom.Xformable(field).GetOrderedXformOps():
            self._report.warn(f"volume {volume.GetPath()}: field {field.GetPath()} has its own "
                              f"transform, which is ignored")
        resolved = self._resolver.resolve(asset.GetFilePathAttr(), self._time)
        if resolved is None or not resolved[1]:
            file = resolved[0] if resolved else "(no filePath)"
            self._report.warn(f"volume {volume.GetPath()}: VDB file {file} of field {field.GetPath()} "
                              f"does not exist at frame {self._frame}; volume skipped")
            return None
        grid = str(asset.GetFieldNameAttr().Get(self._time) or "")
        authored = asset.GetFieldClassAttr().Get(self._time)
        if authored == "levelSet" or grid_class(resolved[0], grid) == "level set":
            said = "fieldClass levelSet" if authored == "levelSet" else "its VDB grid class is level set"
            self._report.warn(f"volume {volume.GetPath()}: field {field.GetPath()} is a level set "
                              f"({said}): a signed distance, not a density; field refused")
            return LEVEL_SET
        return {"file": resolved[0], "grid": grid, "index": int(asset.GetFieldIndexAttr().Get(self._time) or 0)}

    def _add(self, prim: Usd.Prim, key: str) -> int | None:
        """Reads one Volume; skipped when any field file is missing or it has no field."""
        stage = prim.GetStage()
        fields = {}
        for name, path in UsdVol.Volume(prim).GetFieldPaths().items():
            field_key = FIELD_KEYS.get(str(name))
            if field_key is None or field_key in fields:
                self._report.warn(f"volume {prim.GetPath()}: field:{name} is not used by Cirrus "
                                  f"(only density, temperature/heat, emission and velocity/vel/v); ignored")
                continue
            field = self._field(prim, stage.GetPrimAtPath(path))
            if field is None:
                return None
            if field is LEVEL_SET:
                continue
            fields[field_key] = field
        if "density" not in fields:
            self._report.warn(f"volume {prim.GetPath()}: no field:density; skipped")
            return None
        record = {"path": key, "fields": fields, **self._shading(prim, set(fields))}
        if "velocity" in fields:
            record.update(self._velocity_units(prim))
        self.records.append(record)
        self.boxes.append(self._bounds(prim, fields))
        return len(self.records) - 1

    def _shading(self, prim: Usd.Prim, field_keys: set[str]) -> dict:
        """Shading parameters from constant primvars, defaults reported once per volume.

        Emission defaults are reported only when the volume has the field that uses them."""
        material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        if material:
            self._report.warn(f"volume {prim.GetPath()}: material {material.GetPath()} is not read "
                              f"(not a volume material we recognise); fallback volume shading used")
        primvars = UsdGeom.PrimvarsAPI(prim)
        shading, defaulted = {}, []
        for key, name, default in SHADING_PRIMVARS:
            primvar = primvars.GetPrimvar(name)
            if primvar and primvar.HasValue():
                shading[key] = _shading_value(primvar, default, self._time)
            else:
                shading[key] = default
                users = [key for key, names in EMISSION_PRIMVARS.items() if name in names]
                if not users or users[0] in field_keys:
                    defaulted.append(f"{name}={default}")
        if defaulted:
            self._report.warn(f"volume {prim.GetPath()}: unauthored, defaults used: {', '.join(defaulted)}")
        if is_light(prim):
            volume_light(prim, shading, self._time, self._report)
        return shading

    def _velocity_units(self, prim: Usd.Prim) -> dict:
        """What turns the velocity field's values into motion: UsdGeomMotionAPI's inherited
        `motion:velocityScale` (default 1) and the stage's `timeCodesPerSecond` (USD's default 24):
        velocities are world units per second, shutter times in frames."""
        scale = UsdGeom.MotionAPI(prim).ComputeVelocityScale(self._time)
        return {"velocity_scale": float(scale), "time_codes_per_second": prim.GetStage().GetTimeCodesPerSecond()}

    def _bounds(self, prim: Usd.Prim, fields: dict) -> tuple[np.ndarray, np.ndarray] | None:
        """Object-space box: the union of the fields' VDB grid boxes, else the authored extent.

        None (with a warning) when neither can be read; the scene bounds then leave it out.
        """
        # A velocity field moves the volume; its own grid bounds nothing that is drawn.
        boxes = [grid_bounds(field["file"], field["grid"]) for key, field in fields.items() if key != "velocity"]
        boxes = [box for box in boxes if box is not None]
        if boxes:
            return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)
        extent = UsdGeom.Boundable(prim).GetExtentAttr().Get(self._time)
        if extent is not None and len(extent) == 2:
            return np.array(extent[0], dtype=np.float64), np.array(extent[1], dtype=np.float64)
        self._report.warn(f"volume {prim.GetPath()}: no readable grid bounds (empty or unsupported VDB) "
                          f"and no authored extent; left out of scene bounds")
        return None
