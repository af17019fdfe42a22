"""One export run: compose the stage, collect every record, write scene.json and scene.bin."""

import json
import math
import os
import re
from functools import partial
from pathlib import Path

import numpy as np
from pxr import Pcp, Tf, Usd, UsdGeom

from .assets import AssetResolver
from .binfile import BinWriter
from .camera import chosen_camera, export_render
from .instancing import Walker, instance_records
from .lights import export_lights
from .linking import add_linking
from .materials import MaterialTable
from .mtlx import MtlxDocuments
from .motion import Recorder, add_motion, replaying_walker
from .curves import CurvesTable
from .points import PointsTable
from .prototypes import MeshTable, Prototypes
from .render_settings import (chosen_settings, included_purposes, material_binding_purposes, motion_blur_disabled,
                              requested_primvars, warn_render_passes)
from .round_shapes import RoundContext
from .report import ExportError, Report
from .skinning import Skinning
from .volumes import VolumeTable
from .xforms import box_corners

FORMAT_VERSION = 1


def open_stage(path: Path, report: Report) -> Usd.Stage:
    """The composed stage with payloads loaded; unusable input raises ExportError."""
    if not path.is_file():
        raise ExportError(f"{path}: no such file")
    try:
        stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    except Tf.ErrorException as error:
        raise ExportError(f"{path}: cannot be read as USD: {tf_messages(error, path)}") from None
    if stage is None:
        raise ExportError(f"{path}: cannot be read as USD")
    report_composition_errors(stage, path, report)
    return stage


def report_composition_errors(stage: Usd.Stage, path: Path, report: Report) -> None:
    """One warning per missing layer (with how many places refer to it), one per other error."""
    missing: dict[str, list[str]] = {}
    for error in stage.GetCompositionErrors():
        text = " ".join(str(error).split())
        if isinstance(error, Pcp.ErrorInvalidAssetPath):
            missing.setdefault(text.split("@")[1], []).append(str(error.rootSite.path))
        else:
            report.warn(f"{path}: composition error: {text}")
    # MaterialX documents are read by mtlx.py, which reports those it cannot use.
    missing = {layer: sites for layer, sites in missing.items() if not layer.endswith(".mtlx")}
    for layer, sites in missing.items():
        what = "unreadable layer (no usd-core file format for it)" if Path(layer).is_file() else "missing layer"
        report.warn(f"{path}: {what} {layer}, referenced at {len(sites)} prims "
                    f"(first {sites[0]}); their content from it is not exported")


def tf_messages(error: Tf.ErrorException, path: Path) -> str:
    """The quoted messages of a Tf error about the file `path`, without the C++ function and
    source locations, and without naming `path` again (the caller names it once): USD's
    closing "Failed to open layer @path@" is dropped, `<path>` and `path:` prefixes shortened."""
    text = " ".join(str(error).split())
    messages = [m.strip() for m in re.findall(r" : '(.*?)'(?= Error in |$)", text)]
    names = {str(path), str(path.resolve())}
    kept = [m for m in messages if not any(m == f"Failed to open layer @{n}@" for n in names)]
    for name in sorted(names, key=len, reverse=True):
        kept = [m.replace(f"<{name}> ", "it ").replace(f"{name}:", "line ") for m in kept]
    return "; ".join(kept) or text


def pick_time(stage: Usd.Stage, frame: float | None) -> Usd.TimeCode:
    """--frame if given, else the stage's start time code, else the default time."""
    if frame is not None:
        return Usd.TimeCode(frame)
    if stage.HasAuthoredMetadata("startTimeCode"):
        return Usd.TimeCode(stage.GetStartTimeCode())
    return Usd.TimeCode.Default()


