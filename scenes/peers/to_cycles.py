"""Renders an exported Cirrus scene folder with Blender Cycles into an EXR of the same framing.

Usage (Blender 5.0: the `bpy` wheel in .venv-cycles; Debian's blender 3.4 where
installed; both installed by `scenes/peers/install --cycles`):
    .venv-cycles/bin/python scenes/peers/to_cycles.py \\
        SCENE_DIR OUT.exr --spp 64 --threads 2 --seed 1 [--res WxH] [--max-depth 1024]
    blender -b --factory-startup -t 2 --python scenes/peers/to_cycles.py -- \\
        SCENE_DIR OUT.exr --spp 64 --threads 2 --seed 1 [--res WxH] [--max-depth 1024]

SCENE_DIR is what `cirrus export` writes (exporter/FORMAT.md), read with
cirrus_scene.py in Blender's Python (the venv's, or Debian's python3 + numpy
for 3.4). The output
is a float RGB EXR of linear Rec.709 radiance (Blender's scene-linear space,
view transform "Standard", nothing applied on EXR output), box-filtered over
one pixel. What is approximated is printed as `warning: ...` on stderr. The
last line is `render_seconds=S`: the timed render call alone; with --warmup the
same render runs first, untimed, to sync the scene and build the BVH, which
persistent data keeps (it ignores a changed sample count, so the warm-up cannot
be cheaper), so S excludes scene load as for the other renderers (5.0 stamps
the timed render's synchronization_time 0 and its render_time within 10 ms of
S), and `sync_seconds=` (warm-up less S) comes before it: 5.0's sync, which
prepares the volumes, takes seconds (14 s on the teapot cloud, under load).

Blender 5.0 against 3.4, each convention checked (2026-12-02, tests/it/peers.rs):
world-space density, sun, sphere-light and world units are unchanged
(volume_teapot and surface_lights agree as with 3.4); area lights' power is
pi A L, not 4 A L (area_power_factor); the half-voxel shift is gone (voxel_shift);
Principled BSDF inputs were renamed in 4.0 (PRINCIPLED_4); `use_auto_smooth`
went in 4.1 and `use_nodes` is deprecated in 5.0; `scene.cycles.volume_biased`
(5.0) stays False: unbiased null scattering, Cycles' default, where
volume_step_rate and volume_max_steps no longer apply; the wheel takes no `-t`
(render.threads with threads_mode FIXED sets the threads).

What each part becomes (UsdLux units per docs/conventions.md, "Lights"; every
factor below was measured with Cycles 3.4.1 on a white Lambert plane
(2026-11-24): sun 3 W/m^2 -> 0.95493 = 3/pi; point 10 W at 2 units ->
0.063324 = 10/(4 pi^2 4); 10 W square area light of 0.01 unit^2 at 2 units ->
0.19876 = (10/(4 x 0.01)) x 0.01/4/pi; world strength 1 -> 1):

- Camera: Blender cameras, like USD's, look down -Z with +Y up, so the object
  matrix is the camera transform (scale removed; clipping scaled by it).
  Horizontal sensor fit, lens / sensor width = focalLength / the aperture
  conformed by "expandAperture" (sensor 36 mm: Blender clamps both at 1 mm).
  Orthographic: ortho_scale = conformed aperture / 10. Thin lens: Cycles'
  aperture radius is lens x 1e-3 / (2 fstop), ours focalLength / 10 / (2 fStop)
  x scale, so aperture_fstop = lens x 1e-3 / (2 x our radius); round blades.
- Meshes: one Blender mesh per exported mesh (custom split normals when it has
  normals, else flat faces), one object per placement sharing that mesh (Cycles
  instances linked duplicates). Cycles shades both sides, as Cirrus does.
- Materials: Lambert (the specular workflow with zero specularColor) is a
  Diffuse BSDF (roughness 0); anything else is approximated by the Principled
  BSDF (reported), including triangles without a material and materials the
  exporter could not read (UsdPreviewSurface's defaults, a grey plastic, as
  Cirrus renders them); OpenPBR records (`model: open_pbr`, standard_surface
  included) become a Principled BSDF input by input (cycles_openpbr.py says
  how and what differs); emissiveColor is an Emission shader of strength 1
  (radiance = colour) added on top. Textured diffuseColor, emissiveColor,
  metallic and roughness are Image Texture node chains on the meshes' st (UV
  layer "st") and a normal map a Normal Map node (cycles_texture.py says how,
  and what is refused); textured opacity and specularColor (read as one
  Transmission and Specular level) and unrepresentable textures keep their
  fallback (reported); a texture whose image is missing reads its fallback in
  Cirrus too.
- Lights: Blender light power is not UsdLux emission; with e = color x
  intensity x 2^exposure and A the world area:
  - DomeLight: world Background, colour e, strength 1 (radiance).
  - DistantLight: Sun, strength = irradiance (e with normalize, else
    e pi sin^2(angle/2), as src/lights/distant.rs), angle = `angle`.
  - SphereLight of radius r: Point light of radius r; Cycles gives it the
    intensity P/(4 pi) W/sr, a sphere of radiance L radiates 4 pi^2 r^2 L, so
    P = 4 pi^2 r^2 L (L = e, or e/(4 pi r^2) with normalize). Cycles 3.4 draws
    it as a disk facing the shaded point, not a sphere: the same solid angle up
    to r^2/d^2 terms. treatAsPoint: radius 0, P = 4 pi I with Mitsuba's I.
  - RectLight / DiskLight: Area light (rectangle / disk of diameter 2r),
    one-sided along -Z as UsdLux; Cycles 3.4's radiance is P / (4 A), so
    P = 4 A L; 5.0's is P / (pi A), so P = pi A L (area_power_factor).
  - CylinderLight: not converted (reported).
  Power and colour are RGB in UsdLux and a scalar x colour in Blender: energy =
  the largest channel, colour = the rest relative to it. Every light is made
  visible to camera rays (Cycles 3.4 hides them by default; Cirrus shows them).
- Volumes: `bpy.data.volumes.new` + `filepath` = the VDB, placed by the Volume
  prim's transform (Blender applies the grid's own index-to-world inside).
  render.space = WORLD, so density counts per world unit (Blender's default,
  OBJECT, keeps optical depth fixed under object scale, i.e. divides by it);
  precision FULL (not half floats); clipping 0 (no voxel dropped); Principled
  Volume with Density = densityScale reading the density grid, Color = albedo,
  Absorption Color black (so sigma_t = density, sigma_s = albedo x density),
  Anisotropy = g. Voxel placement: Cycles 3.4 is half a voxel off; the object
  is moved by -0.5 voxel along the grid's index axes to compensate; 5.0 needs
  no shift (voxel_shift).
- Motion blur: with the camera's shutter open, Cycles' motion blur with a
  box shutter of the same length, centred (motion_blur_position CENTER), and
  each moving instance keyed (location, quaternion rotation, scale; linear)
  at its key times shifted by the shutter's centre, so our shutter [open,
  close] around the frame is Cycles' (scenes/peers/motion_sphere.usda: 0.02%,
  relMSE 3.8e-5; centred on the frame instead, 3.4e-3). Camera motion and
  volume velocities are not converted (warned).
- Integrator: path tracing on the CPU, no denoiser, no adaptive sampling, no
  clamping, no glossy blur, box filter of width 1 pixel. Cirrus' --max-depth
  counts scattering events (1 = direct light only) and Cycles' bounces count
  the ones after the first, so every Cycles bounce limit = ours - 1 (1023 for
  our unbiased default 1024: no cap that matters). Cycles 3.4 ray-marches
  heterogeneous volumes (step = one voxel x --volume-step-rate): slightly
  biased, unlike Cirrus' and Mitsuba's null-collision tracking; 5.0 tracks
  null collisions (unbiased), like them.
"""

