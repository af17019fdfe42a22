"""Shader node graphs resolved into the scene format's inputs (exporter/FORMAT.md, "Input
grammar"): constants, textures, primvars and per-hit ops.

Nodes are MaterialX nodes (from a .mtlx document, or written in USD with an `ND_*` info:id)
and UsdPreviewSurface's own nodes (UsdUVTexture, UsdPrimvarReader_*), seen through the small
`Node` interface that mtlx.py and usd_nodes.py implement. The meaning of each node is the
MaterialX 1.39 Standard Nodes specification's; whatever only has constant arguments is folded
here, so the renderer sees a constant. `multiply`, `add`, `subtract` and `mix` with an argument
that varies per hit become contract `op` inputs; any other node (or a cycle) gets one warning
naming the material, node and input, and the input's default.
"""

from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

# A constant as JSON: a number, a list of numbers, a string or a bool.
Value = float | list | str | bool
RGBA = "rgba"
# MaterialX address modes -> scene texture wrap modes.
ADDRESS_MODES = {"periodic": "repeat", "clamp": "clamp", "mirror": "mirror", "constant": "constant"}
# MaterialX colour spaces -> scene colour spaces; "" means the document's working space (linear).
COLOR_SPACES = {"srgb_texture": "sRGB", "lin_rec709": "raw", "raw": "raw", "": "raw"}
# Contract ops, evaluated per hit when an argument varies; folded here otherwise.
OPS = {"multiply": ("in1", "in2"), "add": ("in1", "in2"), "subtract": ("in1", "in2"),
       "mix": ("fg", "bg", "mix")}
# Conditionals of MaterialX's stdlib: in1 when the comparison holds, else in2.
CONDITIONS = {"ifgreater": np.greater, "ifgreatereq": np.greater_equal, "ifequal": np.equal}
# Folded only: a varying argument is not expressible in the scene format.
FOLD_ONLY = {"divide": ("in1", "in2"), "power": ("in1", "in2"), "dotproduct": ("in1", "in2"),
             "max": ("in1", "in2"), "min": ("in1", "in2")}
PASS_THROUGH = {"dot", "convert"}
WIDTHS = {"float": 1, "integer": 1, "vector2": 2, "color3": 3, "vector3": 3, "color4": 4, "vector4": 4}


@dataclass(frozen=True)
class Link:
    """An input connected to output `output` of `node`."""

    node: "Node"
    output: str


class Node(Protocol):
    """One shader node, wherever it was written."""

    path: str  # for warnings: a USD prim path or `document.mtlx:node`
    category: str  # MaterialX node category ("image", "multiply") or a USD shader id ("UsdUVTexture")
    type: str  # the output's MaterialX type ("color3", "float", ...)

    def source(self, name: str) -> "Link | Value | None":
        """What drives input `name`: a link, a constant, or None when unauthored."""

    def default(self, name: str) -> Value | None:
        """Input `name`'s default from the node's definition, if known."""

    def file(self, name: str) -> tuple[str, bool] | None:
        """(absolute path, exists) of a filename input, None when unauthored."""

    def color_space(self, name: str) -> str:
        """The colour space a filename input is read in ("" when unsaid)."""


class Unsupported(Exception):
    """A node (or cycle) the scene format cannot express; carries the node for the warning."""

    def __init__(self, node: Node, why: str) -> None:
        super().__init__(why)
        self.node = node


def _json(value: np.ndarray) -> float | list[float]:
    """A folded numpy value as JSON: a number for a scalar, else a list."""
    return float(value) if value.ndim == 0 else [float(v) for v in value]


def _varies(value) -> bool:
    """True for a texture, primvar or op input (a dict), False for a constant."""
    return isinstance(value, dict)


def _is(value, constant: float) -> bool:
    """True when `value` is a constant equal to `constant` in every component."""
    return not _varies(value) and not isinstance(value, str) and bool(np.all(np.asarray(value) == constant))


def _rgba(value) -> list[float]:
    """A constant as a texture fallback: a scalar splatted to rgb, alpha 1 unless given."""
    v = np.atleast_1d(np.asarray(value, dtype=np.float64)).tolist()
    rgb = v * 3 if len(v) == 1 else (v + [0.0, 0.0])[:3]
    return rgb + [v[3] if len(v) == 4 else 1.0]


