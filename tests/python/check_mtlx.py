"""MaterialX checks for tests/materialx.rs, independent of the exporter's own reading.

`inputs SCENE_DIR DOC.mtlx...`: every surfacematerial of each document, read with the
MaterialX package, against its record in SCENE_DIR/scene.json, input by input: constants of
open_pbr_surface nodes equal the record's, and every image a surface input reads is the
record's texture (file and colour space).
`table`: standard_surface -> OpenPBR on a table of parameter sets (the OpenPBR
specification's mapping, as MaterialX 1.39's translation graph gives it), exported by the
exporter from a generated document. Prints what it checked; exits 1 on a mismatch.
"""

import json
import math
import sys
import tempfile
from pathlib import Path

import MaterialX as mx

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "exporter"))
from cirrus_export.export import export  # noqa: E402

SPACES = {"srgb_texture": "sRGB", "lin_rec709": "raw", "": "raw"}
# standard_surface input -> the OpenPBR input an image on it reaches unchanged.
RENAMED = {"base_color": "base_color", "metalness": "base_metalness", "specular_roughness": "specular_roughness",
           "subsurface": "subsurface_weight", "subsurface_color": "subsurface_color", "normal": "geometry_normal"}
FUZZ = 0.3 ** 0.4
# (standard_surface inputs, expected OpenPBR inputs)
TABLE = [
    ({}, {"base_weight": 1, "base_color": [0.8] * 3, "specular_weight": 1, "specular_roughness": 0.2,
          "specular_ior": 1.5, "coat_weight": 0, "fuzz_roughness": FUZZ, "geometry_opacity": 1}),
    ({"base": 0.5, "base_color": (1, 0, 0), "coat": 1, "coat_color": (0.5, 1, 1)},
     {"base_weight": 0.5, "base_color": [0.5, 0, 0], "coat_weight": 1, "coat_color": [0.5, 1, 1]}),
    ({"metalness": 1, "specular": 0.3}, {"base_metalness": 1, "specular_weight": 1}),
    ({"metalness": 0, "specular": 0.3}, {"base_metalness": 0, "specular_weight": 0.3}),
    ({"metalness": 1, "coat": 0.5}, {"coat_weight": 0, "base_color": [0.8] * 3}),
    ({"specular_color": (0, 0, 0)}, {"specular_color": [1, 1, 1]}),
    ({"specular_color": (0.5, 0.25, 1)}, {"specular_color": [0.5, 0.25, 1]}),
    ({"thin_film_thickness": 500, "thin_film_IOR": 1.3},
     {"thin_film_weight": 1, "thin_film_thickness": 0.5, "thin_film_ior": 1.3}),
    ({"transmission": 1, "transmission_color": (0.9, 1, 1), "specular_IOR": 1.33, "thin_walled": True},
     {"transmission_weight": 1, "transmission_color": [0.9, 1, 1], "specular_ior": 1.33, "geometry_thin_walled": True}),
    ({"emission": 2, "emission_color": (1, 0.5, 0), "opacity": (0.25, 1, 1)},
     {"emission_luminance": 2, "emission_color": [1, 0.5, 0], "geometry_opacity": 0.25}),
    ({"sheen": 1, "sheen_roughness": 1, "sheen_color": (1, 0, 1)},
     {"fuzz_weight": 1, "fuzz_roughness": 1, "fuzz_color": [1, 0, 1]}),
    ({"coat_affect_roughness": 0.7, "coat_IOR": 1.8, "coat_roughness": 0.4},
     {"coat_darkening": 0.7, "coat_ior": 1.8, "coat_roughness": 0.4}),
    ({"specular_anisotropy": 0.6, "diffuse_roughness": 0.3},
     {"specular_roughness_anisotropy": 0.6, "base_diffuse_roughness": 0.3}),
]


def close(a, b) -> bool:
    """Equal within f32 rounding, componentwise; bools exactly."""
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    a, b = (a if isinstance(a, list) else [a]), (b if isinstance(b, list) else [b])
    return len(a) == len(b) and all(math.isclose(x, y, rel_tol=1e-6, abs_tol=1e-6) for x, y in zip(a, b))


