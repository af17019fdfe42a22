"""UsdUVTexture lookups as Blender Cycles shader nodes, read as Cirrus reads them
(runs in Blender's Python; used by to_cycles.py).

Cirrus' conventions are summarised on cirrus_scene.TextureInput. In Cycles a
texture is UV Map ("st", the mesh's st as exported) -> Mapping (the st
transform: scale, rotate about Z counter-clockwise, translate, the same order
as UsdTransform2d) -> Image Texture -> channel and scale/bias nodes:

- Orientation: Blender's UV (0, 0) is the image's bottom-left corner, as USD's
  st, so st passes unchanged. Cycles' "Linear" interpolation is bilinear with
  texel centres at half-integers, without mipmaps, as Cirrus.
- Wrap: repeat = REPEAT, clamp = EXTEND, black = CLIP (zeros outside, blended
  at the edge as Cirrus does); Blender 3.4 has no mirror, and one mode for
  both axes: other textures are refused (the caller keeps the fallback).
- Colour space: raw = Non-Color, sRGB = sRGB, auto = Blender's own choice,
  which is OIIO's as Cirrus reads it (8-bit images sRGB, float ones linear).
  Cycles filters an 8-bit sRGB image before decoding it, Cirrus decodes the
  texels first, so such images are decoded here into a float copy (Blender
  holds every image as RGBA; alpha is not decoded). Images load "channel
  packed", so colour never meets alpha.
- Values: texel x scale + bias (Vector Math / Math multiply-add nodes), then
  the channel (Separate Color; a single channel becomes grey when it feeds a
  colour; `rgb` reads red for a scalar).
- Normal map: a Normal Map node in tangent space on "st", fed the texel when
  scale and bias are 1 and 0 (it applies 2 v - 1, as Cirrus then does), else
  (texel x scale + bias + 1) / 2. Its tangent is MikkTSpace's (per-vertex
  dp/du, averaged), Cirrus' the triangle's dp/du: the same on flat UV charts,
  slightly different on curved smooth meshes.
"""

import math

import bpy
import numpy as np

from cirrus_scene import shared_wrap, srgb_to_linear, stores_unit_range

#: The UV layer the meshes carry (to_cycles.py names it).
UV_LAYER = "st"
#: The format's wrap modes and Cycles' Image Texture extensions.
EXTENSIONS = {"repeat": "REPEAT", "clamp": "EXTEND", "black": "CLIP"}
#: The format's colour spaces and Blender's (None: Blender's default for the file).
COLOR_SPACES = {"raw": "Non-Color", "sRGB": "sRGB", "auto": None}


class Unrepresentable(Exception):
    """A texture that Cycles' nodes cannot reproduce; the message says why."""


class TextureNodes:
    """Builds the node chains that read textures into one material's node tree;
    images are shared through `images` ((file, colour space) -> bpy image)."""

    def __init__(self, tree, images):
        self.nodes, self.links = tree.nodes, tree.links
        self.images = images

    def output(self, tex, kind):
        """The socket giving TextureInput `tex` read as `kind` ("color", "scalar"
        or "normal": a Normal Map node's normal); raises Unrepresentable."""
        record = tex.record
        wrap = shared_wrap(record, EXTENSIONS)
        if wrap is None:
            raise Unrepresentable(f"wrap {record['wrap_s']}/{record['wrap_t']}: Cycles 3.4 has one "
                                  "of repeat, clamp (EXTEND), black (CLIP) for both axes")
        node = self.nodes.new("ShaderNodeTexImage")
        node.image = self.image(tex.file, record["color_space"])
        node.interpolation = "Linear"
        node.extension = EXTENSIONS[wrap]
        node.projection = "FLAT"
        self.links.new(self.st(record), node.inputs["Vector"])
        scale, bias = record["scale"], record["bias"]
        if kind == "normal":
            normal = self.nodes.new("ShaderNodeNormalMap")
            normal.space, normal.uv_map = "TANGENT", UV_LAYER
            colour = node.outputs["Color"]
            if not stores_unit_range(record):
                colour = self.multiply_add(colour, [s / 2 for s in scale[:3]],
                                           [(b + 1) / 2 for b in bias[:3]])
            self.links.new(colour, normal.inputs["Color"])
            return normal.outputs["Normal"]
        if tex.channel == "rgb" and kind == "color":
            return self.multiply_add(node.outputs["Color"], scale[:3], bias[:3])
        channel = "r" if tex.channel == "rgb" else tex.channel
        c = "rgba".index(channel)
        if channel == "a":
            value = node.outputs["Alpha"]
        else:
            separate = self.nodes.new("ShaderNodeSeparateColor")
            self.links.new(node.outputs["Color"], separate.inputs["Color"])
            value = separate.outputs[("Red", "Green", "Blue")[c]]
        return self.multiply_add(value, scale[c], bias[c])

    def image(self, file, color_space):
        """The image at `file` decoded as `color_space`, loaded once per space."""
        key = (str(file), color_space)
        if key not in self.images:
            image = bpy.data.images.load(str(file), check_existing=False)
            if COLOR_SPACES[color_space]:
                image.colorspace_settings.name = COLOR_SPACES[color_space]
            if not image.is_float and image.colorspace_settings.name == "sRGB":
                image = decoded_copy(image)
            image.alpha_mode = "CHANNEL_PACKED"
            self.images[key] = image
        return self.images[key]

    def st(self, record):
        """The mesh's st, through a Mapping node when the texture has an st transform."""
        uv = self.nodes.new("ShaderNodeUVMap")
        uv.uv_map = UV_LAYER
        transform = record.get("st_transform")
        if not transform:
            return uv.outputs["UV"]
        mapping = self.nodes.new("ShaderNodeMapping")
        mapping.vector_type = "POINT"
        mapping.inputs["Location"].default_value = (*transform["translation"], 0.0)
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(transform["rotation_deg"]))
        mapping.inputs["Scale"].default_value = (*transform["scale"], 1.0)
        self.links.new(uv.outputs["UV"], mapping.inputs["Vector"])
        return mapping.outputs["Vector"]

    def multiply_add(self, socket, scale, bias):
        """socket x scale + bias (a colour with per-channel lists, or a float), or
        `socket` itself when that is the identity."""
        vector = isinstance(scale, list)
        if vector:
            identity = list(scale) == [1.0] * 3 and list(bias) == [0.0] * 3
        else:
            identity = scale == 1.0 and bias == 0.0
        if identity:
            return socket
        node = self.nodes.new("ShaderNodeVectorMath" if vector else "ShaderNodeMath")
        node.operation = "MULTIPLY_ADD"
        self.links.new(socket, node.inputs[0])
        node.inputs[1].default_value = tuple(scale) if vector else scale
        node.inputs[2].default_value = tuple(bias) if vector else bias
        return node.outputs[0]


def decoded_copy(image):
    """A float copy of an 8-bit sRGB image, decoded as Cirrus decodes it, tagged
    Non-Color: Cycles filters 8-bit sRGB images before decoding them, Cirrus
    decodes the texels first, which differs wherever filtering blends texels."""
    w, h = image.size
    if image.channels != 4:
        raise Unrepresentable(f"{image.filepath}: Blender read {image.channels} channels, not RGBA")
    pixels = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(-1, 4)
    pixels[:, :3] = srgb_to_linear(pixels[:, :3])
    copy = bpy.data.images.new(f"{image.name} (linear)", w, h, alpha=True, float_buffer=True)
    copy.colorspace_settings.name = "Non-Color"
    copy.pixels.foreach_set(pixels.ravel())
    bpy.data.images.remove(image)
    return copy
