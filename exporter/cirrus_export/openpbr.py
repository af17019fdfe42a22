"""OpenPBR Surface inputs (ASWF OpenPBR specification 1.1) of an `open_pbr_surface` node,
or of a `standard_surface` node mapped as the OpenPBR specification gives: MaterialX 1.39
ships that mapping as the graph `NG_standard_surface_to_open_pbr_surface`
(libraries/bxdf/translation/standard_surface_to_open_pbr.mtlx), which is evaluated here by
node_graph over the Standard Surface's own inputs, so the mapping is the library's, not a copy.
"""

from pathlib import Path

from .mtlx import MtlxNode, standard_library
from .node_graph import GraphResolver, Link, Node

# The contract's open_pbr keys: OpenPbrInputs of src/materials/open_pbr/inputs.rs.
OPEN_PBR_INPUTS = [
    "base_weight", "base_color", "base_diffuse_roughness", "base_metalness", "specular_weight",
    "specular_color", "specular_roughness", "specular_roughness_anisotropy", "specular_ior",
    "transmission_weight", "transmission_color", "transmission_depth", "subsurface_weight",
    "subsurface_color", "fuzz_weight", "fuzz_color", "fuzz_roughness", "coat_weight", "coat_color",
    "coat_roughness", "coat_roughness_anisotropy", "coat_ior", "coat_darkening", "thin_film_weight",
    "thin_film_thickness", "thin_film_ior", "emission_luminance", "emission_color", "geometry_opacity",
]
TRANSLATION = "NG_standard_surface_to_open_pbr_surface"
# Normal inputs: (open_pbr_surface's, standard_surface's) for geometry_normal and geometry_coat_normal.
NORMALS = {"geometry_normal": ("geometry_normal", "normal"),
           "geometry_coat_normal": ("geometry_coat_normal", "coat_normal")}
# Inputs the scene format does not model, per surface (subsurface_* ones are in the subsurface warning).
NOT_MODELLED = {
    "open_pbr_surface": ["transmission_scatter", "transmission_scatter_anisotropy",
                         "transmission_dispersion_scale", "transmission_dispersion_abbe_number",
                         "geometry_tangent", "geometry_coat_tangent"],
    "standard_surface": ["specular_rotation", "transmission_scatter", "transmission_scatter_anisotropy",
                         "transmission_dispersion", "transmission_extra_roughness", "coat_rotation",
                         "coat_affect_color", "tangent"],
}


class _Translated:
    """A standard_surface seen through the translation graph: input `name` of this node is
    the graph's output `<name>_out`, whose interface inputs are the surface's."""

    def __init__(self, surface: Node) -> None:
        self._graph = standard_library().getNodeGraph(TRANSLATION)
        self._surface = surface
        self.path, self.category, self.type = surface.path, surface.category, surface.type

    def source(self, name: str) -> Link | None:
        """The translation graph's node for OpenPBR input `name`."""
        output = self._graph.getOutput(f"{name}_out")
        node = output.getConnectedNode() if output is not None else None
        return None if node is None else Link(MtlxNode(node, Path(), interface=self._surface), "out")

    def default(self, name: str) -> None:
        """Every translated input is driven; defaults come from the surface."""
        return None

    def file(self, name: str) -> None:
        """The graph holds no filename input."""
        return None

    def color_space(self, name: str) -> str:
        """The graph holds no filename input."""
        return ""


def _has_effect(surface: Node, name: str) -> bool:
    """Whether input `name` is connected, or authored with a value other than its default:
    an authored default (tools write every input) changes nothing, so nothing is lost."""
    source = surface.source(name)
    return source is not None and (isinstance(source, Link) or source != surface.default(name))


def open_pbr_record(surface: Node, resolver: GraphResolver, warn, material: str) -> dict:
    """The record fields of an open_pbr material (`open_pbr`, `geometry_*`) for a surface
    node of category open_pbr_surface or standard_surface."""
    standard = surface.category == "standard_surface"
    inputs_of = _Translated(surface) if standard else surface
    inputs = {name: resolver.input(inputs_of, name, None) for name in OPEN_PBR_INPUTS}
    thin_walled = resolver.input(inputs_of, "geometry_thin_walled", False)
    normals = {key: resolver.normal_map(surface, names[standard]) for key, names in NORMALS.items()}
    if inputs["subsurface_weight"] != 0.0:
        warn(f"material {material}: subsurface is rendered as OpenPBR's diffuse fallback tinted by "
             f"subsurface_color (no subsurface scattering; radius and scale are not used)")
    dropped = [name for name in NOT_MODELLED[surface.category] if _has_effect(surface, name)]
    if dropped:
        warn(f"material {material}: {surface.category} inputs {', '.join(dropped)} are not modelled; ignored")
    return {"open_pbr": inputs, "geometry_thin_walled": bool(thin_walled) if isinstance(thin_walled, bool) else False,
            **normals}
