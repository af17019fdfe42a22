"""Writes "Teapot Canyon", the production-style demo stage of the quick start.

A desert canyon floor at dusk, authored with usd-core so that it is reproducible
(every random draw comes from fixed seeds) and small in the repository (this
script, not its output, is committed):

  - a heightfield ground and canyon walls with a tiling sand texture
    (UsdPreviewSurface + UsdUVTexture + UsdPrimvarReader_float2);
  - a PointInstancer scattering tens of thousands of rocks: three procedural
    prototypes (displaced icospheres), power-law sizes, random yaw and tilt;
  - native instancing: hoodoo spires, one procedural asset layer referenced
    `instanceable = true` several times, and the CC0 "Fancy" teapot of
    `../shared/assets/usd-wg/full_assets/Teapot` (textured) as the hero props;
  - volumes: the real smoke plume `smoke.vdb` (OpenVDB sample, from
    `../shared/assets/arnold-usd/test_0030`) and the SYNTHETIC explosion of
    `scenes/make_explosion.py` (density + temperature: blackbody emission);
  - a lat-long dusk sky on a DomeLight, a low warm sun (DistantLight) and a
    camera with depth of field focused on the hero teapot;
  - motion blur: the camera's shutter is open from -0.25 to 0.25 frames around
    frame 0 (startTimeCode), a rock tumbles through the air past the hero teapot
    and the smoke plume drifts in the wind (time-sampled transforms).

usage: .venv/bin/python scenes/make_demo.py OUT_DIR --explosion EXPLOSION.vdb
           [--shared ../shared/assets] [--instances N] [--res WxH]

Writes OUT_DIR/canyon.usda (the stage: looks, lights, camera, volumes, the
instancer's arrays in the sublayer OUT_DIR/scatter.usdc), OUT_DIR/assets/*.usda
(the rock prototypes and the hoodoo asset) and OUT_DIR/textures/*.png.
Asset paths are written relative to the layers, so OUT_DIR keeps working when
the repository moves with its `shared/` folder.
"""
import argparse
import os
import struct
import zlib

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade, UsdVol, Vt

TEAPOT = "usd-wg/full_assets/Teapot/Teapot.usd"
SMOKE = "arnold-usd/test_0030/data/smoke.vdb"
HERO = (0.6, -9.0)  # (x, z) of the hero teapot, metres; the camera focuses on it
PROPS = [  # (x, z, scale, yaw in degrees) of the teapots
    (HERO[0], HERO[1], 7.0, 200.0),
    (-6.5, -21.0, 9.0, 120.0),
    (7.5, -33.0, 11.0, 250.0),
]
HOODOOS = [(-13.0, -28.0, 1.0, 0.0), (-20.0, -44.0, 1.4, 70.0), (12.0, -60.0, 1.7, 140.0),
           (-15.5, -66.0, 1.2, 200.0), (15.0, -18.0, 0.8, 300.0), (4.0, -80.0, 2.0, 30.0)]
EXPLOSION = (-2.2, -20.0, 3.0)  # (x, z, scale) of the fireball: in the open, a big boulder behind it
EYE = (-1.2, 2.1, 4.0)  # the camera, metres
SHUTTER = (-0.25, 0.25)  # the camera's shutter, frames around frame 0
# The flying rock's (x, y, z) at frames -1 and 1 (against the sky, 7 m from the camera), and
# its spin (degrees about z) then.
FLYING_ROCK = ((-0.3, 3.2, -3.0), (1.3, 3.4, -3.2), (40.0, -40.0))
SMOKE_DRIFT = 3.0  # metres per frame along +x: the plume drifts in the wind
# No rocks under a teapot or around the camera.
CLEARINGS = [(x, z, 0.32 * s) for x, z, s, _ in PROPS] + [(EYE[0], EYE[2], 3.0)]


# --- noise and the terrain -----------------------------------------------------------

