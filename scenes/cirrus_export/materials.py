"""UsdPreviewSurface materials and their UsdUVTexture / UsdTransform2d networks.

Anything that is not a UsdPreviewSurface reachable from the universal surface output
(MaterialX-only, glslfx) becomes a grey fallback material with one warning naming it.
"""

from pxr import Usd, UsdShade

from .assets import AssetResolver
from .report import Report

NO_MATERIAL = 0xFFFFFFFF
FALLBACK_GREY = [0.18, 0.18, 0.18]

# Manifest key, USD input, UsdPreviewSurface default; a list default means a colour.
SURFACE_INPUTS = [
    ("diffuse_color", "diffuseColor", FALLBACK_GREY),
    ("emissive_color", "emissiveColor", [0.0, 0.0, 0.0]),
    ("metallic", "metallic", 0.0),
    ("roughness", "roughness", 0.5),
    ("specular_color", "specularColor", [0.0, 0.0, 0.0]),
    ("opacity", "opacity", 1.0),
]
CONSTANT_INPUTS = [
    ("ior", "ior", 1.5),
    ("clearcoat", "clearcoat", 0.0),
    ("clearcoat_roughness", "clearcoatRoughness", 0.01),
]
COLOR_SPACES = {"auto", "sRGB", "raw"}
WRAP_MODES = {"repeat": "repeat", "clamp": "clamp", "mirror": "mirror", "black": "black",
              "useMetadata": "repeat"}


def _shader_id(shader: UsdShade.Shader) -> str:
    """The shader's info:id, or "" for sourceAsset/sourceCode shaders."""
    return str(shader.GetIdAttr().Get() or "")


def _upstream(inp: UsdShade.Input) -> tuple[UsdShade.Shader, str] | None:
    """The shader and output an input finally reads from, through Material interface inputs."""
    if not inp:
        return None
    attrs = inp.GetValueProducingAttributes()
    if not attrs or not UsdShade.Output.IsOutput(attrs[0]):
        return None
    return UsdShade.Shader(attrs[0].GetPrim()), UsdShade.Output(attrs[0]).GetBaseName()


def _as_json(value) -> float | list[float] | str:
    """A Gf vector, scalar or token as JSON."""
    if isinstance(value, str):
        return value
    try:
        return [float(v) for v in value]
    except TypeError:
        return float(value)


def _input_value(shader: UsdShade.Shader, name: str, default):
    """An input's constant value, following interface connections to the Material."""
    inp = shader.GetInput(name)
    if not inp:
        return default
    attrs = inp.GetValueProducingAttributes()
    value = attrs[0].Get() if attrs and UsdShade.Input.IsInput(attrs[0]) else None
    return default if value is None else _as_json(value)