class GraphResolver:
    """Resolves one material's inputs; `textures` stores texture records and notes UV sets."""

    def __init__(self, material: str, textures: "TextureSink", warn: Callable[[str], None]) -> None:
        self._material = material
        self._textures = textures
        self._warn = warn
        self._visiting: list[tuple[str, str]] = []

    def input(self, node: Node, name: str, default: Value | None) -> Value | dict | None:
        """Input `name` of `node` as a scene input; the default (the node definition's, else
        `default`) with one warning when its graph cannot be expressed."""
        fallback = node.default(name)
        fallback = default if fallback is None else fallback
        try:
            value = self._source(node, name)
        except Unsupported as bad:
            self._warn(f"material {self._material}: input {name} of {node.path} is driven by "
                       f"{bad.node.path} ({bad.node.category}): {bad}; the input's default is used")
            return fallback
        return fallback if value is None else value

    def normal_map(self, node: Node, name: str) -> dict | None:
        """A `normalmap` node over an image on input `name` as `{"texture", "channel", "scale"}`
        (FORMAT.md geometry_normal), else None; anything else driving it is warned about."""
        found = node.source(name)
        if not isinstance(found, Link):
            return None
        if found.node.category != "normalmap":
            self._warn(f"material {self._material}: input {name} of {node.path} is driven by "
                       f"{found.node.path} ({found.node.category}), not a normalmap; no normal map used")
            return None
        texture = self.input(found.node, "in", None)
        if not isinstance(texture, dict) or "texture" not in texture:
            return None
        scale = self.input(found.node, "scale", 1.0)
        return {"texture": texture["texture"], "channel": "rgb", "scale": scale if isinstance(scale, float) else 1.0}

    def _source(self, node: Node, name: str):
        """Input `name` resolved, or None when unauthored."""
        found = node.source(name)
        if not isinstance(found, Link):
            return found
        key = (found.node.path, found.output)
        if key in self._visiting:
            raise Unsupported(found.node, "a cycle")
        self._visiting.append(key)
        try:
            return self._node(found.node, found.output)
        finally:
            self._visiting.pop()

    def _arg(self, node: Node, name: str):
        """An argument of `node`: its source, else its definition's default."""
        value = self._optional(node, name)
        if value is None:
            raise Unsupported(node, f"no value for its input {name}")
        return value

    def _optional(self, node: Node, name: str):
        """An argument of `node` that may be absent everywhere (None then)."""
        value = self._source(node, name)
        return node.default(name) if value is None else value

    def _node(self, node: Node, output: str):
        """The value of one node's output."""
        category = node.category
        if category in PASS_THROUGH:
            return self._arg(node, "in")
        if category == "constant":
            return self._arg(node, "value")
        if category in OPS:
            return self._op(node, category, [self._arg(node, a) for a in OPS[category]])
        if category in CONDITIONS:
            return self._condition(node, category)
        if category in FOLD_ONLY:
            return self._fold(node, category, [self._arg(node, a) for a in FOLD_ONLY[category]])
        if category == "extract":
            return self._extract(node, self._arg(node, "in"), int(self._arg(node, "index")))
        if category == "swizzle":
            return self._swizzle(node)
        if category in ("image", "tiledimage"):
            return self._image(node)
        if category == "geompropvalue":
            return self._primvar(node, str(self._arg(node, "geomprop")), self._optional(node, "default"))
        # UsdPrimvarReader_<type> in UsdPreviewSurface networks; UsdPrimvarReader (node
        # definitions ND_UsdPrimvarReader_<type>) in MaterialX networks written in USD.
        if category.startswith("UsdPrimvarReader"):
            return self._primvar(node, str(self._arg(node, "varname")), self._optional(node, "fallback"))
        if category == "UsdUVTexture":
            return {"texture": self._textures.usd_texture(node), "channel": output}
        raise Unsupported(node, "a node the scene format cannot express")

    def _op(self, node: Node, category: str, args: list):
        """A contract op, folded when every argument is constant or an identity applies."""
        if not any(_varies(a) for a in args):
            return self._fold(node, category, args)
        if category == "multiply" and any(_is(a, 0.0) for a in args):
            return 0.0
        if category in ("multiply", "add", "subtract"):
            identity = 1.0 if category == "multiply" else 0.0
            rest = [a for i, a in enumerate(args) if not (_is(a, identity) and (i == 1 or category != "subtract"))]
            if len(rest) == 1:
                return rest[0]
        if category == "mix" and (_is(args[2], 0.0) or _is(args[2], 1.0)):
            return args[0] if _is(args[2], 1.0) else args[1]
        return {"op": category, "args": args}

    @staticmethod
    def _fold(node: Node, category: str, args: list) -> float | list[float]:
        """Constant arguments evaluated as MaterialX defines each node (componentwise, scalars
        broadcast)."""
        if any(_varies(a) for a in args):
            raise Unsupported(node, f"a {category} of per-hit values")
        a = [np.asarray(v, dtype=np.float64) for v in args]
        result = {"multiply": lambda: a[0] * a[1], "add": lambda: a[0] + a[1],
                  "subtract": lambda: a[0] - a[1], "mix": lambda: a[0] * a[2] + a[1] * (1.0 - a[2]),
                  "divide": lambda: a[0] / np.where(a[1] == 0.0, 1.0, a[1]),
                  "power": lambda: np.power(a[0], a[1]), "dotproduct": lambda: np.dot(a[0], a[1]),
                  "max": lambda: np.maximum(a[0], a[1]), "min": lambda: np.minimum(a[0], a[1])}[category]()
        return _json(result)

    def _condition(self, node: Node, category: str):
        """ifgreater / ifgreatereq / ifequal: in1 when value1 compares true to value2, else in2;
        a per-hit comparison is expressible only when both branches agree."""
        value1, value2 = self._arg(node, "value1"), self._arg(node, "value2")
        in1, in2 = self._arg(node, "in1"), self._arg(node, "in2")
        if _varies(value1) or _varies(value2):
            if in1 == in2:
                return in1
            raise Unsupported(node, "a comparison of per-hit values")
        return in1 if bool(CONDITIONS[category](float(np.asarray(value1)), float(np.asarray(value2)))) else in2

    @staticmethod
    def _extract(node: Node, value, index: int):
        """One component of a constant, texture or primvar."""
        if not _varies(value):
            return float(np.atleast_1d(np.asarray(value, dtype=np.float64))[index])
        if "op" in value or value["channel"] != "rgb" or not 0 <= index <= 3:
            raise Unsupported(node, f"component {index} of a per-hit {value.get('op', 'value')}")
        return {**value, "channel": RGBA[index]}

    def _swizzle(self, node: Node):
        """MaterialX 1.38 swizzle: one channel is an extract, an identity is a pass-through."""
        channels = str(self._arg(node, "channels"))
        value = self._arg(node, "in")
        if channels in ("rgb", "xyz", "rgba", "xyzw"):
            return value
        if len(channels) == 1 and channels in "rgbaxyzw":
            return self._extract(node, value, "rgbaxyzw".index(channels) % 4)
        raise Unsupported(node, f"swizzle {channels!r}")

    def _primvar(self, node: Node, name: str, fallback) -> dict:
        """A primvar input (geompropvalue, UsdPrimvarReader_*) with its reader's fallback."""
        width = WIDTHS.get(node.type, 3)
        if width == 2:
            raise Unsupported(node, "a 2-component primvar outside a texture's coordinates")
        self._textures.note_primvar(name)
        fallback = 0.0 if fallback is None else fallback
        return {"primvar": name, "channel": "r" if width == 1 else "rgb", "fallback": fallback}

    def _image(self, node: Node):
        """A MaterialX image / tiledimage as a texture input; no file gives the node's
        `default`, and a missing file too, with one warning."""
        default = self._optional(node, "default")
        default = 0.0 if default is None else default
        found = node.file("file")
        if found is None:  # no file authored: the default, as asked
            return default
        if not found[1]:
            self._warn(f"material {self._material}: image file {found[0]} of {node.path} is "
                       f"missing; its default {default} is used")
            return default
        width = WIDTHS.get(node.type, 3)
        space = node.color_space("file")
        if space not in COLOR_SPACES:
            self._warn(f"material {self._material}: colour space {space!r} of {node.path} is not "
                       f"srgb_texture, lin_rec709 or raw; read as raw")
        record = {
            "file": found[0],
            "wrap_s": ADDRESS_MODES.get(str(node.source("uaddressmode") or "periodic"), "repeat"),
            "wrap_t": ADDRESS_MODES.get(str(node.source("vaddressmode") or "periodic"), "repeat"),
            "scale": [1.0, 1.0, 1.0, 1.0], "bias": [0.0, 0.0, 0.0, 0.0], "fallback": _rgba(default),
            "color_space": COLOR_SPACES.get(space, "raw"),
            "st_transform": self._tiling(node) if node.category == "tiledimage" else None,
        }
        self._textures.note_uv(self._uv_set(node))
        return {"texture": self._textures.add(record), "channel": "r" if width == 1 else "rgb"}

    def _tiling(self, node: Node) -> dict:
        """tiledimage's uv = (texcoord * uvtiling - uvoffset) / realworldimagesize *
        realworldtilesize (stdlib NG_tiledimage) as a UsdTransform2d-style st_transform."""
        values = [np.asarray(self._arg(node, n), dtype=np.float64) for n in
                  ("uvtiling", "uvoffset", "realworldimagesize", "realworldtilesize")]
        tiling, offset, image_size, tile_size = values
        ratio = tile_size / np.where(image_size == 0.0, 1.0, image_size)
        return {"translation": _json(-offset * ratio), "rotation_deg": 0.0, "scale": _json(tiling * ratio)}

    def _uv_set(self, node: Node) -> str:
        """The primvar an image reads as texture coordinates: a `geompropvalue`'s geomprop,
        else "st" (texcoord index 0, as usdMtlx and Hydra read it)."""
        found = node.source("texcoord")
        if not isinstance(found, Link):
            return "st"
        reader = found.node
        if reader.category == "geompropvalue":
            return str(self._arg(reader, "geomprop"))
        if reader.category == "texcoord" and int(reader.source("index") or 0) == 0:
            return "st"
        raise Unsupported(reader, "texture coordinates other than texcoord index 0 or a geompropvalue")


class TextureSink(Protocol):
    """Where the resolver stores textures and notes what meshes must carry."""

    def add(self, record: dict) -> int:
        """The index of a texture record, stored once."""

    def usd_texture(self, node: Node) -> int:
        """The index of a UsdUVTexture node's record."""

    def note_uv(self, name: str) -> None:
        """The primvar the material's textures read as st."""

    def note_primvar(self, name: str) -> None:
        """A primvar the material reads."""
