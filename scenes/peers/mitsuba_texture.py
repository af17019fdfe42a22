"""UsdUVTexture lookups as Mitsuba 3 `bitmap` textures, read as Cirrus reads them.

Cirrus (src/materials/texture.rs, summarised on cirrus_scene.TextureInput) and
Mitsuba's `bitmap` share bilinear filtering with texel centres at half-integers
and no mipmaps; they differ in three ways, bridged here:

- Orientation: Mitsuba's uv (0, 0) is the image's top-left corner (v runs down
  the rows), USD's st (0, 0) its bottom-left, so every bitmap's `to_uv` is
  FLIP_T x the texture's st transform; the PLY files keep USD's st, so dp/du
  (the normal map's tangent) is the same in both renderers.
- Wrap: Mitsuba has one mode for both axes and no `black`: textures with
  different modes per axis or `black` are refused (the caller keeps the
  fallback and warns).
- Values: Mitsuba reads an image's channels as they are (raw) or sRGB-decodes
  an 8-bit one; it has no scale, bias or channel selection, and its eval_1 of
  an RGB image is the luminance, not r. So the image is used directly only
  when Cirrus would read exactly what Mitsuba reads (three channels for a
  colour or normal, one for a scalar, scale 1 and bias 0, sRGB decoding
  where Mitsuba does it); otherwise the values Cirrus filters (decoded, x scale
  + bias, the channel picked; for a normal map re-encoded as (n + 1) / 2, which
  Mitsuba's `normalmap` undoes) are baked into a float EXR in the work folder,
  filtered bilinearly by Mitsuba as Cirrus filters the original: the same
  thing, since bilinear weights sum to 1 and the maps are affine. Only `black`
  wrapping (zeros outside, then bias) would break that, and it is refused.
"""

import numpy as np

from cirrus_scene import shared_wrap, srgb_to_linear, st_from_uv, stores_unit_range

#: Mitsuba's uv from USD's st: (s, t) -> (s, 1 - t), on homogeneous 2D points.
FLIP_T = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])
#: Wrap modes Mitsuba's `bitmap` has, by the format's names (the same meaning).
WRAPS = ("repeat", "mirror", "clamp")


class Unrepresentable(Exception):
    """A texture that a `bitmap` cannot reproduce; the message says why."""


class Bitmaps:
    """Builds `bitmap` texture dicts for TextureInputs, baking images only when needed.

    `workdir` receives the baked EXRs; `mi` is the mitsuba module (variant set)."""

    def __init__(self, workdir, mi):
        self.workdir = workdir
        self.mi = mi
        #: (texture index, channel, kind) -> its bitmap dict.
        self.built = {}
        #: Image path -> the loaded mi.Bitmap (one file often feeds several inputs).
        self.images = {}

    def bitmap(self, tex, kind):
        """The `bitmap` dict for TextureInput `tex` read as `kind`: "color" (three
        channels), "scalar" or "normal" (a `normalmap`'s texture); raises
        Unrepresentable when Mitsuba cannot read it as Cirrus does."""
        key = (tex.index, tex.channel, kind)
        if key not in self.built:
            self.built[key] = self.build(tex, kind)
        return self.built[key]

    def build(self, tex, kind):
        """See `bitmap`."""
        record = tex.record
        wrap = shared_wrap(record, WRAPS)
        if wrap is None:
            raise Unrepresentable(f"wrap {record['wrap_s']}/{record['wrap_t']}: Mitsuba's bitmap has "
                                  "one of repeat, mirror, clamp for both axes")
        image = self.image(tex.file)
        tagged_srgb = image.srgb_gamma()
        decode = {"auto": tagged_srgb, "sRGB": True, "raw": False}[record["color_space"]]
        channels = image.channel_count()
        direct = (decode == tagged_srgb and stores_unit_range(record) and (
            (kind in ("color", "normal") and tex.channel == "rgb" and channels == 3)
            or (kind == "scalar" and tex.channel in ("rgb", "r") and channels == 1)))
        if direct:
            filename, raw = str(tex.file), not decode
        else:
            filename, raw = self.bake(tex, kind, image, decode), True
        to_uv = FLIP_T @ st_from_uv(record)
        return {"type": "bitmap", "filename": filename, "raw": raw, "filter_type": "bilinear",
                "wrap_mode": wrap, "to_uv": self.mi.ScalarTransform3f(to_uv.tolist())}

    def image(self, file):
        """The image at `file`, loaded once."""
        if file not in self.images:
            self.images[file] = self.mi.Bitmap(str(file))
        return self.images[file]

    def bake(self, tex, kind, image, decode):
        """Writes what Cirrus filters for `tex` read as `kind` to a float EXR; returns its path."""
        rgba = stored_rgba(self.mi, image)
        if decode:
            rgba[..., :3] = srgb_to_linear(rgba[..., :3])
        record = tex.record
        value = rgba * np.asarray(record["scale"], np.float32) + np.asarray(record["bias"], np.float32)
        if kind == "normal":
            # texture.rs: 2 v - 1 when scale and bias leave [0, 1], else the value is the normal.
            out = value[..., :3] if stores_unit_range(record) else (value[..., :3] + 1.0) / 2.0
        elif tex.channel == "rgb":
            out = value[..., :3] if kind == "color" else value[..., :1]
        else:
            picked = value[..., "rgba".index(tex.channel)][..., None]
            out = np.repeat(picked, 3, axis=-1) if kind == "color" else picked
        path = self.workdir / f"texture{tex.index}_{tex.channel}_{kind}.exr"
        self.mi.Bitmap(np.ascontiguousarray(out, dtype=np.float32)).write(str(path))
        return str(path)


def stored_rgba(mi, image):
    """An image's stored values (no decoding) as float32 (H, W, 4) rgba, as
    texture.rs reads them: one channel is grey, two are grey + alpha, a missing
    alpha is 1."""
    raw = mi.Bitmap(image)
    raw.set_srgb_gamma(False)
    values = np.array(raw.convert(component_format=mi.Struct.Type.Float32), dtype=np.float32)
    if values.ndim == 2:
        values = values[..., None]
    h, w, n = values.shape
    rgba = np.ones((h, w, 4), dtype=np.float32)
    if n <= 2:
        rgba[..., :3] = values[..., :1]
        if n == 2:
            rgba[..., 3] = values[..., 1]
    else:
        rgba[..., :min(n, 4)] = values[..., :4]
    return rgba
