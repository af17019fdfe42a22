"""Builds a Mitsuba 3 scene dictionary from an exported Cirrus scene (see to_mitsuba.py).

What each part becomes, and why (units: Cirrus and Mitsuba's RGB variants both
carry linear Rec.709 radiance in W/(m^2 sr), so values pass through unchanged
once the UsdLux emission color x intensity x 2^exposure is formed; the exporter
stores the three factors separately and src/lights/emission.rs multiplies them):

- Camera: USD looks down -Z with +X right; Mitsuba looks down +Z with +X to the
  image's left, so to_world = world_from_camera x diag(-1, 1, -1). Horizontal
  fov from the aperture conformed by "expandAperture" (src/camera/window.rs);
  thin lens when fStop and focusDistance are set, radius focalLength/10/(2 fStop).
  Orthographic: Mitsuba's view is [-1, 1] wide, so x and y are scaled by half
  the conformed aperture / 10.
- Meshes: one binary PLY per (mesh, material); a prototype with several
  instances becomes a `shapegroup` placed by `instance`s, else the shape is
  placed directly. Surfaces reflect on both sides in Cirrus, so BSDFs are
  wrapped in `twosided`.
- Materials: pure Lambert (specular workflow with zero specularColor, no
  clearcoat, opacity 1) is `diffuse`; anything else is approximated by
  `principled` (reported). Textured diffuseColor, emissiveColor, metallic and
  roughness become `bitmap` textures read as Cirrus reads them, and a normal
  map a `normalmap` wrapper (mitsuba_texture.py says how, and what is refused);
  the PLY files carry the meshes' st. Triangles without a material, and
  materials the exporter could not read, are UsdPreviewSurface's defaults (a
  grey plastic, as Cirrus renders them), hence `principled` too. Textured opacity and specularColor (read
  as a scalar spec_trans and ior), and textures a bitmap cannot reproduce,
  keep their fallback (reported); a texture whose image is missing reads its
  fallback in Cirrus too.
- Lights: sphere = `sphere` shape with an `area` emitter (treatAsPoint: a
  `point` of the same power); rect and disk = `rectangle`/`disk` shapes with
  flipped normals (UsdLux emits from -Z); cylinder = `cylinder` along X; all
  divided by their world area under `normalize`. Light shapes get an opaque
  black BSDF: in Cirrus a ray that finds a light stops there (a `null` BSDF
  would show what is behind it); shadow rays stop at them in both. Distant = `directional` of the
  same irradiance (normalize: the emission; else emission x pi sin^2(angle/2),
  as src/lights/distant.rs), a delta instead of a cone (reported when angle > 0).
  Dome = `constant`.
- Volumes: see vdb_to_vol.py for the grid placement; each placed volume is a
  `heterogeneous` medium (scale = densityScale, albedo, `hg` phase) inside a
  `cube` with a `null` BSDF spanning the padded grid; a camera inside a box
  starts its rays in that medium.
- Integrator: Cirrus' --max-depth counts scattering events and Mitsuba's
  max_depth counts path segments (1 = directly visible emitters only), so
  Mitsuba's is Cirrus' + 1. `path` without volumes, `volpathmis` with them.
"""

import json
import math
import subprocess
from pathlib import Path
from typing import NamedTuple

import numpy as np

import cirrus_scene
from cirrus_scene import (GREY, affine4, conformed_aperture, distant_irradiance,
                          emission, near_far)
from mitsuba_texture import Bitmaps, Unrepresentable

#: Debian's Python, which has pyopenvdb (the .venv does not).
SYSTEM_PYTHON = "/usr/bin/python3"
#: The BSDF of light shapes: opaque and non-reflecting, as Cirrus' lights are to
#: the rays that find them (a `null` BSDF would let the light behind show through).
BLACK = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}