import argparse
import math
import sys
import time
from pathlib import Path

import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cirrus_scene  # noqa: E402
import cycles_openpbr  # noqa: E402
from cirrus_scene import (GREY, CirrusScene, affine4, conformed_aperture,  # noqa: E402
                          distant_irradiance, emission, near_far, parse_resolution)
from cycles_texture import UV_LAYER, TextureNodes, Unrepresentable  # noqa: E402

def voxel_shift():
    """Shift of the grid, in voxels along each index axis, that puts VDB value
    v(i,j,k) at the integer index point (i,j,k) in Cycles (docs/conventions.md,
    "Voxel centres").

    Cycles 3.4 puts it at the voxel's cell centre, (i,j,k) + 0.5, half a voxel
    off: on scenes/peers/volume_voxels.usda (64x64, 64 spp, 2026-11-24) a shift
    of 0 reads 4.0% dark with a 4x4 relMSE of 4.3e-2 against Cirrus, +0.5 8.6%
    and 0.23, -0.5 agrees (0.06%, 1.1e-3). The one-voxel falloff to the
    background needs nothing more (without it the mean would be ~9% off).
    Cycles 5.0 samples values at their index points: on the same scene (64x64,
    256 spp, 2026-12-02) a shift of 0 agrees (0.17%, relMSE 4.3e-4) and -0.5
    reads 3.2% dark (relMSE 2.4e-2)."""
    return -0.5 if bpy.app.version < (5, 0, 0) else 0.0