def record_of(manifest: dict, name: str) -> dict:
    """The material record whose path ends in /name."""
    found = [m for m in manifest["materials"] if m["path"].rsplit("/", 1)[-1] == name]
    assert found, f"no record for material {name}"
    return found[0]


def check_inputs(scene: Path, documents: list[str]) -> int:
    """Compares every document's materials with the scene's records; returns inputs checked."""
    manifest = json.loads((scene / "scene.json").read_text())
    checked = 0
    for file in documents:
        doc = mx.createDocument()
        mx.readFromXmlFile(doc, file)
        for material in doc.getMaterialNodes():
            record = record_of(manifest, material.getName())
            surface = material.getInput("surfaceshader").getConnectedNode()
            assert record["shader"] == f"mtlx:{surface.getCategory()}", (record["path"], record["shader"])
            for inp in surface.getInputs():
                image = inp.getConnectedNode()
                if image is not None and image.getCategory() == "normalmap":
                    image = image.getInput("in").getConnectedNode()
                if image is not None and image.getCategory() == "image" and inp.getName() in RENAMED:
                    value = record["open_pbr"].get(RENAMED[inp.getName()]) or record[RENAMED[inp.getName()]]
                    texture = manifest["textures"][value["texture"]]
                    file_input = image.getInput("file")
                    expected = str((Path(file).parent / file_input.getResolvedValueString()).resolve())
                    assert texture["file"] == expected, (record["path"], inp.getName(), texture["file"], expected)
                    space = SPACES[file_input.getActiveColorSpace()]
                    assert texture["color_space"] == space, (record["path"], inp.getName(), texture["color_space"])
                    checked += 1
                elif surface.getCategory() == "open_pbr_surface" and inp.getValue() is not None:
                    got = record["open_pbr"][inp.getName()]
                    want = inp.getValue()
                    want = [*want] if not isinstance(want, (int, float)) else want
                    assert close(got, want), (record["path"], inp.getName(), got, want)
                    checked += 1
    return checked


def check_table() -> int:
    """Exports one standard_surface per TABLE row and compares the OpenPBR inputs."""
    with tempfile.TemporaryDirectory() as tmp:
        doc = mx.createDocument()
        usda = ['#usda 1.0\ndef Scope "Looks" (prepend references = @./table.mtlx@</MaterialX/Materials>) {}\n']
        for row, (inputs, _) in enumerate(TABLE):
            surface = doc.addNode("standard_surface", f"surface{row}", "surfaceshader")
            for name, value in inputs.items():
                kind = "boolean" if isinstance(value, bool) else "color3" if isinstance(value, tuple) else "float"
                surface.setInputValue(name, mx.Color3(*value) if kind == "color3" else value, kind)
            material = doc.addMaterialNode(f"row{row}", surface)
            assert material is not None
            usda.append(f'def Mesh "Row{row}" (prepend apiSchemas = ["MaterialBindingAPI"]) {{\n'
                        f'  point3f[] points = [(0, 0, {row}), (1, 0, {row}), (0, 1, {row})]\n'
                        f'  int[] faceVertexCounts = [3]\n  int[] faceVertexIndices = [0, 1, 2]\n'
                        f'  rel material:binding = </Looks/row{row}>\n}}\n')
        mx.writeToXmlFile(doc, f"{tmp}/table.mtlx")
        Path(f"{tmp}/table.usda").write_text("".join(usda))
        export(Path(f"{tmp}/table.usda"), Path(f"{tmp}/out"), None)
        manifest = json.loads(Path(f"{tmp}/out/scene.json").read_text())
    checked = 0
    for row, (inputs, expected) in enumerate(TABLE):
        record = record_of(manifest, f"row{row}")
        assert record["model"] == "open_pbr" and record["shader"] == "mtlx:standard_surface", record["path"]
        for name, want in expected.items():
            got = record[name] if name == "geometry_thin_walled" else record["open_pbr"][name]
            assert close(got, want), f"row {row} {inputs}: {name} = {got}, expected {want}"
            checked += 1
    return checked


if __name__ == "__main__":
    count = check_table() if sys.argv[1] == "table" else check_inputs(Path(sys.argv[2]), sys.argv[3:])
    print(f"{count} inputs match")
