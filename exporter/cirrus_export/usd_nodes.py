"""UsdShade shaders as node_graph.Node: MaterialX nodes written in USD (`info:id` of an
`ND_*` node definition, read with the standard libraries' definitions and defaults) and
UsdPreviewSurface's own nodes (UsdUVTexture, UsdPrimvarReader_*, UsdTransform2d)."""

from pxr import Sdf, Usd, UsdShade

from .assets import AssetResolver
from .mtlx import as_value, standard_library
from .node_graph import Link, Value

# UsdPrimvarReader_<suffix> -> the MaterialX type of its result.
READER_TYPES = {"float": "float", "float2": "vector2", "float3": "vector3", "float4": "vector4"}


def shader_id(shader: UsdShade.Shader) -> str:
    """The shader's info:id, or "" for sourceAsset/sourceCode shaders."""
    return str(shader.GetIdAttr().Get() or "")


def upstream(inp: UsdShade.Input) -> tuple[UsdShade.Shader, str] | None:
    """The shader and output an input finally reads from, through Material and NodeGraph
    interface inputs and outputs."""
    if not inp:
        return None
    attrs = inp.GetValueProducingAttributes()
    if not attrs or not UsdShade.Output.IsOutput(attrs[0]):
        return None
    return UsdShade.Shader(attrs[0].GetPrim()), UsdShade.Output(attrs[0]).GetBaseName()


def as_json(value) -> float | list[float] | str | bool:
    """A Gf vector, scalar, token or asset path as JSON."""
    if isinstance(value, Sdf.AssetPath):
        return value.path
    if isinstance(value, (str, bool)):
        return value
    try:
        return [float(v) for v in value]
    except TypeError:
        return float(value)


def input_value(shader: UsdShade.Shader, name: str, default):
    """An input's constant value, following interface connections to the Material."""
    inp = shader.GetInput(name)
    if not inp:
        return default
    attrs = inp.GetValueProducingAttributes()
    value = attrs[0].Get() if attrs and UsdShade.Input.IsInput(attrs[0]) else None
    return default if value is None else as_json(value)


class UsdNode:
    """One UsdShade shader seen as a node_graph.Node."""

    def __init__(self, shader: UsdShade.Shader, resolver: AssetResolver, time: Usd.TimeCode) -> None:
        self.shader, self._resolver, self._time = shader, resolver, time
        self.id = shader_id(shader)
        self._nodedef = standard_library().getNodeDef(self.id) if self.id.startswith("ND_") else None
        self.path = str(shader.GetPath())
        self.category = self._nodedef.getNodeString() if self._nodedef is not None else self.id
        self.type = self._nodedef.getType() if self._nodedef is not None else \
            READER_TYPES.get(self.id.removeprefix("UsdPrimvarReader_"), "")

    def source(self, name: str) -> Link | Value | None:
        """The upstream shader's output, else the (interface-resolved) constant, else None."""
        found = upstream(self.shader.GetInput(name))
        if found is not None:
            return Link(UsdNode(found[0], self._resolver, self._time), found[1])
        return input_value(self.shader, name, None)

    def default(self, name: str) -> Value | None:
        """The MaterialX node definition's default for an `ND_*` shader, else None."""
        inp = self._nodedef.getActiveInput(name) if self._nodedef is not None else None
        return as_value(inp.getValue()) if inp is not None and inp.getValue() is not None else None

    def file(self, name: str) -> tuple[str, bool] | None:
        """An asset input resolved like every USD asset (assets.py)."""
        inp = self.shader.GetInput(name)
        attrs = inp.GetValueProducingAttributes() if inp else []
        return self._resolver.resolve(attrs[0], self._time) if attrs else None

    def color_space(self, name: str) -> str:
        """The input attribute's colorSpace metadata ("" when unauthored)."""
        inp = self.shader.GetInput(name)
        return str(inp.GetAttr().GetColorSpace() or "") if inp else ""