#: Principled BSDF inputs renamed by Blender 4.0, by their 3.x name.
PRINCIPLED_4 = {"Clearcoat": "Coat Weight", "Clearcoat Roughness": "Coat Roughness",
                "Transmission": "Transmission Weight", "Specular": "Specular IOR Level"}


def principled_input(node, name):
    """The Principled BSDF input of 3.x name `name` in this Blender."""
    return node.inputs[PRINCIPLED_4.get(name, name) if bpy.app.version >= (4, 0, 0) else name]


#: Blender sensor width, mm: the lens is scaled to keep USD's focal length to aperture ratio.
SENSOR_WIDTH = 36.0
#: UsdLux light types that Cirrus treats as opaque surfaces.
AREA_LIGHTS = ("sphere", "rect", "disk", "cylinder")


def arguments(argv):
    """The command line after Blender's `--`."""
    p = argparse.ArgumentParser(prog="to_cycles.py", description=__doc__.split("\n\n")[0])
    p.add_argument("scene", type=Path, help="exported Cirrus scene folder")
    p.add_argument("output", type=Path, help="output EXR")
    p.add_argument("--res", type=parse_resolution, help="WxH (default: the scene's, else 640x480)")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel (64)")
    p.add_argument("--seed", type=int, default=0, help="Cycles seed (0)")
    p.add_argument("--max-depth", type=int, default=1024, help="Cirrus' --max-depth: scattering events (1024, its unbiased default)")
    p.add_argument("--threads", type=int, default=2, help="render threads (2)")
    p.add_argument("--volume-step-rate", type=float, default=1.0,
                   help="Cycles' volume step rate: step = voxel size x this (1, Cycles' default)")
    p.add_argument("--voxel-shift", type=float, default=voxel_shift(),
                   help=f"grid shift in voxels ({voxel_shift()} for Cycles {bpy.app.version_string}; "
                        "for the placement checks)")
    p.add_argument("--warmup", action="store_true",
                   help="render 1 spp untimed first (scene sync and BVH build)")
    return p.parse_args(argv)


