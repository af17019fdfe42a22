"""Object-space bounds of one VDB grid, read from the file header without OpenVDB.

Only the grid descriptors, the grid's metadata (`file_bbox_min`/`file_bbox_max`, written
by OpenVDB for every grid) and its transform are read; voxel data is never touched.
Supported maps: (Uniform)ScaleTranslate, (Uniform)Scale, Translation, Affine.
"""

import struct
from pathlib import Path

import numpy as np

from .xforms import box_corners

MAGIC = 0x56444220
FIRST_SUPPORTED_VERSION = 222  # grid compression flags and the current transform layout


class _Reader:
    """Little-endian reads over a byte buffer."""

    def __init__(self, data: bytes, offset: int = 0) -> None:
        self.data, self.offset = data, offset

    def take(self, fmt: str):
        """Unpacks `fmt` (struct syntax, little-endian) at the cursor and advances."""
        values = struct.unpack_from("<" + fmt, self.data, self.offset)
        self.offset += struct.calcsize("<" + fmt)
        return values if len(values) > 1 else values[0]

    def string(self) -> str:
        """An OpenVDB string: u32 length then bytes."""
        size = self.take("I")
        text = self.data[self.offset:self.offset + size].decode("utf-8", "replace")
        self.offset += size
        return text

    def metadata(self) -> dict[str, tuple[str, bytes]]:
        """A metadata block: count, then (name, type name, u32 size, bytes) entries."""
        entries = {}
        for _ in range(self.take("I")):
            name, kind = self.string(), self.string()
            size = self.take("I")
            entries[name] = (kind, self.data[self.offset:self.offset + size])
            self.offset += size
        return entries


def _index_to_object(reader: _Reader) -> np.ndarray | None:
    """The grid transform as a row-vector 4x4 (index -> object space), or None if unsupported."""
    kind = reader.string()
    matrix = np.eye(4)
    if kind in ("ScaleTranslateMap", "UniformScaleTranslateMap"):
        translation, scale = reader.take("3d"), reader.take("3d")
        matrix[np.diag_indices(3)], matrix[3, :3] = scale, translation
    elif kind in ("ScaleMap", "UniformScaleMap"):
        matrix[np.diag_indices(3)] = reader.take("3d")
    elif kind == "TranslationMap":
        matrix[3, :3] = reader.take("3d")
    elif kind == "AffineMap":
        matrix = np.array(reader.take("16d"), dtype=np.float64).reshape(4, 4)
    else:
        return None
    return matrix


def _grid_header(path: str, grid: str) -> tuple[_Reader, dict] | None:
    """The first grid called `grid` in a .vdb: its metadata, and a reader at its transform.

    None when the file or grid cannot be read.
    """
    try:
        data = Path(path).read_bytes()
        reader = _Reader(data)
        if reader.take("Q") & 0xFFFFFFFF != MAGIC or reader.take("I") < FIRST_SUPPORTED_VERSION:
            return None
        reader.take("IIB36s")  # library version, has-offsets flag, UUID
        reader.metadata()
        for _ in range(reader.take("I")):
            name, _, _ = reader.string(), reader.string(), reader.string()
            grid_pos, _, end_pos = reader.take("qqq")
            if name.split("\x1e")[0] == grid:
                at = _Reader(data, grid_pos)
                at.take("I")  # compression flags
                return at, at.metadata()
            reader.offset = end_pos  # each grid's data follows its descriptor
    except (OSError, struct.error, ValueError):
        return None
    return None


def grid_class(path: str, grid: str) -> str | None:
    """OpenVDB's class of grid `grid` in a .vdb (its `class` metadata: "level set",
    "fog volume", "staggered", "unknown"), or None when it cannot be read."""
    found = _grid_header(path, grid)
    entry = found[1].get("class") if found else None
    return entry[1].decode("utf-8", "replace") if entry and entry[0] == "string" else None


def grid_bounds(path: str, grid: str) -> tuple[np.ndarray, np.ndarray] | None:
    """Object-space box of grid `grid` in a .vdb, grown by one voxel (the trilinear falloff).

    None when the file, grid, bbox metadata or transform cannot be read, or the grid is empty.
    """
    found = _grid_header(path, grid)
    if found is None:
        return None
    try:
        return _bounds_at(*found)
    except (struct.error, ValueError):
        return None


def _bounds_at(reader: _Reader, meta: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """One grid's box from its metadata and its transform, which `reader` is at."""
    lo, hi = meta.get("file_bbox_min"), meta.get("file_bbox_max")
    if lo is None or hi is None or lo[0] != "vec3i" or hi[0] != "vec3i":
        return None
    lo_index = np.array(struct.unpack("<3i", lo[1]), dtype=np.float64) - 1.0
    hi_index = np.array(struct.unpack("<3i", hi[1]), dtype=np.float64) + 1.0
    if (lo_index > hi_index).any():
        return None
    matrix = _index_to_object(reader)
    if matrix is None:
        return None
    corners = box_corners(lo_index, hi_index) @ matrix[:3, :3] + matrix[3, :3]
    return corners.min(axis=0), corners.max(axis=0)