class Converter(cirrus_scene.Converter):
    """Turns one CirrusScene into a Mitsuba scene dict; `warnings` lists what was approximated."""

    def __init__(self, scene, width, height, max_depth, workdir, mi):
        super().__init__(scene)
        self.width, self.height = width, height
        self.max_depth = max_depth
        self.workdir = Path(workdir)
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.mi = mi
        #: Mesh index -> its PlyParts, so a mesh shared by prototypes is written once.
        self.plys = {}
        self.bitmaps = Bitmaps(self.workdir, mi)

    def transform(self, m):
        """A 4x4 numpy matrix as a Mitsuba ScalarTransform4f."""
        return self.mi.ScalarTransform4f(np.asarray(m, dtype=np.float64).tolist())

    # ----------------------------------------------------------------- scene

    def build(self):
        """The whole scene dictionary."""
        d = {"type": "scene", "integrator": self.integrator(), "sensor": self.sensor()}
        for i, light in enumerate(self.manifest["lights"]):
            entry = self.light(light)
            if entry is not None:
                d[f"light_{i}"] = entry
        d.update(self.shapes())
        d.update(self.volumes())
        self.place_camera_medium(d)
        if self.manifest["instances"].get("motion") or self.manifest["camera"].get("motion"):
            self.warn("motion blur not converted (Mitsuba 3's scalar and LLVM variants have none): "
                      "objects and camera rendered at the frame's transforms")
        for w in self.manifest.get("warnings", []):
            self.warn(f"exporter: {w}")
        return d

    def integrator(self):
        """`path`, or `volpathmis` with volumes, at Mitsuba depth = Cirrus depth + 1."""
        kind = "volpathmis" if self.manifest["volumes"] else "path"
        return {"type": kind, "max_depth": self.max_depth + 1}

    # ---------------------------------------------------------------- camera

    def sensor(self):
        """The camera: perspective, thin lens or orthographic, with a box-filtered RGB film."""
        cam = self.manifest["camera"]
        if cam["path"] is None:
            raise SystemExit("error: the scene has no camera prim "
                             "(Cirrus frames a default one; not converted)")
        if cam["horizontal_aperture_offset"] or cam["vertical_aperture_offset"]:
            self.warn("camera: aperture offsets not converted")
        world_from_camera = affine4(cam["transform"])
        linear = world_from_camera[:3, :3]
        scales = np.linalg.norm(linear, axis=0)
        aperture = conformed_aperture(cam, self.width, self.height)
        near, far = near_far(self.manifest)
        film = {
            "type": "hdrfilm",
            "width": self.width,
            "height": self.height,
            "pixel_format": "rgb",
            "component_format": "float32",
            "rfilter": {"type": "box"},
        }
        flip = np.diag([-1.0, 1.0, -1.0, 1.0])
        if cam["projection"] == "orthographic":
            half = aperture[0] / 10.0 / 2.0
            to_world = world_from_camera @ flip @ np.diag([half, half, 1.0, 1.0])
            return {"type": "orthographic", "to_world": self.transform(to_world),
                    "near_clip": near, "far_clip": far, "film": film}
        sheared = abs(np.linalg.det(linear) - scales.prod()) > 1e-4 * scales.prod()
        if np.ptp(scales) > 1e-4 * scales.max() or sheared:
            self.warn("camera: transform is not a rotation times a uniform scale; "
                      "shear and non-uniform scale dropped")
        rigid = world_from_camera.copy()
        rigid[:3, :3] = linear / scales
        scale = float(np.cbrt(abs(np.linalg.det(linear))))
        sensor = {
            "to_world": self.transform(rigid @ flip),
            "fov_axis": "x",
            "fov": math.degrees(2.0 * math.atan(aperture[0] / (2.0 * cam["focal_length"]))),
            "near_clip": near * scale,
            "far_clip": far * scale,
            "film": film,
        }
        if cam["f_stop"] > 0 and cam["focus_distance"] > 0:
            sensor["type"] = "thinlens"
            sensor["aperture_radius"] = cam["focal_length"] / 10.0 / (2.0 * cam["f_stop"]) * scale
            sensor["focus_distance"] = cam["focus_distance"] * scale
        else:
            sensor["type"] = "perspective"
        return sensor

    # ---------------------------------------------------------------- lights

    def light(self, light):
        """One UsdLux light as a Mitsuba emitter or emitting shape; None when it emits nothing."""
        if light.get("color_temperature") is not None:
            self.warn(f"light {light['path']}: colorTemperature ignored")
        e = emission(light)
        m = affine4(light["transform"])
        kind = light["type"]
        if kind == "dome":
            if light.get("texture"):
                self.warn(f"light {light['path']}: dome texture not converted (constant emission used)")
            return {"type": "constant", "radiance": rgb(e)}
        if kind == "distant":
            return self.distant(light, m)
        if kind == "sphere":
            return self.sphere_light(light, e, m)
        if kind in ("rect", "disk"):
            return self.planar_light(light, e, m)
        if kind == "cylinder":
            return self.cylinder_light(light, e, m)
        self.warn(f"light {light['path']}: type {kind} not converted")
        return None

    def distant(self, light, m):
        """A `directional` emitter carrying the irradiance on a surface facing the light."""
        irradiance = distant_irradiance(light)
        if light["angle_deg"] > 0:
            self.warn(f"light {light['path']}: distant cone of {light['angle_deg']:.3g} deg "
                      "rendered as a single direction (Mitsuba's directional); its disk is not visible")
        axis = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
        return {"type": "directional", "direction": (-axis / np.linalg.norm(axis)).tolist(),
                "irradiance": rgb(irradiance)}

    def sphere_light(self, light, e, m):
        """A sphere with an area emitter, or a point light of the same power for treatAsPoint."""
        scales = np.linalg.norm(m[:3, :3], axis=0)
        radius = light["radius"] * scales.mean()
        area = 4.0 * math.pi * radius**2
        centre = m[:3, 3].tolist()
        if light["treat_as_point"]:
            intensity = e / 4.0 if light["normalize"] else math.pi * radius**2 * e
            return {"type": "point", "position": centre, "intensity": rgb(intensity)}
        radiance = e / area if light["normalize"] else e
        return {"type": "sphere", "center": centre, "radius": radius,
                "bsdf": BLACK, "emitter": {"type": "area", "radiance": rgb(radiance)}}

    def planar_light(self, light, e, m):
        """A rect or disk light: Mitsuba's shape emits along its normal, UsdLux along -Z, so flipped."""
        if light["type"] == "rect":
            if light.get("texture"):
                self.warn(f"light {light['path']}: rect texture not converted")
            hx, hy, shape = light["width"] / 2.0, light["height"] / 2.0, "rectangle"
            unit_area = 4.0
        else:
            hx = hy = light["radius"]
            shape, unit_area = "disk", math.pi
        to_world = m @ np.diag([hx, hy, 1.0, 1.0])
        area = unit_area * np.linalg.norm(np.cross(to_world[:3, 0], to_world[:3, 1]))
        radiance = e / area if light["normalize"] else e
        return {"type": shape, "to_world": self.transform(to_world), "flip_normals": True,
                "bsdf": BLACK, "emitter": {"type": "area", "radiance": rgb(radiance)}}

    def cylinder_light(self, light, e, m):
        """A cylinder light along the light's X axis, emitting from its side."""
        r, half = light["radius"], light["length"] / 2.0
        scales = np.linalg.norm(m[:3, :3], axis=0)
        p0 = (m @ np.array([-half, 0.0, 0.0, 1.0]))[:3]
        p1 = (m @ np.array([half, 0.0, 0.0, 1.0]))[:3]
        radius = r * (scales[1] + scales[2]) / 2.0
        area = 2.0 * math.pi * radius * np.linalg.norm(p1 - p0)
        radiance = e / area if light["normalize"] else e
        return {"type": "cylinder", "p0": p0.tolist(), "p1": p1.tolist(), "radius": radius,
                "bsdf": BLACK, "emitter": {"type": "area", "radiance": rgb(radiance)}}

    # ------------------------------------------------------------- materials

    def bsdf(self, index):
        """A material (UNBOUND for none) as `twosided` `diffuse`, or an approximating
        `principled` (reported), inside a `normalmap` when it has one."""
        mat = self.material_record(index)
        if mat.get("model") == "open_pbr":
            self.warn(f"material {mat['path']}: OpenPBR not converted (rendered as "
                      "UsdPreviewSurface's default grey plastic; to_cycles.py converts it)")
        base = self.input(mat, "diffuse_color", GREY, "color")
        if self.is_lambert(mat):
            return twosided(self.normal_mapped(mat, {"type": "diffuse", "reflectance": base}))
        self.warn(f"material {mat['path']}: UsdPreviewSurface approximated by Mitsuba's principled BSDF")
        opacity = self.constant(mat, "opacity", 1.0)
        if self.texture(mat, "opacity"):
            self.keep_fallback(mat, "opacity", "Mitsuba's spec_trans would need 1 - opacity")
        ior = mat.get("ior", 1.5)
        metallic = self.input(mat, "metallic", 0.0, "scalar")
        if mat.get("use_specular_workflow", False):
            specular = self.constant(mat, "specular_color", [0.0, 0.0, 0.0])
            if self.texture(mat, "specular_color"):
                self.keep_fallback(mat, "specular_color", "read as one ior")
            f0 = min(max(float(np.dot(specular, [0.2126, 0.7152, 0.0722])), 0.0), 0.99)
            ior = (1 + math.sqrt(f0)) / (1 - math.sqrt(f0))
            metallic = 0.0
            self.warn(f"material {mat['path']}: specularColor approximated by "
                      "an ior of the same luminance F0")
        principled = self.normal_mapped(mat, {
            "type": "principled",
            "base_color": base,
            "metallic": metallic,
            "roughness": self.input(mat, "roughness", 0.5, "scalar"),
            "eta": max(float(ior), 1.0001),
            "clearcoat": float(mat.get("clearcoat", 0.0)),
            "clearcoat_gloss": 1.0 - float(mat.get("clearcoat_roughness", 0.01)),
            "spec_trans": 1.0 - float(opacity),
        })
        return principled if opacity < 1 else twosided(principled)

    def input(self, mat, key, default, kind):
        """A material input as a Mitsuba parameter: a `bitmap` for a texture
        (mitsuba_texture.py), else the constant (an RGB spectrum for a colour,
        a float for a scalar); an unrepresentable texture gives its fallback."""
        tex = self.texture(mat, key)
        if tex is not None:
            try:
                return self.bitmaps.bitmap(tex, kind)
            except Unrepresentable as e:
                self.keep_fallback(mat, key, str(e))
        value = self.constant(mat, key, default)
        return rgb(value) if kind == "color" else float(value)

    def normal_mapped(self, mat, bsdf):
        """`bsdf` inside Mitsuba's `normalmap` when the material has a normal map.

        Both renderers read the map in the shading frame (x along dp/du
        projected onto the shading normal, y = n x x) after 2 v - 1 (the bake
        re-encodes a map whose scale and bias already give [-1, 1]). Mitsuba
        flips a mapped normal facing away from wi (flip_invalid_normals) where
        Cirrus bends it (preview_surface.rs' bend_normal): the same wherever
        the view sees the mapped normal's front. Its `twosided` mirrors wi
        instead of flipping the mapped normal, so back faces of normal-mapped
        surfaces differ (reported)."""
        tex = self.texture(mat, "normal")
        if tex is None:
            return bsdf
        try:
            normalmap = self.bitmaps.bitmap(tex, "normal")
        except Unrepresentable as e:
            self.warn(f"material {mat['path']}: normal map not converted ({e})")
            return bsdf
        self.warn(f"material {mat['path']}: normal map on back faces differs (Mitsuba's twosided "
                  "mirrors the direction, Cirrus flips the mapped normal)")
        # No shadow-terminator term (Estevez et al. 2019, Mitsuba's default): Cirrus has none.
        return {"type": "normalmap", "normalmap": normalmap, "bsdf": bsdf,
                "use_shadowing_function": False}

    def emitter(self, index):
        """An area emitter for an emissive material (textured or not black), else None."""
        mat = self.material_record(index)
        if not self.texture(mat, "emissive_color") and max(self.constant(mat, "emissive_color", [0.0] * 3)) <= 0:
            return None
        return {"type": "area", "radiance": self.input(mat, "emissive_color", [0.0] * 3, "color")}

    # ---------------------------------------------------------------- shapes

    def shapes(self):
        """Every placed mesh: baked for single instances, shapegroup + instances otherwise."""
        placements = {}
        for proto, world in self.scene.instances():
            placements.setdefault(proto, []).append(world)
        out = {}
        for proto, worlds in placements.items():
            parts = self.manifest["prototypes"][proto]["meshes"]
            pieces = [(ply, affine4(part["transform"]))
                      for part in parts for ply in self.mesh_plys(part["mesh"])]
            if not pieces:
                continue
            emissive = any(self.emitter(ply.material) is not None for ply, _ in pieces)
            if len(worlds) == 1 or emissive:
                for w_i, world in enumerate(worlds):
                    for p_i, (ply, part) in enumerate(pieces):
                        out[f"shape_{proto}_{w_i}_{p_i}"] = self.ply_shape(ply, world @ part)
                continue
            group = {"type": "shapegroup"}
            for p_i, (ply, part) in enumerate(pieces):
                group[f"part_{p_i}"] = self.ply_shape(ply, part)
            out[f"group_{proto}"] = group
            for w_i, world in enumerate(worlds):
                out[f"instance_{proto}_{w_i}"] = {
                    "type": "instance",
                    "shapegroup": {"type": "ref", "id": f"group_{proto}"},
                    "to_world": self.transform(world),
                }
        return out

    def ply_shape(self, ply, to_world):
        """A `ply` shape with the material's BSDF (and emitter); flat-shaded without normals."""
        shape = {"type": "ply", "filename": str(ply.path), "to_world": self.transform(to_world),
                 "face_normals": ply.flat, "bsdf": self.bsdf(ply.material)}
        light = self.emitter(ply.material)
        if light is not None:
            shape["emitter"] = light
        return shape

    def mesh_plys(self, mesh_index):
        """A PlyPart for each material of one mesh, written once."""
        if mesh_index in self.plys:
            return self.plys[mesh_index]
        mesh = self.manifest["meshes"][mesh_index]
        points = self.scene.array(mesh["points"])
        triangles = self.scene.array(mesh["triangles"])
        normals = self.scene.array(mesh["normals"]) if mesh.get("normals") else None
        uvs = self.scene.array(mesh["uvs"]) if mesh.get("uvs") else None
        materials = self.scene.array(mesh["triangle_materials"])
        if mesh.get("double_sided") and any(self.emitter(int(m)) for m in np.unique(materials)):
            self.warn(f"mesh {mesh['path']}: double-sided emission rendered one-sided")
        out = []
        for mat in np.unique(materials):
            path = self.workdir / f"mesh{mesh_index}_mat{int(mat)}.ply"
            write_ply(path, points, triangles[materials == mat], normals, uvs)
            out.append(PlyPart(path, int(mat), normals is None))
        self.plys[mesh_index] = out
        return out

    # --------------------------------------------------------------- volumes

    def volumes(self):
        """Every placed volume as a null-BSDF box holding a heterogeneous medium."""
        out = {}
        grids = {}
        for proto, world in self.scene.instances():
            for part in self.manifest["prototypes"][proto]["volumes"]:
                vol = self.manifest["volumes"][part["volume"]]
                field = vol["fields"]["density"]
                key = (field["file"], field["grid"], field["index"])
                if key not in grids:
                    grids[key] = self.grid_to_vol(field, len(grids))
                placed = world @ affine4(part["transform"])
                n = len(out) // 2
                box, out[f"medium_{n}"] = self.medium_box(vol, grids[key], placed)
                box["interior"] = {"type": "ref", "id": f"medium_{n}"}
                out[f"volume_{n}"] = box
        self.warn_overlaps([box["to_world"] for key, box in out.items() if key.startswith("volume_")])
        return out

    def place_camera_medium(self, d):
        """Starts camera rays in the medium whose box holds the eye (Mitsuba needs telling)."""
        eye = affine4(self.manifest["camera"]["transform"])[:3, 3]
        for key, box in d.items():
            if key.startswith("volume_"):
                box_from_world = np.linalg.inv(np.array(box["to_world"].matrix, dtype=np.float64))
                local = box_from_world @ np.append(eye, 1.0)
                if np.all(np.abs(local[:3]) < 1.0):
                    d["sensor"]["medium"] = dict(box["interior"])
                    return

    def warn_overlaps(self, cubes):
        """Warns when the world bounds of two medium boxes meet: Mitsuba media cannot overlap."""
        corners = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        bounds = []
        for cube in cubes:
            world = corners @ np.array(cube.matrix, dtype=np.float64).T
            bounds.append((world[:, :3].min(axis=0), world[:, :3].max(axis=0)))
        for i, (lo_a, hi_a) in enumerate(bounds):
            for lo_b, hi_b in bounds[i + 1:]:
                if np.all(lo_a < hi_b) and np.all(lo_b < hi_a):
                    self.warn("volumes: the bounds of two volumes overlap; Mitsuba media cannot "
                              "overlap (Cirrus adds their extinctions), so the overlap renders wrong")
                    return

    def grid_to_vol(self, field, n):
        """Runs vdb_to_vol.py with Debian's Python; returns its placement record and the .vol path."""
        vol_path = self.workdir / f"grid{n}.vol"
        script = Path(__file__).with_name("vdb_to_vol.py")
        result = subprocess.run(
            [SYSTEM_PYTHON, str(script), field["file"], field["grid"], str(field["index"]),
             str(vol_path)],
            capture_output=True, text=True, check=False)
        if result.returncode != 0:
            raise SystemExit(f"error: {script.name} failed on {field['file']}:\n{result.stderr}")
        info = json.loads(result.stdout)
        info["path"] = vol_path
        if info["negative"] or info["non_finite"]:
            self.warn(f"grid {field['grid']}: {info['negative']} negative and {info['non_finite']} "
                      "non-finite values written as 0 (as Cirrus reads them)")
        if info["background"] != 0:
            self.warn(f"grid {field['grid']}: background {info['background']} read as 0")
        return info

    def medium_box(self, vol, grid, world_from_volume):
        """(the cube shape over the padded grid, the heterogeneous medium inside it)."""
        if vol["fields"].get("temperature") and vol.get("heat_scale", 0) > 0:
            self.warn(f"volume {vol['path']}: emission (temperature) not converted")
        world_from_index = world_from_volume @ affine4(np.asarray(grid["world_from_index"]).ravel())
        lo = np.asarray(grid["index_min"])
        shape = np.asarray(grid["shape"], dtype=np.float64)
        unit_to_index = np.eye(4)
        unit_to_index[:3, :3] = np.diag(shape)
        unit_to_index[:3, 3] = lo
        grid_to_world = world_from_index @ unit_to_index
        # Mitsuba's cube spans [-1, 1]^3; mirror it when the map flips orientation,
        # so its normals still point out and the medium stays inside.
        unit_from_cube = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])
        cube = grid_to_world @ unit_from_cube
        if np.linalg.det(cube[:3, :3]) < 0:
            cube = cube @ np.diag([-1.0, 1.0, 1.0, 1.0])
        medium = {
            "type": "heterogeneous",
            "sigma_t": {"type": "gridvolume", "filename": str(grid["path"]),
                        "to_world": self.transform(grid_to_world)},
            "scale": cirrus_scene.density_scale(vol),
            "albedo": {"type": "constvolume", "value": rgb(vol["albedo"])},
            "phase": {"type": "hg", "g": float(vol["anisotropy"])},
        }
        return {"type": "cube", "to_world": self.transform(cube), "bsdf": {"type": "null"}}, medium


