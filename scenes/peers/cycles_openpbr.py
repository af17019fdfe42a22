"""OpenPBR Surface records (`model: open_pbr`, exporter/FORMAT.md) as Blender 5.0's
Principled BSDF (runs in Blender's Python; used by to_cycles.py).

Blender 4.0 rebuilt the Principled BSDF after OpenPBR, so most inputs map one to
one (checked against Cycles' `svm_node_closure_bsdf` and measured on
scenes/peers/openpbr_spheres.usda; docs/peers/materials.md has the numbers):

| OpenPBR | Principled BSDF | note |
|---|---|---|
| base_weight x base_color | Base Color | Principled has no base weight |
| base_metalness | Metallic | metal F0 = base colour, F82 tint = Specular Tint, both |
| base_diffuse_roughness | Diffuse Roughness | EON in both (Cycles since 4.3) |
| specular_weight | Specular IOR Level = weight / 2 | Cycles scales F0 by 2 x level, OpenPBR by the weight, then both invert to an IOR |
| specular_color | Specular Tint | OpenPBR tints the exact Fresnel, Cycles F0 of a Schlick-shaped curve (grazing goes to 1): tints differ at grazing angles |
| specular_roughness | Roughness | alpha = r^2 in both |
| specular_ior | IOR | under a coat, OpenPBR's ratio to the coat's IOR (below) |
| transmission_weight | Transmission Weight | Cycles tints refraction by sqrt(base colour): transmission_color is not converted |
| coat_weight, _roughness, _ior, _color | Coat Weight, Roughness, IOR, Tint | Cycles' coat tint is absorbed along the view ray only, OpenPBR's along both; Cycles does not darken the base (coat_darkening) nor roughen it |
| fuzz_weight, _color, _roughness | Sheen Weight, Tint, Roughness | the same Zeltner et al. 2022 LTC sheen in both |
| emission_luminance x emission_color | Emission Strength x Color | radiance, under coat and fuzz in both |
| geometry_opacity | Alpha | |

Not converted, warned: anisotropy (tangent frames differ), thin film (Cirrus ignores
it; left at thickness 0 here too), subsurface (Cirrus renders OpenPBR's diffuse
fallback), transmission colour, thin walls, normal maps with a scale, coat normals,
coat_darkening (warned when it has an effect: a coat over a non-metal base).
"""

#: OpenPBR's colour inputs (a number there is grey).
COLOURS = ("base_color", "specular_color", "transmission_color", "subsurface_color",
           "fuzz_color", "coat_color", "emission_color")
#: The specification's defaults (OpenPBR Surface 1.1), for inputs the record omits.
DEFAULTS = {
    "base_weight": 1.0, "base_color": [0.8] * 3, "base_diffuse_roughness": 0.0, "base_metalness": 0.0,
    "specular_weight": 1.0, "specular_color": [1.0] * 3, "specular_roughness": 0.3,
    "specular_roughness_anisotropy": 0.0, "specular_ior": 1.5, "transmission_weight": 0.0,
    "transmission_color": [1.0] * 3, "subsurface_weight": 0.0, "fuzz_weight": 0.0,
    "fuzz_color": [1.0] * 3, "fuzz_roughness": 0.5, "coat_weight": 0.0, "coat_color": [1.0] * 3,
    "coat_roughness": 0.0, "coat_roughness_anisotropy": 0.0, "coat_ior": 1.6, "coat_darkening": 1.0,
    "thin_film_weight": 0.0, "emission_luminance": 0.0, "emission_color": [1.0] * 3,
    "geometry_opacity": 1.0,
}
#: OpenPBR input -> Principled BSDF input, converted as they are.
DIRECT = {
    "base_metalness": "Metallic", "base_diffuse_roughness": "Diffuse Roughness",
    "specular_color": "Specular Tint", "specular_roughness": "Roughness",
    "transmission_weight": "Transmission Weight", "coat_weight": "Coat Weight",
    "coat_roughness": "Coat Roughness", "coat_ior": "Coat IOR", "coat_color": "Coat Tint",
    "fuzz_weight": "Sheen Weight", "fuzz_color": "Sheen Tint", "fuzz_roughness": "Sheen Roughness",
    "emission_color": "Emission Color", "emission_luminance": "Emission Strength",
    "geometry_opacity": "Alpha",
}
#: Inputs Cycles cannot reproduce, by the value at which they have no effect.
NOT_CONVERTED = {
    "specular_roughness_anisotropy": (0.0, "anisotropy (the tangent frames differ)"),
    "coat_roughness_anisotropy": (0.0, "coat anisotropy"),
    "thin_film_weight": (0.0, "thin film (Cirrus does not render it either)"),
    "subsurface_weight": (0.0, "subsurface (Cirrus renders OpenPBR's diffuse fallback)"),
    "transmission_color": ([1.0] * 3, "transmission_color (Cycles tints by sqrt(base colour))"),
}


