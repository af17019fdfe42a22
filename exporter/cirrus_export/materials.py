"""Material records: UsdPreviewSurface (model preview_surface) and OpenPBR / Standard Surface
(model open_pbr), read from USD shading networks and from MaterialX documents.

The richest look a material offers is read: its `mtlx` render-context surface output (an
`ND_open_pbr_surface_surfaceshader`, `ND_standard_surface_surfaceshader` or
`ND_UsdPreviewSurface_surfaceshader`), else its universal one (UsdPreviewSurface). A richer look
skipped for a simpler one is listed in the record's `skipped` and warned about once; a material
with nothing readable becomes a grey fallback with one warning naming it. Bindings into a
`.mtlx` document referenced as a layer are read through mtlx.py. Inputs go through node_graph.
"""

from pxr import Usd, UsdGeom, UsdShade

from .assets import AssetResolver
from .geometry_lights import light_material
from .mtlx import MtlxDocuments
from .node_graph import GraphResolver, Link, Node
from .openpbr import open_pbr_record
from .prims import prototype_path
from .report import Report
from .usd_nodes import UsdNode, input_value, shader_id, upstream

NO_MATERIAL = 0xFFFFFFFF
FALLBACK_GREY = [0.18, 0.18, 0.18]
# The display primvars of a gprim with no bound material: primvar, record key, width.
DISPLAY_INPUTS = (("displayColor", "diffuse_color", 3), ("displayOpacity", "opacity", 1))

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


# Surface nodes read, by MaterialX category (or UsdPreviewSurface's info:id).
PREVIEW = "UsdPreviewSurface"
OPEN_PBR = {"open_pbr_surface", "standard_surface"}


def binding_purpose(relationship: Usd.Relationship) -> str:
    """The material purpose of a binding relationship, "" for allPurpose: its name is
    `material:binding[:purpose]` or `material:binding:collection[:purpose]:name`
    (UsdShadeMaterialBindingAPI)."""
    parts = relationship.GetName().split(":")[2:]
    if parts[:1] == ["collection"]:
        parts = parts[1:-1]
    return parts[0] if parts else ""