class PlyPart(NamedTuple):
    """One mesh's triangles of one material, written as a PLY file."""

    path: Path
    material: int
    #: True when the mesh has no normals: Cirrus then shades with face normals.
    flat: bool


def rgb(value):
    """An RGB spectrum entry (linear Rec.709, used as is by the *_rgb variants)."""
    return {"type": "rgb", "value": [float(v) for v in value]}


def twosided(bsdf):
    """The BSDF on both sides of the surface, as Cirrus shades back faces."""
    return {"type": "twosided", "material": bsdf}


def write_ply(path, points, triangles, normals, uvs):
    """A binary little-endian PLY with vertex normals when given (else flat faces)
    and USD's st as (u, v) when given (mitsuba_texture.py flips t in each bitmap)."""
    columns = [points]
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(points)}",
              "property float x", "property float y", "property float z"]
    if normals is not None:
        header += ["property float nx", "property float ny", "property float nz"]
        columns.append(normals)
    if uvs is not None:
        header += ["property float u", "property float v"]
        columns.append(uvs)
    header += [f"element face {len(triangles)}", "property list uchar int vertex_indices", "end_header"]
    face = np.zeros(len(triangles), dtype=[("n", "u1"), ("i", "<i4", 3)])
    face["n"] = 3
    face["i"] = triangles
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(np.ascontiguousarray(np.hstack(columns), dtype="<f4").tobytes())
        f.write(face.tobytes())
