"""Independent EXR reader for the tests: the `OpenEXR` Python package, not OIIO.

usage: read_exr.py FILE.exr
Prints JSON: {"width", "height", "compression", "channels": {name: {"type", "values"}},
"strings": {name: value}, "matrices": {name: [16 floats, row-major]}}.
Values are row-major (row 0 at the top), as float.
"""
import json
import sys

import numpy as np
import OpenEXR


def describe(path: str) -> dict:
    """Everything the tests compare, read through the OpenEXR bindings."""
    with OpenEXR.File(path, separate_channels=True) as exr:
        header = dict(exr.header())  # a live view: copy before the file closes
        channels = {
            name: {
                "type": {np.float16: "half", np.float32: "float", np.uint32: "uint"}[ch.pixels.dtype.type],
                "values": ch.pixels.astype(np.float64).ravel().tolist(),
            }
            for name, ch in exr.channels().items()
        }
    lo, hi = header["dataWindow"]
    strings = {k: v for k, v in header.items() if isinstance(v, str)}
    matrices = {
        k: np.asarray(v, dtype=np.float64).ravel().tolist()
        for k, v in header.items()
        if isinstance(v, np.ndarray) and v.shape == (4, 4)
    }
    return {
        "width": int(hi[0] - lo[0] + 1),
        "height": int(hi[1] - lo[1] + 1),
        "compression": header["compression"].name,
        "channels": channels,
        "strings": strings,
        "matrices": matrices,
    }


if __name__ == "__main__":
    json.dump(describe(sys.argv[1]), sys.stdout)