def fields_of(material):
    """A material's `open_pbr` inputs as a record the converter's input readers take
    (the material's path added, grey colours spelled as RGB)."""
    fields = {"path": material["path"]}
    for key, value in material.get("open_pbr", {}).items():
        if value is None:
            continue
        fields[key] = [float(value)] * 3 if key in COLOURS and isinstance(value, (int, float)) else value
    return fields


def principled(converter, textures, material):
    """A Principled BSDF node for an open_pbr record; what it cannot convert is warned
    through the converter (whose set_input / constant / texture read the inputs)."""
    fields = fields_of(material)
    path = material["path"]
    node = textures.nodes.new("ShaderNodeBsdfPrincipled")
    for key, socket in DIRECT.items():
        converter.set_input(textures, fields, key, DEFAULTS[key], node.inputs[socket])
    base_colour(converter, textures, fields, node.inputs["Base Color"])
    weight = converter.constant(fields, "specular_weight", 1.0)
    if converter.texture(fields, "specular_weight"):
        converter.keep_fallback(fields, "specular_weight", "a constant Specular IOR Level")
    node.inputs["IOR"].default_value = specular_ior_under_coat(converter, fields)
    node.inputs["Specular IOR Level"].default_value = max(float(weight), 0.0) / 2.0
    for key, (neutral, what) in NOT_CONVERTED.items():
        if converter.texture(fields, key) or converter.constant(fields, key, neutral) != neutral:
            converter.warn(f"material {path}: OpenPBR {what} not converted")
    coat = converter.constant(fields, "coat_weight", 0.0)
    metal = converter.constant(fields, "base_metalness", 0.0)
    if metal > 0 and weight != 1:
        converter.warn(f"material {path}: OpenPBR specular_weight on metal not converted "
                       "(Cycles' metal has no specular weight)")
    if coat > 0 and metal < 1 and converter.constant(fields, "coat_darkening", 1.0) > 0:
        converter.warn(f"material {path}: OpenPBR coat_darkening not converted (Cycles' coat "
                       "does not darken the base: Cirrus reads darker)")
    if material.get("geometry_thin_walled"):
        converter.warn(f"material {path}: OpenPBR geometry_thin_walled not converted")
    normal = material.get("geometry_normal")
    if normal and normal.get("scale", 1.0) == 1.0:
        converter.normal_map(textures, {"path": path, "normal": normal}, node.inputs["Normal"])
    elif normal:
        converter.warn(f"material {path}: OpenPBR normal map with a scale not converted")
    if material.get("geometry_coat_normal"):
        converter.warn(f"material {path}: OpenPBR coat normal map not converted")
    return node


def base_colour(converter, textures, fields, socket):
    """Base Color = base_weight x base_color (a Vector Math scale for a textured colour)."""
    weight = float(converter.constant(fields, "base_weight", 1.0))
    if converter.texture(fields, "base_weight"):
        converter.keep_fallback(fields, "base_weight", "a constant factor on Base Color")
    if weight != 1.0 and converter.texture(fields, "base_color"):
        scale = textures.nodes.new("ShaderNodeVectorMath")
        scale.operation = "SCALE"
        scale.inputs["Scale"].default_value = weight
        textures.links.new(scale.outputs["Vector"], socket)
        socket = scale.inputs[0]
    converter.set_input(textures, fields, "base_color", DEFAULTS["base_color"], socket)
    if not converter.texture(fields, "base_color"):
        socket.default_value = (*(weight * c for c in socket.default_value[:3]), 1.0)


def specular_ior_under_coat(converter, fields):
    """The IOR of the base's specular interface: specular_ior lerped towards its ratio to
    coat_ior by coat_weight, the ratio inverted where it would be below 1 (OpenPBR 1.1,
    "Dielectric", specular_ior_ratio_with_tir_fix; src/materials/open_pbr/model.rs). Cycles
    puts the base under no medium: on scenes/peers/openpbr_spheres.usda (coat IOR =
    specular IOR, so the base's specular vanishes in OpenPBR) the coated sphere read 16%
    darker in Cirrus on its dark red channel with specular_ior as is. 1 (no interface)
    skips Cycles' specular lobe, as the ratio 1 removes OpenPBR's."""
    ior = float(converter.constant(fields, "specular_ior", 1.5))
    coat = min(max(float(converter.constant(fields, "coat_weight", 0.0)), 0.0), 1.0)
    coat_ior = float(converter.constant(fields, "coat_ior", 1.6))
    if coat == 0 or coat_ior <= 0:
        return ior
    ratio = ior / coat_ior
    ratio = 1.0 / ratio if ratio < 1 else ratio
    return (1 - coat) * ior + coat * ratio