class Converter(cirrus_scene.Converter):
    """Builds one CirrusScene into Blender's current (emptied) scene; `warnings` lists
    what was approximated."""

    def __init__(self, scene, args):
        super().__init__(scene)
        self.args = args
        self.width, self.height = args.res or tuple(self.manifest["render"]["resolution"] or (640, 480))
        self.bl = bpy.context.scene
        #: Mesh index -> its Blender mesh, so a mesh shared by placements is built once.
        self.meshes = {}
        #: Material index -> its Blender material.
        self.materials = {}
        #: (image file, colour space) -> its Blender image, shared by materials.
        self.images = {}
        #: The shutter's centre, frames relative to the frame (motion_blur).
        self.shutter_centre = 0.0

    def link(self, name, data, matrix):
        """A new object holding `data`, placed by the 4x4 numpy `matrix`, in the scene."""
        obj = bpy.data.objects.new(name, data)
        obj.matrix_world = matrix_of(matrix)
        self.bl.collection.objects.link(obj)
        return obj

    # ------------------------------------------------------------------ build

    def build(self):
        """The whole scene: settings, camera, lights, meshes, volumes."""
        self.settings()
        self.motion_blur()
        self.camera()
        self.world()
        lights = self.manifest["lights"]
        for light in lights:
            self.light(light)
        if len(lights) > 1 and any(light["type"] in AREA_LIGHTS for light in lights):
            self.warn("lights: Cycles' lights are transparent to every ray but the camera's; "
                      "where an area light hides another light or the dome, Cirrus (whose "
                      "lights are opaque) is darker")
        self.shapes()
        self.volumes()
        self.bl.frame_set(self.bl.frame_current)  # the keyed objects at the frame
        for w in self.manifest.get("warnings", []):
            self.warn(f"exporter: {w}")

    def settings(self):
        """Cycles on the CPU, unbiased settings, the film and the EXR output."""
        render, cycles = self.bl.render, self.bl.cycles
        render.engine = "CYCLES"
        render.resolution_x, render.resolution_y = self.width, self.height
        render.resolution_percentage = 100
        render.pixel_aspect_x = render.pixel_aspect_y = 1.0
        render.threads_mode = "FIXED"
        render.threads = self.args.threads
        render.use_persistent_data = True
        render.film_transparent = False
        render.image_settings.file_format = "OPEN_EXR"
        render.image_settings.color_mode = "RGB"
        render.image_settings.color_depth = "32"
        render.image_settings.exr_codec = "ZIP"
        view = self.bl.view_settings
        view.view_transform, view.look, view.exposure, view.gamma = "Standard", "None", 0.0, 1.0
        cycles.device = "CPU"
        cycles.samples = self.args.spp
        cycles.seed = self.args.seed
        cycles.use_adaptive_sampling = False
        cycles.use_denoising = False
        cycles.pixel_filter_type = "BOX"
        cycles.filter_width = 1.0
        cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
        cycles.blur_glossy = 0.0
        cycles.caustics_reflective = cycles.caustics_refractive = True
        bounces = max(self.args.max_depth - 1, 0)
        for key in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                    "volume_bounces", "transparent_max_bounces"):
            setattr(cycles, key, bounces)
        cycles.volume_step_rate = self.args.volume_step_rate
        cycles.volume_max_steps = 4096
        if hasattr(cycles, "volume_biased"):
            cycles.volume_biased = False  # 5.0: null scattering, its default

    # ---------------------------------------------------------------- camera

    def camera(self):
        """The camera: perspective, thin lens or orthographic."""
        cam = self.manifest["camera"]
        if cam["path"] is None:
            raise SystemExit("error: the scene has no camera prim (Cirrus frames a default one; not converted)")
        if cam["horizontal_aperture_offset"] or cam["vertical_aperture_offset"]:
            self.warn("camera: aperture offsets not converted")
        world_from_camera = affine4(cam["transform"])
        linear = world_from_camera[:3, :3]
        scales = np.linalg.norm(linear, axis=0)
        if np.ptp(scales) > 1e-4 * scales.max():
            self.warn("camera: non-uniform scale dropped")
        scale = float(np.cbrt(abs(np.linalg.det(linear))))
        rigid = world_from_camera.copy()
        rigid[:3, :3] = linear / scales
        aperture = conformed_aperture(cam, self.width, self.height)
        near, far = near_far(self.manifest)
        data = bpy.data.cameras.new("camera")
        data.sensor_fit = "HORIZONTAL"
        data.clip_start, data.clip_end = near * scale, far * scale
        if cam["projection"] == "orthographic":
            data.type = "ORTHO"
            data.ortho_scale = aperture[0] / 10.0 * scale
        else:
            data.type = "PERSP"
            # Blender clamps sensor and lens to 1 mm and more; only their ratio matters.
            data.sensor_width = SENSOR_WIDTH
            data.lens = cam["focal_length"] * SENSOR_WIDTH / aperture[0]
            if cam["f_stop"] > 0 and cam["focus_distance"] > 0:
                radius = cam["focal_length"] / 10.0 / (2.0 * cam["f_stop"]) * scale
                data.dof.use_dof = True
                data.dof.focus_distance = cam["focus_distance"] * scale
                data.dof.aperture_fstop = data.lens * 1e-3 / (2.0 * radius)
                data.dof.aperture_blades = 0
        self.bl.camera = self.link("camera", data, rigid)

    # ---------------------------------------------------------------- lights

    def world(self):
        """The world: the (first) dome light's radiance, else black."""
        world = bpy.data.worlds.new("world")
        use_nodes(world)
        background = world.node_tree.nodes["Background"]
        domes = [light for light in self.manifest["lights"] if light["type"] == "dome"]
        radiance = sum((emission(d) for d in domes), np.zeros(3))
        for dome in domes:
            if dome.get("texture"):
                self.warn(f"light {dome['path']}: dome texture not converted (constant emission used)")
        background.inputs["Color"].default_value = (*radiance, 1.0)
        background.inputs["Strength"].default_value = 1.0
        self.bl.world = world

    def light(self, light):
        """One UsdLux light as a Blender light (domes are the world)."""
        if light.get("color_temperature") is not None:
            self.warn(f"light {light['path']}: colorTemperature ignored")
        kind, m = light["type"], affine4(light["transform"])
        if kind == "dome":
            return
        if kind == "distant":
            data = bpy.data.lights.new(light["path"], "SUN")
            data.angle = math.radians(light["angle_deg"])
            power = distant_irradiance(light)
        elif kind == "sphere":
            data, power = self.sphere_light(light, m)
        elif kind in ("rect", "disk"):
            data, power = self.area_light(light, m)
        else:
            self.warn(f"light {light['path']}: type {kind} not converted")
            return
        set_power(data, power)
        # Cirrus' camera rays see lights; Cycles 3.4 hides them from the camera by default.
        self.link(light["path"], data, m).visible_camera = True

    def sphere_light(self, light, m):
        """A Point light of the sphere's radius (or 0) and the power radiating its radiance."""
        e = emission(light)
        radius = light["radius"] * float(np.linalg.norm(m[:3, :3], axis=0).mean())
        data = bpy.data.lights.new(light["path"], "POINT")
        if light["treat_as_point"]:
            data.shadow_soft_size = 0.0
            intensity = e / 4.0 if light["normalize"] else math.pi * radius**2 * e
            return data, 4.0 * math.pi * intensity
        data.shadow_soft_size = radius
        radiance = e / (4.0 * math.pi * radius**2) if light["normalize"] else e
        return data, 4.0 * math.pi**2 * radius**2 * radiance

    def area_light(self, light, m):
        """An Area light (rectangle or disk) with P = k A L (area_power_factor); Blender
        scales its size by the object's."""
        data = bpy.data.lights.new(light["path"], "AREA")
        if light["type"] == "rect":
            if light.get("texture"):
                self.warn(f"light {light['path']}: rect texture not converted")
            data.shape = "RECTANGLE"
            data.size, data.size_y = light["width"], light["height"]
            unit_area = light["width"] * light["height"]
        else:
            data.shape = "DISK"
            data.size = 2.0 * light["radius"]
            unit_area = math.pi * light["radius"] ** 2
        area = unit_area * float(np.linalg.norm(np.cross(m[:3, 0], m[:3, 1])))
        e = emission(light)
        radiance = e / area if light["normalize"] else e
        return data, area_power_factor() * area * radiance

    # ------------------------------------------------------------- materials

    def material(self, index):
        """The Blender material of a Cirrus material index, built once."""
        if index not in self.materials:
            self.materials[index] = self.build_material(index)
        return self.materials[index]

    def build_material(self, index):
        """Diffuse BSDF for Lambert, else an approximating Principled BSDF; plus emission."""
        mat = self.material_record(index)
        out = bpy.data.materials.new(f"material{index}")
        use_nodes(out)
        nodes, links = out.node_tree.nodes, out.node_tree.links
        nodes.remove(nodes["Principled BSDF"])
        output = nodes["Material Output"]
        textures = TextureNodes(out.node_tree, self.images)
        if mat.get("model") == "open_pbr":
            surface = cycles_openpbr.principled(self, textures, mat)
        elif self.is_lambert(mat):
            surface = diffuse(nodes, GREY)
            self.set_input(textures, mat, "diffuse_color", GREY, surface.inputs["Color"])
            self.normal_map(textures, mat, surface.inputs["Normal"])
        else:
            surface = self.principled(textures, mat)
        if self.emits(index):
            glow = nodes.new("ShaderNodeEmission")
            self.set_input(textures, mat, "emissive_color", [0.0] * 3, glow.inputs["Color"])
            glow.inputs["Strength"].default_value = 1.0
            add = nodes.new("ShaderNodeAddShader")
            links.new(surface.outputs[0], add.inputs[0])
            links.new(glow.outputs[0], add.inputs[1])
            surface = add
        links.new(surface.outputs[0], output.inputs["Surface"])
        return out

    def emits(self, index):
        """Whether material `index` has a textured or non-zero emissiveColor."""
        mat = self.material_record(index)
        return bool(self.texture(mat, "emissive_color")) or max(
            self.constant(mat, "emissive_color", [0.0] * 3)) > 0

    def set_input(self, textures, mat, key, default, socket):
        """Feeds a material input to a node socket: a texture's node chain
        (cycles_texture.py), else the constant; an unrepresentable texture
        gives its fallback (reported)."""
        tex = self.texture(mat, key)
        if tex is not None:
            kind = "color" if isinstance(default, list) else "scalar"
            try:
                textures.links.new(textures.output(tex, kind), socket)
                return
            except Unrepresentable as e:
                self.keep_fallback(mat, key, str(e))
        value = self.constant(mat, key, default)
        socket.default_value = (*value, 1.0) if isinstance(default, list) else float(value)

    def normal_map(self, textures, mat, socket):
        """Feeds the material's normal map, if any, to a BSDF's Normal socket."""
        tex = self.texture(mat, "normal")
        if tex is None:
            return
        try:
            textures.links.new(textures.output(tex, "normal"), socket)
        except Unrepresentable as e:
            self.warn(f"material {mat['path']}: normal map not converted ({e})")

    def principled(self, textures, mat):
        """An approximation of a non-Lambert UsdPreviewSurface by Cycles' Principled BSDF."""
        self.warn(f"material {mat['path']}: UsdPreviewSurface approximated by Cycles' Principled BSDF")
        node = textures.nodes.new("ShaderNodeBsdfPrincipled")
        opacity = self.constant(mat, "opacity", 1.0)
        if self.texture(mat, "opacity"):
            self.keep_fallback(mat, "opacity", "read as one Transmission")
        self.set_input(textures, mat, "diffuse_color", GREY, node.inputs["Base Color"])
        self.set_input(textures, mat, "roughness", 0.5, node.inputs["Roughness"])
        self.normal_map(textures, mat, node.inputs["Normal"])
        node.inputs["IOR"].default_value = max(float(mat.get("ior", 1.5)), 1.0001)
        principled_input(node, "Clearcoat").default_value = float(mat.get("clearcoat", 0.0))
        principled_input(node, "Clearcoat Roughness").default_value = float(mat.get("clearcoat_roughness", 0.01))
        principled_input(node, "Transmission").default_value = 1.0 - float(opacity)
        if mat.get("use_specular_workflow", False):
            specular = self.constant(mat, "specular_color", [0.0] * 3)
            if self.texture(mat, "specular_color"):
                self.keep_fallback(mat, "specular_color", "read as one Specular level")
            # Principled "Specular" 0.5 is F0 = 0.04: scale the luminance F0 to it.
            f0 = float(np.dot(specular, [0.2126, 0.7152, 0.0722]))
            principled_input(node, "Specular").default_value = min(f0 / 0.08, 1.0)
            self.warn(f"material {mat['path']}: specularColor approximated by its luminance F0")
        else:
            self.set_input(textures, mat, "metallic", 0.0, node.inputs["Metallic"])
        return node

    # ---------------------------------------------------------------- shapes

    def shapes(self):
        """Every placed mesh as an object sharing its mesh data with the other placements."""
        motion = self.instance_motion()
        for n, (proto, world) in enumerate(self.scene.instances()):
            for p_i, part in enumerate(self.manifest["prototypes"][proto]["meshes"]):
                mesh = self.mesh(part["mesh"])
                local = affine4(part["transform"])
                obj = self.link(f"instance{n}_{p_i}", mesh, world @ local)
                if n in motion:
                    self.key_motion(obj, [key @ local for key in motion[n]])

    # ---------------------------------------------------------------- motion

    def motion_blur(self):
        """Cycles' motion blur over the camera's shutter (frames relative to the frame,
        exporter/FORMAT.md): a box shutter (Cycles' default flat curve) of length close -
        open centred on the frame; the keys are shifted by the shutter's centre
        (key_frame), so any shutter, centred or not, maps onto Cycles' centred one."""
        cam = self.manifest["camera"]
        shutter_open, shutter_close = cam.get("shutter") or (0.0, 0.0)
        render = self.bl.render
        render.use_motion_blur = shutter_close > shutter_open
        if not render.use_motion_blur:
            return
        render.motion_blur_shutter = shutter_close - shutter_open
        render.motion_blur_position = "CENTER"
        self.shutter_centre = (shutter_open + shutter_close) / 2.0
        if cam.get("motion"):
            self.warn("camera: camera motion not converted (the camera stays at the frame's transform)")
        for volume in self.manifest.get("volumes", []):
            if volume["fields"].get("velocity"):
                self.warn(f"volume {volume['path']}: velocity (motion blur) not converted")

    def key_frame(self, time):
        """The Blender frame of a key time (frames relative to the frame) such that Cycles'
        centred shutter spans our [open, close]."""
        return self.bl.frame_current + time - self.shutter_centre

    def instance_motion(self):
        """Instance index -> its world-from-prototype 4x4 at each key time (instances.motion)."""
        motion = self.manifest["instances"].get("motion")
        if not motion or not self.bl.render.use_motion_blur:
            return {}
        keys = len(motion["times"])
        transforms = self.scene.array(motion["transform"])
        return {int(n): [affine4(t) for t in transforms[i * keys:(i + 1) * keys]]
                for i, n in enumerate(self.scene.array(motion["instance"]))}

    def key_motion(self, obj, matrices):
        """Keys an object's location, rotation and scale at every key time, linearly
        interpolated (Blender then holds the end keys, as Cirrus does). Blender decomposes
        each matrix (shear is lost, warned) and interpolates quaternion components where
        Cirrus lerps matrices: the same for translation and scale, close for small turns."""
        obj.rotation_mode = "QUATERNION"
        bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
        for time, matrix in zip(self.manifest["instances"]["motion"]["times"], matrices):
            linear = matrix[:3, :3]
            gram = linear.T @ linear
            if np.abs(gram - np.diag(np.diag(gram))).max() > 1e-4 * np.abs(gram).max():
                self.warn(f"{obj.name}: sheared motion key decomposed (shear lost)")
            obj.matrix_world = matrix_of(matrix)
            frame = self.key_frame(time)
            for path in ("location", "rotation_quaternion", "scale"):
                obj.keyframe_insert(path, frame=frame)

    def mesh(self, index):
        """The Blender mesh of exported mesh `index` (triangles, per-face material slots)."""
        if index in self.meshes:
            return self.meshes[index]
        record = self.manifest["meshes"][index]
        points = self.scene.array(record["points"]).astype(np.float32)
        triangles = self.scene.array(record["triangles"]).astype(np.int32)
        materials = self.scene.array(record["triangle_materials"])
        mesh = bpy.data.meshes.new(record["path"])
        mesh.vertices.add(len(points))
        mesh.vertices.foreach_set("co", points.ravel())
        mesh.loops.add(3 * len(triangles))
        mesh.loops.foreach_set("vertex_index", triangles.ravel())
        mesh.polygons.add(len(triangles))
        mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(triangles), 3, dtype=np.int32))
        mesh.polygons.foreach_set("loop_total", np.full(len(triangles), 3, dtype=np.int32))
        if record.get("uvs"):
            st = mesh.uv_layers.new(name=UV_LAYER)
            st.data.foreach_set("uv", self.scene.array(record["uvs"])[triangles.ravel()].ravel())
        slots = {int(m): slot for slot, m in enumerate(np.unique(materials))}
        if not record.get("double_sided") and any(self.emits(m) for m in slots):
            self.warn(f"mesh {record['path']}: one-sided emission rendered two-sided "
                      "(Cycles' emission shader emits from both faces)")
        for m in slots:
            mesh.materials.append(self.material(m))
        mesh.polygons.foreach_set("material_index",
                                  np.array([slots[int(m)] for m in materials], dtype=np.int32))
        normals = record.get("normals")
        mesh.polygons.foreach_set("use_smooth", np.full(len(triangles), normals is not None))
        mesh.update()
        mesh.validate()
        if normals is not None:
            if bpy.app.version < (4, 1, 0):  # 4.1 keeps custom normals without it
                mesh.use_auto_smooth = True
            mesh.normals_split_custom_set_from_vertices(
                [tuple(v) for v in self.scene.array(normals).astype(np.float64)])
        self.meshes[index] = mesh
        return mesh

    # --------------------------------------------------------------- volumes

    def volumes(self):
        """Every placed volume: a VDB volume object with a Principled Volume material."""
        for n, (proto, world) in enumerate(self.scene.instances()):
            for v_i, part in enumerate(self.manifest["prototypes"][proto]["volumes"]):
                record = self.manifest["volumes"][part["volume"]]
                self.volume(f"volume{n}_{v_i}", record, world @ affine4(part["transform"]))

    def volume(self, name, record, world_from_volume):
        """One volume object: the density grid per world unit, at integer index points."""
        field = record["fields"]["density"]
        if field["index"] != 0:
            self.warn(f"volume {record['path']}: grid {field['grid']} index {field['index']} "
                      "read as the first grid of that name")
        if record["fields"].get("temperature") and record.get("heat_scale", 0) > 0:
            self.warn(f"volume {record['path']}: emission (temperature) not converted")
        data = bpy.data.volumes.new(name)
        data.filepath = field["file"]
        data.render.space = "WORLD"
        data.render.precision = "FULL"
        data.render.clipping = 0.0
        data.grids.load()
        grid = data.grids.get(field["grid"])
        if grid is None:
            raise SystemExit(f"error: {field['file']} has no grid {field['grid']}")
        if has_no_leaves(field["file"], field["grid"]):
            self.warn(f"volume {record['path']}: grid {field['grid']} holds active tiles only, no "
                      "leaf nodes: Cycles 3.4 renders such a grid empty")
        data.materials.append(self.volume_material(name, record, field["grid"]))
        shift = np.eye(4)
        if self.args.voxel_shift:
            # The grid's index-to-object map, whose columns are the index axes.
            index_to_object = np.array(grid.matrix_object, dtype=np.float64)
            shift[:3, 3] = index_to_object[:3, :3] @ np.full(3, self.args.voxel_shift)
        self.link(name, data, world_from_volume @ shift)

    def volume_material(self, name, record, grid):
        """Principled Volume: density = densityScale x grid, colour = albedo, HG g."""
        mat = bpy.data.materials.new(f"{name}_material")
        use_nodes(mat)
        nodes, links = mat.node_tree.nodes, mat.node_tree.links
        nodes.remove(nodes["Principled BSDF"])
        node = nodes.new("ShaderNodeVolumePrincipled")
        node.inputs["Color"].default_value = (*record["albedo"], 1.0)
        node.inputs["Density"].default_value = cirrus_scene.density_scale(record)
        node.inputs["Density Attribute"].default_value = grid
        node.inputs["Anisotropy"].default_value = float(record["anisotropy"])
        node.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        node.inputs["Emission Strength"].default_value = 0.0
        node.inputs["Blackbody Intensity"].default_value = 0.0
        links.new(node.outputs[0], nodes["Material Output"].inputs["Volume"])
        return mat


