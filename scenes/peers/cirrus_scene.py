"""Reads an exported Cirrus scene folder (scene.json + scene.bin, scenes/FORMAT.md).

Plain data only: the manifest as parsed JSON, bulk arrays as numpy views of
scene.bin (little-endian f32/u32), and 3x4 row-major transforms as 4x4 numpy
matrices acting on column vectors; plus the few rules of Cirrus' that every
converter repeats (UsdLux emission, aperture conforming, clipping, distant-light
irradiance). Used by the peer-renderer converters in this folder (Mitsuba in the
project .venv, Cycles inside Blender's Python: numpy only); it renders nothing.
"""

import argparse
import json
import math
from pathlib import Path

import numpy as np

_DTYPES = {"f32": np.dtype("<f4"), "u32": np.dtype("<u4")}


class CirrusScene:
    """One exported scene: `manifest` (the parsed scene.json) and its arrays."""

    def __init__(self, folder):
        self.folder = Path(folder)
        with open(self.folder / "scene.json", encoding="utf-8") as f:
            self.manifest = json.load(f)
        if self.manifest.get("format") != "cirrus-scene" or self.manifest.get("version") != 1:
            raise ValueError(f"{self.folder}: not a version-1 cirrus scene folder")
        self.blob = np.fromfile(self.folder / "scene.bin", dtype=np.uint8)

    def array(self, ref):
        """The array an array reference names, shaped (count, width), or (count,) for width 1."""
        dtype = _DTYPES[ref["type"]]
        count, width = ref["count"], ref["width"]
        start = ref["offset"]
        data = self.blob[start : start + count * width * 4].view(dtype)
        return data if width == 1 else data.reshape(count, width)

    def instances(self):
        """(prototype index, world-from-prototype 4x4) for every instance."""
        inst = self.manifest["instances"]
        if inst["count"] == 0:
            return []
        protos = self.array(inst["prototype"])
        transforms = self.array(inst["transform"])
        return [(int(p), affine4(t)) for p, t in zip(protos, transforms)]


def affine4(transform12):
    """A format transform (12 floats, rows of [R | t]) as a 4x4 float64 matrix."""
    m = np.eye(4)
    m[:3, :] = np.asarray(transform12, dtype=np.float64).reshape(3, 4)
    return m


def emission(light):
    """UsdLux emission of a light record: color x intensity x 2^exposure (CONVENTIONS.md).

    colorTemperature is not applied here: callers warn when it is set.
    """
    return np.asarray(light["color"], dtype=np.float64) * light["intensity"] * 2.0 ** light["exposure"]


#: u32::MAX in triangle_materials: no material (Cirrus' grey default).
NO_MATERIAL = 0xFFFFFFFF
#: Cirrus' default and fallback material albedo.
GREY = [0.18, 0.18, 0.18]


def parse_resolution(text):
    """'WxH' as (W, H), both positive (an argparse type)."""
    w, _, h = text.partition("x")
    if not (w.isdigit() and h.isdigit() and int(w) > 0 and int(h) > 0):
        raise argparse.ArgumentTypeError(f"resolution {text!r} is not WxH")
    return int(w), int(h)


def conformed_aperture(camera, width, height):
    """(horizontal, vertical) aperture grown to the image aspect ("expandAperture",
    src/camera/window.rs), in the camera record's units (tenths of a scene unit)."""
    ha, va = camera["horizontal_aperture"], camera["vertical_aperture"]
    image_aspect = width / height
    if image_aspect > ha / va:
        return va * image_aspect, va
    return ha, ha / image_aspect


def scene_size(manifest):
    """Diagonal of the scene bounds (1 when empty), scene units."""
    b = manifest["bounds"]
    size = float(np.linalg.norm(np.subtract(b["max"], b["min"])))
    return size if size > 0 else 1.0


def near_far(manifest):
    """The camera's (near, far) clipping distances as Cirrus uses them: rays start
    at the eye unless near exceeds 1e-3 far, so a tiny near stands in for 0."""
    near, far = manifest["camera"]["clipping_range"]
    if near <= 1e-3 * far:
        near = 1e-4 * min(far, scene_size(manifest))
    return near, far


def density_scale(volume):
    """A volume's grey densityScale (sigma_t per world unit per density).

    The format stores one number, or three for chromatic extinction, which neither peer
    converter renders: refused naming the volume, so a comparison never runs on a
    silently greyed medium."""
    scale = volume["density_scale"]
    if isinstance(scale, list):
        if len(set(scale)) > 1:
            raise ValueError(f"volume {volume['path']}: chromatic densityScale {scale} is not converted")
        scale = scale[0]
    return float(scale)


def distant_irradiance(light):
    """Irradiance on a surface facing a distant light (src/lights/distant.rs):
    the emission under `normalize`, else the disk's radiance x pi sin^2(angle/2)."""
    e = emission(light)
    if light["normalize"]:
        return e
    half = math.radians(light["angle_deg"]) / 2.0
    return e * math.pi * math.sin(min(half, math.pi / 2)) ** 2


def material_input(manifest, material, key, default):
    """(a material input's constant value, whether it was a texture): a textured
    input gives its texture's fallback value, which converters use instead."""
    value = material.get(key, default)
    if isinstance(value, dict):
        fallback = manifest["textures"][value["texture"]]["fallback"]
        return (fallback[:3] if isinstance(default, list) else fallback[0]), True
    return value, False


def is_lambert(manifest, material):
    """Whether a UsdPreviewSurface is exactly Lambertian in Cirrus: the specular
    workflow with zero specularColor, no clearcoat, opaque."""
    specular, _ = material_input(manifest, material, "specular_color", [0.0, 0.0, 0.0])
    opacity, _ = material_input(manifest, material, "opacity", 1.0)
    return (material.get("use_specular_workflow", False) and max(specular) == 0
            and material.get("clearcoat", 0.0) == 0 and opacity >= 1)


class Converter:
    """What the peer converters share: the scene, the warnings about what was
    approximated (printed by the caller) and material inputs read as constants."""

    def __init__(self, scene):
        self.scene = scene
        self.manifest = scene.manifest
        self.warnings = []

    def warn(self, message):
        """Records something not converted exactly, once."""
        if message not in self.warnings:
            self.warnings.append(message)

    def constant(self, material, key, default):
        """A material input's constant; a texture becomes its fallback (reported)."""
        value, textured = material_input(self.manifest, material, key, default)
        if textured:
            self.warn(f"material {material['path']}: texture on {key} not converted (its fallback used)")
        return value
