"""Reads an exported Cirrus scene folder (scene.json + scene.bin, scenes/FORMAT.md).

Plain data only: the manifest as parsed JSON, bulk arrays as numpy views of
scene.bin (little-endian f32/u32), and 3x4 row-major transforms as 4x4 numpy
matrices acting on column vectors. Used by the peer-renderer converters in this
folder; it renders nothing.
"""

import json
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