def has_no_leaves(path, grid):
    """Whether a VDB grid is all active tiles without leaf nodes (False when Debian's
    pyopenvdb, which Blender's Python shares, is missing). Cycles 3.4 renders such
    grids empty: scenes/tests/volume_shadow.usda (volume_box.vdb, 16^3 voxels in
    tiles) reads unshadowed, 0.5 instead of 0.5/e; the same box rewritten with
    leaves reads 0.18394 (0.5/e = 0.18394)."""
    try:
        import pyopenvdb
    except ImportError:
        return False
    return pyopenvdb.read(path, grid).leafCount() == 0


def area_power_factor():
    """k in an area light's power P = k A L for radiance L over area A: 4 in
    Cycles 3.4 (its radiance is P / (4 A)); pi in 5.0, a Lambertian emitter's
    exitance: the 10 W rect light of scenes/peers/surface_lights.usda alone
    (96x64, 64 spp, 2026-12-02) read 1.273 = 4/pi times Cirrus with k = 4, and
    sphere lights and the dome agree with 3.4's units (0.03%, 0.02%)."""
    return 4.0 if bpy.app.version < (5, 0, 0) else math.pi


def use_nodes(datablock):
    """Gives a new material or world its node tree (5.0 always has one and
    deprecates `use_nodes`)."""
    if bpy.app.version < (5, 0, 0):
        datablock.use_nodes = True


