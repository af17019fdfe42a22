"""`scene.bin`: every bulk array, little-endian, each at a 16-byte-aligned offset."""

from pathlib import Path

import numpy as np

ALIGN = 16
DTYPES = {"f32": np.dtype("<f4"), "u32": np.dtype("<u4")}


class BinWriter:
    """Appends arrays to one buffer and hands back their manifest references."""

    def __init__(self) -> None:
        self._chunks: list[bytes] = []
        self._size = 0

    def add(self, values: np.ndarray, kind: str, width: int) -> dict:
        """Stores `values` as `kind` ("f32"/"u32") with `width` scalars per element.

        Returns the array reference `{"offset", "count", "type", "width"}` of FORMAT.md.
        """
        data = np.ascontiguousarray(values, dtype=DTYPES[kind]).reshape(-1)
        if data.size % width:
            raise ValueError(f"array of {data.size} scalars is not a multiple of width {width}")
        pad = -self._size % ALIGN
        if pad:
            self._chunks.append(bytes(pad))
            self._size += pad
        offset = self._size
        raw = data.tobytes()
        self._chunks.append(raw)
        self._size += len(raw)
        return {"offset": offset, "count": data.size // width, "type": kind, "width": width}

    def write(self, path: Path) -> None:
        """Writes the buffer, padded to a multiple of 16 bytes."""
        with open(path, "wb") as out:
            for chunk in self._chunks:
                out.write(chunk)
            out.write(bytes(-self._size % ALIGN))
