"""Reads an exported Cirrus scene folder (scene.json + scene.bin, exporter/FORMAT.md).

Plain data only: the manifest as parsed JSON, bulk arrays as numpy views of
scene.bin (little-endian f32/u32), and 3x4 row-major transforms as 4x4 numpy
matrices acting on column vectors; plus the few rules of Cirrus' that every
converter repeats (UsdLux emission, aperture conforming, clipping, distant-light
irradiance, the material Cirrus gives unbound triangles, and how Cirrus reads a
texture: TextureInput, sRGB decoding, the st transform, scale and bias).
Used by the peer-renderer converters in this folder (Mitsuba in the
project .venv, Cycles inside Blender's Python: numpy only); it renders nothing.
"""

import argparse
import json
import math
from pathlib import Path
from typing import NamedTuple

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
    """UsdLux emission of a light record: color x intensity x 2^exposure
    (docs/conventions.md, "Lights").

    colorTemperature is not applied here: callers warn when it is set.
    """
    return np.asarray(light["color"], dtype=np.float64) * light["intensity"] * 2.0 ** light["exposure"]


#: u32::MAX in triangle_materials: no material (Cirrus renders UNBOUND).
NO_MATERIAL = 0xFFFFFFFF
#: UsdPreviewSurface's default diffuseColor.
GREY = [0.18, 0.18, 0.18]
#: The material record Cirrus renders for NO_MATERIAL (src/materials/mod.rs:
#: UsdPreviewSurface's defaults, a grey plastic with roughness 0.5 and ior 1.5,
#: not a Lambert), which is also what the exporter writes for a material it
#: could not read ("fallback": true; Cirrus renders those records as they are).
UNBOUND = {"path": "(no material)", "fallback": False, "diffuse_color": GREY,
           "emissive_color": [0.0, 0.0, 0.0], "metallic": 0.0, "roughness": 0.5,
           "specular_color": [0.0, 0.0, 0.0], "use_specular_workflow": False, "ior": 1.5,
           "opacity": 1.0, "clearcoat": 0.0, "clearcoat_roughness": 0.01, "normal": None}


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
    input gives its texture's fallback value (Cirrus' value where the image is missing)."""
    value = material.get(key, default)
    if isinstance(value, dict):
        fallback = manifest["textures"][value["texture"]]["fallback"]
        return (fallback[:3] if isinstance(default, list) else fallback[0]), True
    return value, False


class TextureInput(NamedTuple):
    """A material input read from a texture whose image file exists (src/materials/texture.rs).

    Conventions the converters must reproduce: st = (0, 0) is the image's
    bottom-left corner (row = (1 - t) height), texel centres at half-integers,
    bilinear filtering without mipmaps, `st_transform` (UsdTransform2d: scale,
    rotate counter-clockwise, translate) applied to the mesh's st first, wrap
    per axis on texel indices, colour space `auto` = sRGB-decode 8-bit images
    (OIIO's tag), the value texel x scale + bias, then `channel` picked (a
    single channel splatted to grey for colours; `rgb` reads r for scalars).
    """

    #: Index into the manifest's "textures".
    index: int
    #: The manifest's texture record (file, wrap_s/t, scale, bias, fallback, color_space, st_transform).
    record: dict
    #: The image, resolved against the scene folder.
    file: Path
    #: The output read: "rgb", "r", "g", "b" or "a".
    channel: str


def srgb_to_linear(v):
    """The sRGB decoding Cirrus applies to sRGB images (src/output/exr.rs), elementwise."""
    v = np.asarray(v, dtype=np.float32)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4).astype(np.float32)


def st_from_uv(record):
    """A texture's UsdTransform2d as a 3x3 affine matrix on (s, t, 1) (identity when none)."""
    m = np.eye(3)
    t = record.get("st_transform")
    if t:
        a = math.radians(t["rotation_deg"])
        rotate = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        m[:2, :2] = rotate @ np.diag(t["scale"])
        m[:2, 2] = t["translation"]
    return m


def stores_unit_range(record):
    """Whether a texture's scale is 1 and bias 0 on r, g and b (texture.rs'
    keeps_stored_range): a normal map then still needs 2 v - 1."""
    return list(record["scale"][:3]) == [1.0] * 3 and list(record["bias"][:3]) == [0.0] * 3


def shared_wrap(record, supported):
    """A texture's wrap mode when both axes share it and it is in `supported`
    (the peer's modes, by the format's names), else None."""
    wrap = record["wrap_s"]
    return wrap if wrap == record["wrap_t"] and wrap in supported else None


class Converter:
    """What the peer converters share: the scene, the warnings about what was
    approximated (printed by the caller) and material inputs read as constants
    or textures."""

    def __init__(self, scene):
        self.scene = scene
        self.manifest = scene.manifest
        self.warnings = []

    def warn(self, message):
        """Records something not converted exactly, once."""
        if message not in self.warnings:
            self.warnings.append(message)

    def material_record(self, index):
        """The material record of a triangle_materials index (UNBOUND for NO_MATERIAL)."""
        return UNBOUND if index == NO_MATERIAL else self.manifest["materials"][index]

    def constant(self, material, key, default):
        """A material input's constant; a texture gives its fallback (callers
        that cannot convert the texture report it with `keep_fallback`)."""
        return material_input(self.manifest, material, key, default)[0]

    def texture(self, material, key):
        """The TextureInput behind a material input, or None for a constant or a
        texture whose image is missing (Cirrus then reads the fallback too; the
        exporter warned)."""
        value = material.get(key)
        if not isinstance(value, dict):
            return None
        record = self.manifest["textures"][value["texture"]]
        if not record["file"]:
            return None
        file = Path(record["file"])
        if not file.is_absolute():
            file = self.scene.folder / file
        if not file.is_file():
            return None
        return TextureInput(value["texture"], record, file, value.get("channel", "rgb"))

    def keep_fallback(self, material, key, reason):
        """Reports a texture that a peer cannot represent (its fallback is used)."""
        self.warn(f"material {material['path']}: texture on {key} not converted ({reason}; "
                  "its fallback used)")

    def is_lambert(self, material):
        """Whether a UsdPreviewSurface is exactly Lambertian in Cirrus: the specular
        workflow with zero (untextured) specularColor, no clearcoat, opaque."""
        specular = self.constant(material, "specular_color", [0.0, 0.0, 0.0])
        opacity = self.constant(material, "opacity", 1.0)
        textured = self.texture(material, "specular_color") or self.texture(material, "opacity")
        return (material.get("use_specular_workflow", False) and max(specular) == 0
                and material.get("clearcoat", 0.0) == 0 and opacity >= 1 and not textured)