class ValueNoise:
    """Smooth lattice value noise in [-1, 1] (fixed seed), optionally periodic so a
    texture made from it tiles: `period` lattice cells per repeat."""

    def __init__(self, seed: int, period: int = 256) -> None:
        self.table = np.random.default_rng(seed).uniform(-1.0, 1.0, (period, period, period)).astype(np.float64)
        self.period = period

    def __call__(self, x: np.ndarray, y: np.ndarray, z: np.ndarray | float = 0.0) -> np.ndarray:
        z = np.broadcast_to(z, np.shape(x))
        cells = [np.floor(c).astype(np.int64) for c in (x, y, z)]
        fracs = [c - f for c, f in zip((x, y, z), cells)]
        weights = [f * f * (3.0 - 2.0 * f) for f in fracs]
        total = np.zeros(np.shape(x))
        for corner in range(8):
            offsets = [(corner >> axis) & 1 for axis in range(3)]
            index = tuple((c + o) % self.period for c, o in zip(cells, offsets))
            weight = np.ones(np.shape(x))
            for w, o in zip(weights, offsets):
                weight = weight * (w if o else 1.0 - w)
            total += weight * self.table[index]
        return total

    def fractal(self, x, y, z=0.0, octaves: int = 4) -> np.ndarray:
        """Sum of octaves, each twice the frequency and half the amplitude (range ~[-1, 1])."""
        total, amplitude, frequency = 0.0, 0.5, 1.0
        for _ in range(octaves):
            total = total + amplitude * self(x * frequency, y * frequency, z * frequency)
            amplitude, frequency = amplitude * 0.5, frequency * 2.0
        return total


TERRAIN_NOISE = ValueNoise(seed=11)