def world_bounds(prototype_boxes: list, prototype: np.ndarray, matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Union of every instance's prototype box through its world matrix (vectorised)."""
    lo = np.array([box[0] for box in prototype_boxes]).reshape(-1, 3)
    hi = np.array([box[1] for box in prototype_boxes]).reshape(-1, 3)
    corners = np.stack([box_corners(a, b) for a, b in zip(lo, hi)]) if len(lo) else np.zeros((0, 8, 3))
    keep = np.isfinite(lo).all(axis=1)[prototype]
    local = corners[prototype[keep]]
    m = matrices[keep]
    world = np.einsum("nkj,nji->nki", local, m[:, :3, :3]) + m[:, None, 3, :3]
    if world.size == 0:
        return np.zeros(3), np.zeros(3)
    return world.reshape(-1, 3).min(axis=0), world.reshape(-1, 3).max(axis=0)


def export(path: Path, out_dir: Path, frame: float | None, camera: str | None = None,
           shutter: tuple[float, float] | None = None, settings: str | None = None) -> list[str]:
    """Exports `path` to `out_dir` as seen by the camera prim `camera` (default: the stage's)
    with `shutter` (frames; default: the camera's) and the render settings prim `settings`
    (default: see chosen_settings); returns the warnings. Raises ExportError for unusable
    input."""
    report = Report()
    with report.usd_diagnostics():
        manifest, writer = collect(path, out_dir, frame, report, (camera, settings), shutter)
    manifest["warnings"] = report.warnings
    manifest["unrendered"] = report.counts
    bad = first_non_finite(manifest)
    if bad is not None:
        field, prim, value = bad
        raise ExportError(f"{path}: {prim or 'the stage'}: {field} is {value}; Cirrus needs finite values")
    writer.write(out_dir / "scene.bin")
    with open(out_dir / "scene.json", "w", encoding="utf-8") as out:
        json.dump(manifest, out, indent=1, allow_nan=False)
    return report.warnings


def first_non_finite(value, field: str = "", prim: str | None = None):
    """(field path, enclosing record's prim path, value) of the first NaN or infinite
    number of the manifest, else None: JSON cannot hold one."""
    if isinstance(value, float) and not math.isfinite(value):
        return field, prim, value
    if isinstance(value, dict):
        prim = value.get("path") if isinstance(value.get("path"), str) else prim
        items = ((f"{field}.{k}" if field else k, v) for k, v in value.items())
    elif isinstance(value, (list, tuple)):
        items = ((f"{field}[{i}]", v) for i, v in enumerate(value))
    else:
        return None
    for name, item in items:
        found = first_non_finite(item, name, prim)
        if found is not None:
            return found
    return None


def collect(path: Path, out_dir: Path, frame: float | None, report: Report,
            prims: tuple[str | None, str | None] = (None, None),
            shutter: tuple[float, float] | None = None) -> tuple[dict, BinWriter]:
    """Reads the stage into the manifest (warnings not yet filled in) and the scene.bin arrays;
    `prims` are the --camera and --settings prim paths."""
    stage = open_stage(path, report)
    chosen = chosen_camera(stage, prims[0])
    settings = chosen_settings(stage, prims[1], report)
    warn_render_passes(stage, report)
    time = pick_time(stage, frame)
    frame_label = "default" if time.IsDefault() else f"{time.GetValue():g}"
    out_dir.mkdir(parents=True, exist_ok=True)
    resolver = AssetResolver(out_dir)
    writer = BinWriter()
    mtlx = MtlxDocuments(stage, report)
    mtlx.warn_unreadable()
    materials = MaterialTable(resolver, mtlx, report, time, material_binding_purposes(settings, report))
    skinning = Skinning(report, time)
    aov_primvars = requested_primvars(settings, time, report)
    meshes = MeshTable(writer, materials, skinning, report, time, str(path), aov_primvars)
    volumes = VolumeTable(resolver, report, time, frame_label)
    points = PointsTable(RoundContext(writer, materials, report, time, str(path), aov_primvars=aov_primvars))
    curves = CurvesTable(RoundContext(writer, materials, report, time, str(path), aov_primvars=aov_primvars))
    round_shapes = {"Points": (points, ("points", "points")),
                    **{kind: (curves, ("curves", "curves")) for kind in ("BasisCurves", "NurbsCurves")}}
    prototypes = Prototypes(meshes, volumes, round_shapes)
    recorder = Recorder(prototypes)
    walker = partial(Walker, purposes=included_purposes(settings, report))
    sink = walker(recorder, skinning, report, time).walk_stage(stage)
    instances, prototype, matrices = instance_records(sink, writer)
    lights = export_lights(stage, time, resolver, report)
    links = add_linking(stage, lights, sink, prototypes.records, {"meshes": meshes.records, "points": points.records,
                        "curves": curves.records, "volumes": volumes.records}, report)
    if links is not None:
        instances["links"] = links
    if instances["count"] == 0 and not lights:
        # Each warning names the stage; the error does so once.
        named = f"{path}: "
        problems = "; ".join(w.removeprefix(named) for w in report.warnings) or \
            "the stage holds no visible mesh, gprim, volume or light"
        raise ExportError(f"{path}: nothing to export from /: {problems}")
    lo, hi = world_bounds(prototypes.boxes, prototype, matrices)
    camera, render = export_render(stage, time, (lo, hi), report, chosen, settings)
    if shutter is None and motion_blur_disabled(settings, render["products"], time, report):
        shutter = (0.0, 0.0)
    add_motion(stage, time, shutter, replaying_walker(walker, recorder, skinning, stage),
               (camera, instances), (matrices, sink.arrays()["source"]), writer, report, (meshes, skinning, points, curves),
               lights)
    manifest = {
        "format": "cirrus-scene",
        "version": FORMAT_VERSION,
        "source": {"path": str(path.resolve()), "mtime": os.path.getmtime(path),
                   "time_code": None if time.IsDefault() else time.GetValue()},
        "stage": {"meters_per_unit": UsdGeom.GetStageMetersPerUnit(stage),
                  "up_axis": str(UsdGeom.GetStageUpAxis(stage))},
        "bounds": {"min": lo.tolist(), "max": hi.tolist()},
        "meshes": meshes.records,
        "points": points.records,
        "curves": curves.records,
        "prototypes": prototypes.records,
        "instances": instances,
        "materials": materials.materials,
        "textures": materials.textures,
        "lights": lights,
        "camera": camera,
        "volumes": volumes.records,
        "render": render,
        "warnings": [],
    }
    return manifest, writer