class MaterialTable:
    """Materials and textures of the manifest, each USD material and texture stored once."""

    def __init__(self, resolver: AssetResolver, mtlx: MtlxDocuments, report: Report, time: Usd.TimeCode,
                 purposes: tuple[str, ...]) -> None:
        """`purposes`: the material purposes bindings are resolved for, in order of preference
        ("" is allPurpose; render_settings.material_binding_purposes)."""
        self._purposes = purposes
        self.materials: list[dict] = []
        self.textures: list[dict] = []
        self._by_path: dict[str, int] = {}
        self._texture_keys: dict[str, int] = {}
        self._uv_names: dict[int, str] = {}
        self._primvars: dict[int, set[str]] = {}
        # Records whose primvar inputs fall back to the unbound look silently.
        self.silent: set[int] = set()
        self._resolver, self._mtlx, self._report, self._time = resolver, mtlx, report, time

    def bound_index(self, prim: Usd.Prim) -> int:
        """Material index bound to `prim` for the first purpose of `purposes` that binds one,
        or NO_MATERIAL. usd-core resolves each purpose (ComputeBoundMaterial: inheritance,
        strengths, collections); its fallback to an allPurpose binding counts only as the ""
        entry, so `full, preview, ""` prefers any full binding to a nearer allPurpose one."""
        api = UsdShade.MaterialBindingAPI(prim)
        broken = None
        for purpose in self._purposes:
            material, relationship = api.ComputeBoundMaterial(purpose)
            if not relationship or binding_purpose(relationship) != purpose:
                continue
            if material:
                return self.index(material)
            if broken is None:
                broken = str(relationship.GetTargets()[0])
        return NO_MATERIAL if broken is None else self._unloadable(broken)

    def _unloadable(self, path: str) -> int:
        """A bound material that does not compose: a surfacematerial of a .mtlx document
        referenced as a layer (which usd-core cannot compose), else a grey fallback warned
        about once."""
        if path not in self._by_path:
            index = self._by_path[path] = len(self.materials)
            self.materials.append(None)
            found = self._mtlx.material(path)
            if found is not None and found[0] is not None:
                shader = found[0].source("surfaceshader")
                self.materials[index] = self._record(path, shader.node if isinstance(shader, Link) else None,
                                                     "mtlx:", [])
            else:
                why = "missing layer, or MaterialX-only" if found is None else \
                    f"from {found[1]}, which is unusable or has no surfacematerial of that name"
                self._report.warn(f"material {path}: bound but not a loadable Material ({why}); "
                                  f"using the grey fallback")
                self.materials[index] = self._fallback(path)
        return self._by_path[path]

    def uv_primvar(self, index: int) -> str:
        """The primvar a material's textures read as st (UsdPrimvarReader_float2 varname), default "st"."""
        return self._uv_names.get(index, "st")

    def primvars(self, index: int) -> set[str]:
        """The primvars a material reads (primvar inputs), which its meshes must carry."""
        return self._primvars.get(index, set())

    def index(self, material: UsdShade.Material) -> int:
        """The manifest index of a material, reading it the first time.

        A material inside an instance is keyed by its path in the prototype, so every
        instance of an asset shares one record; its `name` (CryptoMaterial's) is its path as
        seen through the first instance met, stable where `/__Prototype_N` is not.
        """
        prim = material.GetPrim()
        path = str(prim.GetPrimInPrototype().GetPath() if prim.IsInstanceProxy() else prim.GetPath())
        if path not in self._by_path:
            self._by_path[path] = len(self.materials)
            self.materials.append(None)
            record = self._read(material, path)
            if prim.IsInstanceProxy():
                record["name"] = str(prim.GetPath())
            self.materials[self._by_path[path]] = record
        return self._by_path[path]

    def display_color(self, prim: Usd.Prim) -> int:
        """For a gprim with no bound material: a preview_surface record from its displayColor /
        displayOpacity, as Hydra's fallback material reads them; NO_MATERIAL when neither is
        authored. Per mesh (its path + `.displayColor`)."""
        api = UsdGeom.PrimvarsAPI(prim)
        found = {name: api.FindPrimvarWithInheritance(name) for name, _, _ in DISPLAY_INPUTS}
        found = {name: primvar for name, primvar in found.items() if primvar and primvar.HasValue()}
        if not found:
            return NO_MATERIAL
        path = f"{prim.GetPath()}.displayColor"
        if path not in self._by_path:
            index = self._by_path[path] = len(self.materials)
            record = {**self._fallback(path), "fallback": False, "shader": "displayColor"}
            for name, key, width in DISPLAY_INPUTS:
                if name in found:
                    record[key] = self._display_input(found[name], index, record[key], width)
            self.materials.append(record)
        return self._by_path[path]

    def instance_display(self, names: frozenset[str]) -> int:
        """For a mesh with no bound material and no displayColor / displayOpacity of its own (or
        inherited within its copy) whose instances may give it `names` (among those two): one
        preview_surface record reading them as primvars, so each copy takes its instance's
        value, as Hydra's fallback material reads the instancer's. Their fallbacks are the
        unbound look, so a copy no instance colours renders exactly as NO_MATERIAL, and it is
        not warned about (`silent`)."""
        path = "cirrus:instanceDisplay:" + ",".join(sorted(names))
        if path not in self._by_path:
            index = self._by_path[path] = len(self.materials)
            record = {**self._fallback(path), "fallback": False, "shader": "displayColor"}
            for name, key, width in DISPLAY_INPUTS:
                if name in names:
                    record[key] = {"primvar": name, "channel": "rgb" if width == 3 else "r",
                                   "fallback": record[key]}
                    self.note_primvar(index, name)
            self.silent.add(index)
            self.materials.append(record)
        return self._by_path[path]

    def mesh_light(self, prim: Usd.Prim, base: int) -> int:
        """The index of the material of the mesh light `prim` (geometry_lights.py) over the
        material `base` it is bound to (NO_MATERIAL or a displayColor look: no Material),
        one record per light prim (its path in its prototype) and base; it reads what the
        base reads."""
        key = f"{prototype_path(prim)}.light:{base}"
        if key not in self._by_path:
            index = self._by_path[key] = len(self.materials)
            unbound = base == NO_MATERIAL or self.materials[base]["shader"] == "displayColor"
            self.materials.append(light_material(prim, None if unbound else self.materials[base],
                                                 self._time, self._report))
            if not unbound:
                for table in (self._uv_names, self._primvars):
                    if base in table:
                        table[index] = table[base]
        return self._by_path[key]

    def hair(self) -> int:
        """The default look of curves with no bound material and no displayColor: a dark brown
        rough dielectric (UsdPreviewSurface, ior 1.55 as keratin), one record for every such prim."""
        path = "cirrus:hair"
        if path not in self._by_path:
            self._by_path[path] = len(self.materials)
            record = {**self._fallback(path), "fallback": False, "shader": "hair default"}
            record.update(diffuse_color=[0.09, 0.05, 0.025], roughness=0.35, ior=1.55)
            self.materials.append(record)
        return self._by_path[path]

    def _display_input(self, primvar: UsdGeom.Primvar, index: int, default, width: int):
        """A display primvar as a constant (constant interpolation) or a primvar input."""
        values = primvar.ComputeFlattened(self._time)
        if primvar.GetInterpolation() == UsdGeom.Tokens.constant and values:
            return [float(v) for v in values[0]] if width == 3 else float(values[0])
        self._primvars.setdefault(index, set()).add(primvar.GetPrimvarName())
        return {"primvar": str(primvar.GetPrimvarName()), "channel": "rgb" if width == 3 else "r",
                "fallback": default}

    def _read(self, material: UsdShade.Material, path: str) -> dict:
        """One material record: the mtlx look if readable, else the universal one, else the
        grey fallback with a warning."""
        skipped = []
        self._warn_displacement(material, path)
        mtlx = material.GetSurfaceOutput("mtlx")
        if mtlx and mtlx.HasConnectedSource():
            shader, _, _ = material.ComputeSurfaceSource("mtlx")
            node = UsdNode(shader, self._resolver, self._time) if shader else None
            if node is not None and (node.category in OPEN_PBR or node.category == PREVIEW):
                return self._record(path, node, "", skipped)
            skipped.append(f"the mtlx surface ({node.id if node else 'unconnected'}) is not "
                           f"open_pbr_surface, standard_surface or UsdPreviewSurface")
        shader, _, _ = material.ComputeSurfaceSource()
        node = UsdNode(shader, self._resolver, self._time) if shader else None
        return self._record(path, node if node is not None and node.id == PREVIEW else None, "", skipped,
                            node.id if node else "no universal surface output")

    def _warn_displacement(self, material: UsdShade.Material, path: str) -> None:
        """Warns of displacement (issue 40), a connected displacement output or an authored
        UsdPreviewSurface `displacement` input: neither is rendered."""
        outputs = [o.GetFullName() for o in material.GetDisplacementOutputs() if o.HasConnectedSource()]
        shader, _, _ = material.ComputeSurfaceSource()
        amount = shader.GetInput("displacement") if shader else None
        inputs = [f"{shader.GetPath()}.inputs:displacement"] if amount and (
            amount.HasConnectedSource() or amount.Get(self._time) not in (None, 0)) else []
        for name in outputs + inputs:
            self._report.warn(f"material {path}: displacement ({name}) is not rendered")

    def _record(self, path: str, node: Node | None, prefix: str, skipped: list[str],
                what: str = "no surface shader") -> dict:
        """The record of a surface node (shader named `prefix` + its id or category), or the
        grey fallback with a warning; a non-empty `skipped` is warned about once."""
        if node is None or (node.category not in OPEN_PBR and node.category != PREVIEW):
            what = node.category if node is not None else what
            self._report.warn(f"material {path}: not a UsdPreviewSurface, OpenPBR or Standard Surface "
                              f"({what or 'sourceAsset shader'}); using the grey fallback")
            return {**self._fallback(path), "skipped": skipped}
        if skipped:
            self._report.warn(f"material {path}: {'; '.join(skipped)}; the simpler look is used")
        index = len(self.materials) - 1
        resolver = GraphResolver(path, _Sink(self, index, path), self._report.warn)
        record = {"path": path, "fallback": False, "shader": prefix + (node.id if not prefix else node.category),
                  "skipped": skipped}
        if node.category in OPEN_PBR:
            return {**record, "model": "open_pbr", **open_pbr_record(node, resolver, self._report.warn, path)}
        for key, name, default in SURFACE_INPUTS:
            record[key] = resolver.input(node, name, default)
        record["use_specular_workflow"] = bool(resolver.input(node, "useSpecularWorkflow", 0.0))
        for key, name, default in CONSTANT_INPUTS:
            value = resolver.input(node, name, default)
            record[key] = default if isinstance(value, dict) else value
        normal = resolver.input(node, "normal", None)
        record["normal"] = normal if isinstance(normal, dict) and "texture" in normal else None
        threshold = self._opacity_threshold(path, resolver.input(node, "opacityThreshold", 0.0))
        if threshold > 0.0:
            record["opacity_threshold"] = threshold
        return record

    def _opacity_threshold(self, path: str, value) -> float:
        """inputs:opacityThreshold as a constant in [0, 1]: a connected one reads as 0 (no
        mask), one outside [0, 1] is clamped, each with a warning naming the material."""
        if isinstance(value, dict):
            self._report.warn(f"material {path}: inputs:opacityThreshold is connected, which Cirrus "
                              f"does not read; 0 (no cut-out mask) used")
            return 0.0
        clamped = min(max(float(value), 0.0), 1.0)
        if clamped != value:
            self._report.warn(f"material {path}: inputs:opacityThreshold {value} is outside [0, 1]; "
                              f"{clamped} used")
        return clamped

    @staticmethod
    def _fallback(path: str) -> dict:
        """The stand-in for a material we cannot read: UsdPreviewSurface's defaults (a grey 0.18 plastic)."""
        record = {"path": path, "fallback": True, "shader": "", "skipped": []}
        for key, _, default in SURFACE_INPUTS:
            record[key] = default
        record["use_specular_workflow"] = False
        for key, _, default in CONSTANT_INPUTS:
            record[key] = default
        record["normal"] = None
        return record

    def note_uv(self, index: int, name: str) -> None:
        """Remembers the primvar material `index`'s textures read as st (the first one named)."""
        self._uv_names.setdefault(index, name)

    def note_primvar(self, index: int, name: str) -> None:
        """Remembers a primvar material `index` reads."""
        self._primvars.setdefault(index, set()).add(name)

    def usd_texture(self, texture: UsdShade.Shader, index: int, material_path: str) -> int:
        """A UsdUVTexture's record index, noting the UsdPrimvarReader_float2 varname its st
        reads (through a UsdTransform2d)."""
        reader = upstream(texture.GetInput("st"))
        if reader is not None and shader_id(reader[0]) == "UsdTransform2d":
            reader = upstream(reader[0].GetInput("in"))
        if reader is not None and shader_id(reader[0]) == "UsdPrimvarReader_float2":
            self.note_uv(index, str(input_value(reader[0], "varname", "st")))
        return self._texture_index(texture, material_path)

    def _texture_index(self, texture: UsdShade.Shader, material_path: str) -> int:
        """The manifest index of a UsdUVTexture, stored once per distinct record."""
        attrs = texture.GetInput("file").GetValueProducingAttributes()
        resolved = self._resolver.resolve(attrs[0], self._time) if attrs else None
        # No file authored (or an empty one) reads the fallback as asked, silently; a missing
        # file is reported here once, and recorded as none so the loader does not again.
        file, exists = resolved if resolved else ("", True)
        fallback = input_value(texture, "fallback", [0.0, 0.0, 0.0, 1.0])
        if not exists:
            self._report.warn(f"material {material_path}: image file {file} of {texture.GetPath()} "
                              f"is missing; its fallback {[float(f'{v:.6g}') for v in fallback]} is used")
            file = ""
        record = {
            "file": file,
            "wrap_s": WRAP_MODES.get(input_value(texture, "wrapS", "useMetadata"), "repeat"),
            "wrap_t": WRAP_MODES.get(input_value(texture, "wrapT", "useMetadata"), "repeat"),
            "scale": input_value(texture, "scale", [1.0, 1.0, 1.0, 1.0]),
            "bias": input_value(texture, "bias", [0.0, 0.0, 0.0, 0.0]),
            "fallback": fallback,
            "color_space": self._color_space(texture, material_path),
            "st_transform": self._st_transform(texture),
        }
        return self.add_texture(record)

    def add_texture(self, record: dict) -> int:
        """The manifest index of a texture record, stored once per distinct record."""
        key = repr(sorted(record.items()))
        if key not in self._texture_keys:
            self._texture_keys[key] = len(self.textures)
            self.textures.append(record)
        return self._texture_keys[key]

    def _color_space(self, texture: UsdShade.Shader, material_path: str) -> str:
        """sourceColorSpace as auto | sRGB | raw; anything else is warned about and read as auto."""
        space = input_value(texture, "sourceColorSpace", "auto")
        if space not in COLOR_SPACES:
            self._report.warn(f"material {material_path}: sourceColorSpace {space!r} of "
                              f"{texture.GetPath()} is not auto, sRGB or raw; auto used")
            return "auto"
        return space

    def _st_transform(self, texture: UsdShade.Shader) -> dict | None:
        """The UsdTransform2d between the texture and its primvar reader, if any."""
        found = upstream(texture.GetInput("st"))
        if found is None or shader_id(found[0]) != "UsdTransform2d":
            return None
        xform = found[0]
        return {"translation": input_value(xform, "translation", [0.0, 0.0]),
                "rotation_deg": input_value(xform, "rotation", 0.0),
                "scale": input_value(xform, "scale", [1.0, 1.0])}


class _Sink:
    """node_graph.TextureSink for one material: textures and primvars land in the table."""

    def __init__(self, table: MaterialTable, index: int, path: str) -> None:
        self._table, self._index, self._path = table, index, path

    def add(self, record: dict) -> int:
        """A texture record's index."""
        return self._table.add_texture(record)

    def usd_texture(self, node: UsdNode) -> int:
        """A UsdUVTexture node's record index."""
        return self._table.usd_texture(node.shader, self._index, self._path)

    def note_uv(self, name: str) -> None:
        """The primvar this material's textures read as st."""
        self._table.note_uv(self._index, name)

    def note_primvar(self, name: str) -> None:
        """A primvar this material reads."""
        self._table.note_primvar(self._index, name)