def smoothstep(a: float, b: float, x: np.ndarray) -> np.ndarray:
    """0 below a, 1 above b, the cubic Hermite ramp between."""
    t = np.clip((x - a) / (b - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def height(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Ground height in metres at (x, z): low dunes on the floor, walls rising
    beyond |x| ~ 18 m along a gently winding canyon axis."""
    axis = x + 4.0 * np.sin(z / 23.0)
    dunes = 0.35 * np.sin(0.21 * x + 0.6 * np.sin(0.09 * z)) * np.cos(0.15 * z) + 0.25 * TERRAIN_NOISE.fractal(
        x / 7.0, z / 7.0)
    wall = smoothstep(17.0, 34.0, np.abs(axis))
    cliffs = wall * (10.0 + 4.0 * TERRAIN_NOISE.fractal(x / 9.0 + 40.0, z / 9.0, octaves=5))
    return dunes + cliffs


def terrain_mesh(size_x: float, z0: float, z1: float, n: int) -> dict:
    """The ground: an n x n heightfield over [-size_x, size_x] x [z0, z1], with
    vertex normals from central differences and UVs = position / 3 m."""
    xs = np.linspace(-size_x, size_x, n)
    zs = np.linspace(z1, z0, n)
    x, z = np.meshgrid(xs, zs, indexing="xy")
    y = height(x, z)
    eps = 0.05
    nx = -(height(x + eps, z) - height(x - eps, z)) / (2 * eps)
    nz = -(height(x, z + eps) - height(x, z - eps)) / (2 * eps)
    normals = np.stack([nx, np.ones_like(nx), nz], -1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    rows = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    quads = np.stack([rows, rows + n, rows + n + 1, rows + 1], -1).reshape(-1)
    return {
        "points": np.stack([x, y, z], -1).reshape(-1, 3),
        "normals": normals.reshape(-1, 3),
        "uv": np.stack([x, -z], -1).reshape(-1, 2) / 3.0,
        "counts": np.full((n - 1) * (n - 1), 4),
        "indices": quads,
    }


# --- procedural rocks ----------------------------------------------------------------

def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere: (points, triangles) after `subdivisions` 4:1 splits."""
    t = (1.0 + 5 ** 0.5) / 2.0
    points = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
              (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    points = [np.array(p, float) / np.linalg.norm(p) for p in points]
    for _ in range(subdivisions):
        midpoint_of: dict[tuple[int, int], int] = {}

        def midpoint(a: int, b: int) -> int:
            key = (min(a, b), max(a, b))
            if key not in midpoint_of:
                m = points[a] + points[b]
                points.append(m / np.linalg.norm(m))
                midpoint_of[key] = len(points) - 1
            return midpoint_of[key]

        split = []
        for a, b, c in faces:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            split += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = split
    return np.array(points), np.array(faces)


def vertex_normals(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals."""
    face_normals = np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]])
    normals = np.zeros_like(points)
    for corner in range(3):
        np.add.at(normals, faces[:, corner], face_normals)
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def rock(seed: int, radii: tuple[float, float, float], roughness: float, subdivisions: int = 3) -> dict:
    """A rock: an icosphere with radii (x, y, z) in metres, displaced along its
    normals by fractal noise of relative amplitude `roughness`, resting on y = 0."""
    points, faces = icosphere(subdivisions)
    noise = ValueNoise(seed)
    bumps = noise.fractal(points[:, 0] * 1.7 + 10, points[:, 1] * 1.7 + 10, points[:, 2] * 1.7 + 10, octaves=5)
    points = points * (1.0 + roughness * bumps)[:, None] * np.array(radii)
    points[:, 1] -= points[:, 1].min()
    return {"points": points, "normals": vertex_normals(points, faces),
            "counts": np.full(len(faces), 3), "indices": faces.reshape(-1)}


def stack(parts: list[tuple[dict, float]]) -> dict:
    """Meshes stacked along y (each at the given height offset) into one mesh."""
    merged = {"points": [], "normals": [], "counts": [], "indices": []}
    base = 0
    for mesh, lift in parts:
        merged["points"].append(mesh["points"] + [0.0, lift, 0.0])
        merged["normals"].append(mesh["normals"])
        merged["counts"].append(mesh["counts"])
        merged["indices"].append(mesh["indices"] + base)
        base += len(mesh["points"])
    return {key: np.concatenate(value) for key, value in merged.items()}


ROCKS = {  # prototype name: (mesh, material, share of the instances)
    "Boulder": (lambda: rock(21, (1.0, 0.75, 0.9), 0.28), "Sandstone", 0.5),
    "Slab": (lambda: rock(22, (1.2, 0.38, 0.85), 0.22), "Basalt", 0.3),
    "Pebble": (lambda: rock(23, (0.9, 0.45, 0.7), 0.15), "Limestone", 0.2),
}


def hoodoo() -> dict:
    """A hoodoo spire, about 9 m: a column of displaced spheroids under a cap stone."""
    return stack([(rock(31, (2.0, 2.6, 1.8), 0.25), 0.0), (rock(32, (1.5, 2.4, 1.4), 0.3), 2.2),
                  (rock(33, (1.1, 2.2, 1.0), 0.3), 4.2), (rock(34, (1.9, 0.9, 1.7), 0.25), 6.2)])


# --- images ---------------------------------------------------------------------------

def write_png(path: str, rgb: np.ndarray) -> None:
    """An 8-bit RGB PNG (no dependency beyond zlib); rgb is (h, w, 3) in [0, 1],
    already sRGB-encoded."""
    pixels = (np.clip(rgb, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    h, w, _ = pixels.shape
    raw = b"".join(b"\x00" + pixels[row].tobytes() for row in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    with open(path, "wb") as out:
        out.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                  + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def sand_texture(size: int) -> np.ndarray:
    """A tiling sand albedo (sRGB): wind ripples plus grain, from periodic noise."""
    noise = ValueNoise(seed=5, period=16)
    u, v = np.meshgrid(np.arange(size) / size * 16, np.arange(size) / size * 16, indexing="xy")
    ripples = np.sin(2 * np.pi * (v * 1.0 + 0.35 * noise.fractal(u, v, octaves=3)))
    blotches = noise.fractal(u * 0.5 + 3.0, v * 0.5 + 3.0, octaves=3)
    grain = np.random.default_rng(6).uniform(-1.0, 1.0, (size, size))
    shade = 0.82 + 0.06 * ripples + 0.12 * blotches + 0.05 * grain
    colour = np.array([0.80, 0.58, 0.40])
    return shade[..., None] * colour


def sky_texture(width: int, sun_azimuth: float, sun_elevation: float) -> np.ndarray:
    """A dusk sky as a lat-long image (sRGB, UsdLuxDomeLight's OpenEXR layout: row 0
    is the zenith, column u looks along longitude pi (1 - 2u)): deep blue above,
    warm at the horizon, brighter towards the sun; dark ground below."""
    height_px = width // 2
    lat = np.pi * (0.5 - (np.arange(height_px) + 0.5) / height_px)
    lon = np.pi * (1.0 - 2.0 * (np.arange(width) + 0.5) / width)
    lon, lat = np.meshgrid(lon, lat, indexing="xy")
    direction = np.stack([np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)], -1)
    sun = np.array([np.cos(sun_elevation) * np.sin(sun_azimuth), np.sin(sun_elevation),
                    np.cos(sun_elevation) * np.cos(sun_azimuth)])
    towards_sun = np.clip(direction @ sun, 0.0, 1.0)
    up = np.clip(np.sin(lat), 0.0, 1.0)[..., None]
    zenith, horizon = np.array([0.35, 0.5, 0.78]), np.array([1.0, 0.78, 0.6])
    sky = horizon + (zenith - horizon) * up ** 0.45
    sky = sky + np.array([0.5, 0.25, 0.08]) * (towards_sun ** 6)[..., None]
    ground = np.array([0.22, 0.16, 0.12])
    return np.where(lat[..., None] >= 0.0, sky, ground)


# --- USD authoring --------------------------------------------------------------------

def preview_material(stage: Usd.Stage, path: str, colour=None, texture: str | None = None,
                     roughness: float = 0.8) -> UsdShade.Material:
    """A UsdPreviewSurface material: constant diffuse colour, or an sRGB texture read
    through the `st` primvar."""
    material = UsdShade.Material.Define(stage, path)
    surface = UsdShade.Shader.Define(stage, path + "/Surface")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    if texture is None:
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*colour))
    else:
        reader = UsdShade.Shader.Define(stage, path + "/UV")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        image = UsdShade.Shader.Define(stage, path + "/Texture")
        image.CreateIdAttr("UsdUVTexture")
        image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(texture)
        image.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
        image.CreateInput("wrapS", Sdf.ValueTypeNames.Token).Set("repeat")
        image.CreateInput("wrapT", Sdf.ValueTypeNames.Token).Set("repeat")
        image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            image.ConnectableAPI(), "rgb")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    return material


def define_mesh(stage: Usd.Stage, path: str, mesh: dict, material: UsdShade.Material | None) -> UsdGeom.Mesh:
    """A Mesh prim from a dict of numpy arrays (points, normals, counts, indices, uv?)."""
    prim = UsdGeom.Mesh.Define(stage, path)
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(mesh["points"].astype(np.float32)))
    prim.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(mesh["counts"].astype(np.int32)))
    prim.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(mesh["indices"].astype(np.int32)))
    prim.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(mesh["normals"].astype(np.float32)))
    prim.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    prim.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    if "uv" in mesh:
        primvar = UsdGeom.PrimvarsAPI(prim).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                          UsdGeom.Tokens.vertex)
        primvar.Set(Vt.Vec2fArray.FromNumpy(mesh["uv"].astype(np.float32)))
    if material is not None:
        UsdShade.MaterialBindingAPI.Apply(prim.GetPrim()).Bind(material)
    return prim


def write_hoodoo_asset(path: str) -> None:
    """The hoodoo asset layer: one mesh with its own material inside the asset."""
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/Hoodoo")
    stage.SetDefaultPrim(root.GetPrim())
    Usd.ModelAPI(root.GetPrim()).SetKind("component")
    material = preview_material(stage, "/Hoodoo/Looks/Banded", colour=(0.55, 0.30, 0.18), roughness=0.9)
    define_mesh(stage, "/Hoodoo/Geom", hoodoo(), material)
    stage.GetRootLayer().Save()


def place(stage: Usd.Stage, path: str, x: float, z: float, scale: float, yaw: float, lift: float = 0.0) -> Usd.Prim:
    """An Xform at ground height (x, z) with uniform scale and yaw (degrees)."""
    xform = UsdGeom.Xform.Define(stage, path)
    y = float(height(np.array(x), np.array(z))) + lift
    xform.AddTranslateOp().Set(Gf.Vec3d(x, y, z))
    xform.AddRotateYOp().Set(yaw)
    xform.AddScaleOp().Set(Gf.Vec3f(scale))
    return xform.GetPrim()


def scatter(count: int, seed: int) -> dict:
    """PointInstancer arrays: positions on the ground, yaw + tilt orientations,
    power-law sizes (many pebbles, few boulders), prototype indices."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-40.0, 40.0, count * 2)
    z = -np.abs(rng.uniform(-1.0, 1.0, count * 2)) ** 1.6 * 140.0 + 6.0  # denser near the camera
    keep = np.ones_like(x, bool)
    for cx, cz, r in CLEARINGS:
        keep &= (x - cx) ** 2 + (z - cz) ** 2 > r ** 2
    x, z = x[keep][:count], z[keep][:count]
    n = len(x)
    # Near the camera only pebbles, so no boulder fills the frame.
    largest = np.minimum(1.8, 0.06 * np.hypot(x - EYE[0], z - EYE[2]))
    size = np.clip(0.022 * (1.0 - rng.uniform(0.0, 1.0, n)) ** -0.6, 0.02, largest)
    shares = np.array([share for _, _, share in ROCKS.values()])
    proto = rng.choice(len(ROCKS), n, p=shares / shares.sum())
    yaw = rng.uniform(0.0, 2.0 * np.pi, n)
    tilt_axis = rng.uniform(0.0, 2.0 * np.pi, n)
    tilt = rng.normal(0.0, 0.25, n)
    q_yaw = np.stack([np.cos(yaw / 2), np.zeros(n), np.sin(yaw / 2), np.zeros(n)], -1)
    q_tilt = np.stack([np.cos(tilt / 2), np.sin(tilt / 2) * np.cos(tilt_axis), np.zeros(n),
                       np.sin(tilt / 2) * np.sin(tilt_axis)], -1)
    orientation = quaternion_product(q_tilt, q_yaw)
    y = height(x, z) - 0.3 * size  # sunk into the sand
    return {"positions": np.stack([x, y, z], -1), "orientations": orientation,
            "scales": np.repeat(size[:, None], 3, 1), "protoIndices": proto}


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton product of (w, x, y, z) quaternions."""
    aw, ax, ay, az = a.T
    bw, bx, by, bz = b.T
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], -1)


def volume(stage: Usd.Stage, path: str, vdb: str, fields: list[str], primvars: dict,
           translate, scale: float) -> UsdVol.Volume:
    """A Volume prim with one OpenVDBAsset per field of `vdb` and constant shading primvars."""
    prim = UsdVol.Volume.Define(stage, path)
    for field in fields:
        asset = UsdVol.OpenVDBAsset.Define(stage, f"{path}/{field}")
        asset.CreateFilePathAttr(vdb)
        asset.CreateFieldNameAttr(field)
        prim.CreateFieldRelationship(field, asset.GetPath())
    api = UsdGeom.PrimvarsAPI(prim)
    for name, value in primvars.items():
        kind = Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else Sdf.ValueTypeNames.Float
        api.CreatePrimvar(name, kind).Set(Gf.Vec3f(*value) if isinstance(value, tuple) else value)
    prim.AddTranslateOp().Set(Gf.Vec3d(*translate))
    prim.AddScaleOp().Set(Gf.Vec3f(scale))
    return prim


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="output folder")
    parser.add_argument("--explosion", required=True, help="the VDB written by scenes/make_explosion.py")
    parser.add_argument("--shared", default=os.path.join(os.path.dirname(__file__), "..", "..", "shared", "assets"),
                        help="the shared assets folder (teapot, smoke.vdb)")
    parser.add_argument("--instances", type=int, default=60000, help="rocks scattered by the PointInstancer")
    parser.add_argument("--res", default="1280x720", help="RenderSettings resolution, WxH")
    args = parser.parse_args()

    out = os.path.abspath(args.out)
    for folder in ("assets", "textures"):
        os.makedirs(os.path.join(out, folder), exist_ok=True)
    sun_azimuth, sun_elevation = np.radians(-125.0), np.radians(18.0)
    write_png(os.path.join(out, "textures", "sand.png"), sand_texture(512))
    write_png(os.path.join(out, "textures", "dusk_sky.png"), sky_texture(512, sun_azimuth, sun_elevation))
    write_hoodoo_asset(os.path.join(out, "assets", "hoodoo.usdc"))

    def relative(path: str) -> str:
        return os.path.relpath(os.path.abspath(path), out)

    stage_path = os.path.join(out, "canyon.usda")
    stage = Usd.Stage.CreateNew(stage_path)
    stage.SetMetadata("comment", "Cirrus demo 'Teapot Canyon', written by scenes/make_demo.py")
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    # Frame 0 is the frame rendered; the moving prims are keyed at frames -1 and 1.
    stage.SetStartTimeCode(0.0)
    stage.SetEndTimeCode(0.0)

    looks = {name: preview_material(stage, f"/World/Looks/{name}", colour=colour, roughness=rough)
             for name, colour, rough in [("Sandstone", (0.50, 0.30, 0.19), 0.85),
                                         ("Basalt", (0.09, 0.085, 0.08), 0.6),
                                         ("Limestone", (0.42, 0.37, 0.31), 0.7)]}
    sand = preview_material(stage, "/World/Looks/Sand", texture="./textures/sand.png", roughness=0.95)

    # The heavy arrays (ground and instancer) go into a binary sublayer.
    scatter_layer = Sdf.Layer.CreateNew(os.path.join(out, "scatter.usdc"))
    stage.GetRootLayer().subLayerPaths.append("./scatter.usdc")
    with Usd.EditContext(stage, scatter_layer):
        define_mesh(stage, "/World/Ground", terrain_mesh(70.0, -150.0, 14.0, 260), sand)
        instancer = UsdGeom.PointInstancer.Define(stage, "/World/Rocks")
        prototypes = instancer.CreatePrototypesRel()
        for name, (make, look, _) in ROCKS.items():
            mesh = define_mesh(stage, f"/World/Rocks/Prototypes/{name}", make(), looks[look])
            prototypes.AddTarget(mesh.GetPath())
        arrays = scatter(args.instances, seed=7)
        instancer.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(arrays["positions"].astype(np.float32)))
        instancer.CreateOrientationsAttr(Vt.QuathArray([Gf.Quath(*map(float, q)) for q in arrays["orientations"]]))
        instancer.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(arrays["scales"].astype(np.float32)))
        instancer.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(arrays["protoIndices"].astype(np.int32)))
    scatter_layer.Save()

    for i, (x, z, scale, yaw) in enumerate(HOODOOS):
        prim = place(stage, f"/World/Hoodoos/Hoodoo_{i}", x, z, scale, yaw, lift=-0.5 * scale)
        prim.GetReferences().AddReference("./assets/hoodoo.usdc")
        prim.SetInstanceable(True)
    teapot = os.path.join(args.shared, TEAPOT)
    if os.path.exists(teapot):
        for i, (x, z, scale, yaw) in enumerate(PROPS):
            prim = place(stage, f"/World/Teapots/Teapot_{i}", x, z, scale, yaw, lift=-0.02 * scale)
            prim.GetReferences().AddReference(relative(teapot))
            prim.GetVariantSets().GetVariantSet("modelVariant").SetVariantSelection("Fancy")
            prim.SetInstanceable(True)
    else:
        print(f"make_demo: warning: {teapot} is missing; the scene has no teapots")

    smoke = os.path.join(args.shared, SMOKE)
    if os.path.exists(smoke):
        plume = volume(stage, "/World/Smoke", relative(smoke), ["density"],
                       {"densityScale": 8.0, "albedo": (0.8, 0.8, 0.8), "anisotropy": 0.4},
                       (7.0, 2.0, -78.0), 0.2)
        drift = plume.GetOrderedXformOps()[0]
        for frame in (-1.0, 1.0):
            drift.Set(Gf.Vec3d(7.0 + SMOKE_DRIFT * frame, 2.0, -78.0), frame)
    else:
        print(f"make_demo: warning: {smoke} is missing; the scene has no smoke plume")
    # The fireball's grid spans [-1, 1] with the stem's foot at y = -0.97: stand it on the
    # sand, 10 cm deep. Its fire (up to 2600 K) lights the boulder and the sand around it.
    ex, ez, escale = EXPLOSION
    centre_y = float(height(np.array(ex), np.array(ez))) + 0.97 * escale - 0.1
    volume(stage, "/World/Explosion", relative(args.explosion), ["density", "temperature"],
           {"densityScale": 4.0, "albedo": (0.25, 0.24, 0.23), "anisotropy": 0.3, "heatScale": 0.03,
            "temperatureOffset": 0.0, "temperatureScale": 1.0}, (ex, centre_y, ez), escale)

    # A rock flying past the hero teapot, tumbling: blurred by the camera's shutter.
    (x0, y0, z0), (x1, y1, z1), (spin0, spin1) = FLYING_ROCK
    flying = UsdGeom.Xform.Define(stage, "/World/FlyingRock")
    move, spin = flying.AddTranslateOp(), flying.AddRotateZOp()
    for frame, position, angle in ((-1.0, (x0, y0, z0), spin0), (1.0, (x1, y1, z1), spin1)):
        move.Set(Gf.Vec3d(*position), frame)
        spin.Set(angle, frame)
    define_mesh(stage, "/World/FlyingRock/Rock", rock(41, (0.35, 0.28, 0.32), 0.25), looks["Basalt"])

    sky = UsdLux.DomeLight.Define(stage, "/World/Lights/Sky")
    sky.CreateTextureFileAttr("./textures/dusk_sky.png")
    sky.CreateIntensityAttr(1.2)
    sun = UsdLux.DistantLight.Define(stage, "/World/Lights/Sun")
    sun.CreateIntensityAttr(4.0)
    sun.CreateNormalizeAttr(True)
    sun.CreateAngleAttr(1.0)
    sun.CreateColorAttr(Gf.Vec3f(1.0, 0.72, 0.48))
    # Light travels along -Z of the prim: point -Z away from the sun direction.
    sun_xform = UsdGeom.Xformable(sun)
    sun_xform.AddRotateYOp().Set(float(np.degrees(sun_azimuth)))
    sun_xform.AddRotateXOp().Set(-float(np.degrees(sun_elevation)))

    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    # USD lens lengths are in tenths of a scene unit: 0.4 is a 40 mm lens on a 36 mm back.
    camera.CreateFocalLengthAttr(0.4)
    camera.CreateHorizontalApertureAttr(0.36)
    camera.CreateVerticalApertureAttr(0.2025)
    eye = Gf.Vec3d(*EYE)
    focus = Gf.Vec3d(HERO[0], float(height(np.array(HERO[0]), np.array(HERO[1]))) + 1.2, HERO[1])
    camera.CreateFocusDistanceAttr(float((focus - eye).GetLength()))
    camera.CreateFStopAttr(2.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.05, 10000.0))
    camera.CreateShutterOpenAttr(SHUTTER[0])
    camera.CreateShutterCloseAttr(SHUTTER[1])
    look = Gf.Matrix4d().SetLookAt(eye, Gf.Vec3d(0.5, 1.6, -30.0), Gf.Vec3d(0, 1, 0)).GetInverse()
    UsdGeom.Xformable(camera).AddTransformOp().Set(look)

    width, height_px = (int(v) for v in args.res.split("x"))
    settings = UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(Gf.Vec2i(width, height_px))
    settings.CreateCameraRel().AddTarget(camera.GetPath())
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")
    stage.GetRootLayer().Save()
    print(f"make_demo: wrote {stage_path} ({len(arrays['positions'])} rock instances)")


if __name__ == "__main__":
    main()