def diffuse(nodes, colour):
    """A Diffuse BSDF node (Lambert: roughness 0) of an RGB albedo."""
    node = nodes.new("ShaderNodeBsdfDiffuse")
    node.inputs["Color"].default_value = (*colour, 1.0)
    node.inputs["Roughness"].default_value = 0.0
    return node


def set_power(data, rgb):
    """A light's RGB power as Blender's scalar energy (the largest channel) x colour."""
    rgb = np.asarray(rgb, dtype=np.float64)
    energy = float(rgb.max())
    data.energy = energy
    data.color = tuple(rgb / energy) if energy > 0 else (0.0, 0.0, 0.0)


def matrix_of(m):
    """A 4x4 numpy matrix as Blender's Matrix."""
    from mathutils import Matrix

    return Matrix(np.asarray(m, dtype=np.float64).tolist())


def main():
    # Blender passes the script's arguments after `--`; the bpy module gets them plainly.
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    args = arguments(argv)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    start = time.time()
    converter = Converter(CirrusScene(args.scene), args)
    converter.build()
    for w in converter.warnings:
        print(f"warning: {w}", file=sys.stderr)
    warmup = 0.0
    if args.warmup:
        # Persistent data keeps the synced scene and BVH but not a changed
        # sample count or seed, so the warm-up renders the very same image.
        timer = time.perf_counter()
        bpy.ops.render.render()
        warmup = time.perf_counter() - timer
    built = time.time()
    timer = time.perf_counter()
    bpy.ops.render.render()
    render_seconds = time.perf_counter() - timer
    args.output.parent.mkdir(parents=True, exist_ok=True)
    bpy.data.images["Render Result"].save_render(str(args.output.resolve()), scene=bpy.context.scene)
    print(f"cycles {bpy.app.version_string}: {converter.width}x{converter.height} {args.spp} spp, "
          f"convert{'+warmup' if args.warmup else ''} {built - start:.1f} s, "
          f"render {render_seconds:.1f} s -> {args.output}")
    if args.warmup:
        # The warm-up is the same render plus the scene sync and BVH build.
        print(f"sync_seconds={max(warmup - render_seconds, 0.0):.6f}")
    print(f"render_seconds={render_seconds:.6f}")


if __name__ == "__main__":
    main()