class MaterialTable:
    """Materials and textures of the manifest, each USD material and texture stored once."""

    def __init__(self, resolver: AssetResolver, report: Report, time: Usd.TimeCode) -> None:
        self.materials: list[dict] = []
        self.textures: list[dict] = []
        self._by_path: dict[str, int] = {}
        self._texture_keys: dict[str, int] = {}
        self._uv_names: dict[int, str] = {}
        self._resolver = resolver
        self._report = report
        self._time = time

    def bound_index(self, prim: Usd.Prim) -> int:
        """Material index bound to `prim` (preview purpose, then full), or NO_MATERIAL."""
        api = UsdShade.MaterialBindingAPI(prim)
        broken = None
        for purpose in (UsdShade.Tokens.preview, UsdShade.Tokens.full):
            material, relationship = api.ComputeBoundMaterial(purpose)
            if material:
                return self.index(material)
            if relationship and broken is None:
                broken = str(relationship.GetTargets()[0])
        return NO_MATERIAL if broken is None else self._unloadable(broken)

    def _unloadable(self, path: str) -> int:
        """A fallback record for a bound material that does not compose (e.g. a .mtlx
        reference, which usd-core cannot read), warned about once."""
        if path not in self._by_path:
            self._report.warn(f"material {path}: bound but not a loadable Material (missing layer, or "
                              f"MaterialX-only); using the grey fallback")
            self._by_path[path] = len(self.materials)
            self.materials.append(self._fallback(path))
        return self._by_path[path]

    def uv_primvar(self, index: int) -> str:
        """The primvar a material's textures read as st (UsdPrimvarReader_float2 varname), default "st"."""
        return self._uv_names.get(index, "st")

    def index(self, material: UsdShade.Material) -> int:
        """The manifest index of a material, reading it the first time.

        A material inside an instance is keyed by its path in the prototype, so every
        instance of an asset shares one record.
        """
        prim = material.GetPrim()
        path = str(prim.GetPrimInPrototype().GetPath() if prim.IsInstanceProxy() else prim.GetPath())
        if path not in self._by_path:
            self._by_path[path] = len(self.materials)
            self.materials.append(self._read(material, path))
        return self._by_path[path]

    def _read(self, material: UsdShade.Material, path: str) -> dict:
        """One material record, or the grey fallback with a warning."""
        shader, _, _ = material.ComputeSurfaceSource()
        if not shader or _shader_id(shader) != "UsdPreviewSurface":
            what = _shader_id(shader) if shader else "no universal surface output"
            self._report.warn(f"material {path}: not a UsdPreviewSurface ({what or 'sourceAsset shader'});"
                              f" using the grey fallback")
            return self._fallback(path)
        record = {"path": path, "fallback": False}
        for key, name, default in SURFACE_INPUTS:
            record[key] = self._texture_or_value(shader, name, default, path)
        record["use_specular_workflow"] = bool(_input_value(shader, "useSpecularWorkflow", 0.0))
        for key, name, default in CONSTANT_INPUTS:
            record[key] = _input_value(shader, name, default)
        normal = self._texture_or_value(shader, "normal", None, path)
        record["normal"] = normal if isinstance(normal, dict) else None  # only a normal map counts
        return record

    @staticmethod
    def _fallback(path: str) -> dict:
        """The stand-in for a material we cannot read: UsdPreviewSurface's defaults (a grey 0.18 plastic)."""
        record = {"path": path, "fallback": True}
        for key, _, default in SURFACE_INPUTS:
            record[key] = default
        record["use_specular_workflow"] = False
        for key, _, default in CONSTANT_INPUTS:
            record[key] = default
        record["normal"] = None
        return record

    def _texture_or_value(self, shader: UsdShade.Shader, name: str, default, path: str):
        """A UsdUVTexture reference `{"texture", "channel"}` or the input's constant."""
        found = _upstream(shader.GetInput(name))
        if found is None or _shader_id(found[0]) != "UsdUVTexture":
            if found is not None:
                self._report.warn(f"material {path}: {name} is driven by "
                                  f"{_shader_id(found[0]) or found[0].GetPath()}, not read; constant used")
            return _input_value(shader, name, default)
        texture, channel = found
        self._note_uv_primvar(texture)
        return {"texture": self._texture_index(texture, path), "channel": channel}

    def _note_uv_primvar(self, texture: UsdShade.Shader) -> None:
        """Remembers the varname of the UsdPrimvarReader_float2 feeding a texture's st."""
        reader = _upstream(texture.GetInput("st"))
        if reader is not None and _shader_id(reader[0]) == "UsdTransform2d":
            reader = _upstream(reader[0].GetInput("in"))
        if reader is not None and _shader_id(reader[0]) == "UsdPrimvarReader_float2":
            self._uv_names.setdefault(len(self.materials), str(_input_value(reader[0], "varname", "st")))

    def _texture_index(self, texture: UsdShade.Shader, material_path: str) -> int:
        """The manifest index of a UsdUVTexture, stored once per distinct record."""
        attrs = texture.GetInput("file").GetValueProducingAttributes()
        resolved = self._resolver.resolve(attrs[0], self._time) if attrs else None
        file, exists = resolved if resolved else ("", False)
        if not exists:
            self._report.warn(f"material {material_path}: texture file {file or '(none)'} of "
                              f"{texture.GetPath()} is missing; its fallback value is used")
        record = {
            "file": file,
            "wrap_s": WRAP_MODES.get(_input_value(texture, "wrapS", "useMetadata"), "repeat"),
            "wrap_t": WRAP_MODES.get(_input_value(texture, "wrapT", "useMetadata"), "repeat"),
            "scale": _input_value(texture, "scale", [1.0, 1.0, 1.0, 1.0]),
            "bias": _input_value(texture, "bias", [0.0, 0.0, 0.0, 0.0]),
            "fallback": _input_value(texture, "fallback", [0.0, 0.0, 0.0, 1.0]),
            "color_space": self._color_space(texture, material_path),
            "st_transform": self._st_transform(texture),
        }
        key = repr(sorted(record.items()))
        if key not in self._texture_keys:
            self._texture_keys[key] = len(self.textures)
            self.textures.append(record)
        return self._texture_keys[key]

    def _color_space(self, texture: UsdShade.Shader, material_path: str) -> str:
        """sourceColorSpace as auto | sRGB | raw; anything else is warned about and read as auto."""
        space = _input_value(texture, "sourceColorSpace", "auto")
        if space not in COLOR_SPACES:
            self._report.warn(f"material {material_path}: sourceColorSpace {space!r} of "
                              f"{texture.GetPath()} is not auto, sRGB or raw; auto used")
            return "auto"
        return space

    def _st_transform(self, texture: UsdShade.Shader) -> dict | None:
        """The UsdTransform2d between the texture and its primvar reader, if any."""
        found = _upstream(texture.GetInput("st"))
        if found is None or _shader_id(found[0]) != "UsdTransform2d":
            return None
        xform = found[0]
        return {"translation": _input_value(xform, "translation", [0.0, 0.0]),
                "rotation_deg": _input_value(xform, "rotation", 0.0),
                "scale": _input_value(xform, "scale", [1.0, 1.0])}
