//! UsdLux rows: lights over a Lambert ground of albedo 0.5 (radiance 0.5 /
//! pi x irradiance) seen straight down, judged against the irradiance each
//! light's shape gives in closed form (a sphere's pi L r^2 cos / d^2, a
//! polygon's Lambert formula; docs/conventions.md's emission table). Local
//! lights hang 0.5 above the ground, six to a stage, 5 and 6 units apart,
//! each measured 0.5..1 unit beside it (the others add under 2%).

use super::sheet::{self, ensure, near, Rgb, Shot};
use super::{row, Honoured, Row, Warned};
use std::f64::consts::PI;
use std::sync::OnceLock;

/// Where the lights of a stage hang: (x, y) of slot 0..6; slots 6 and 7,
/// between them, only in the fourth stage.
const SLOTS: [(f64, f64); 8] = [
    (-5.0, 3.0),
    (0.0, 3.0),
    (5.0, 3.0),
    (-5.0, -3.0),
    (0.0, -3.0),
    (5.0, -3.0),
    (0.0, 0.0),
    (5.0, 0.0),
];
/// Height of the local lights above the ground.
const HEIGHT: f64 = 0.5;

/// A stage: the top camera, a Lambert ground of albedo 0.5 at z = 0, and
/// `lights` (usda at the root; `$X`, `$Y` of a light are filled from its
/// slot by [`at`]).
fn stage(lights: &str) -> String {
    format!(
        "#usda 1.0\n(\n    upAxis = \"Z\"\n    metersPerUnit = 1\n)\n\n{}\n\
         def Mesh \"Ground\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{{\n    \
         point3f[] points = [(-40, -40, 0), (40, -40, 0), (40, 40, 0), (-40, 40, 0)]\n    \
         int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    \
         rel material:binding = </GroundLook>\n}}\n\n{}\n{lights}\n",
        sheet::top_camera("Camera", ""),
        sheet::material("GroundLook", &sheet::lambert((0.5, 0.5, 0.5)))
    )
}

/// A light prim `kind` named `name` in slot `slot`, `HEIGHT` up, with
/// `body` lines (and `schemas` applied).
fn at(slot: usize, kind: &str, name: &str, schemas: &str, body: &str) -> String {
    let (x, y) = SLOTS[slot];
    let api = if schemas.is_empty() {
        String::new()
    } else {
        format!(" (prepend apiSchemas = [{schemas}])")
    };
    format!(
        "def {kind} \"{name}\"{api}\n{{\n    double3 xformOp:translate = ({x}, {y}, {HEIGHT})\n    \
         uniform token[] xformOpOrder = [\"xformOp:translate\"]\n    {}\n}}\n",
        body.replace('\n', "\n    ")
    )
}

/// The pixel column and row of world (x, y) (top camera, 4 pixels a unit).
fn pixel(x: f64, y: f64) -> (usize, usize) {
    (
        ((x + 8.0) * 4.0).round() as usize,
        ((6.0 - y) * 4.0).round() as usize,
    )
}

/// The measured region of slot `slot`: pixels 2..4 right of the light,
/// rows -1..1 (world offsets 0.5..1 in x, -0.25..0.25 in y).
fn region(slot: usize) -> ((usize, usize), (usize, usize)) {
    let (px, py) = pixel(SLOTS[slot].0, SLOTS[slot].1);
    ((px + 2, px + 4), (py - 1, py + 1))
}

/// The mean over slot `slot`'s measured [`region`] of the ground radiance
/// 0.5 / pi x `irradiance(dx, dy)` (offsets from the slot's light).
fn expected(slot: usize, irradiance: impl Fn(f64, f64) -> f64) -> f64 {
    expected_in(slot, region(slot), irradiance)
}

/// The mean over the pixels `((x0, x1), (y0, y1))` (columns and rows, ends
/// excluded) of the ground radiance 0.5 / pi x `irradiance(dx, dy)` at
/// world offsets from slot `slot`'s light, 8 x 8 points a pixel.
fn expected_in(
    slot: usize,
    ((x0, x1), (y0, y1)): ((usize, usize), (usize, usize)),
    irradiance: impl Fn(f64, f64) -> f64,
) -> f64 {
    let (lx, ly) = SLOTS[slot];
    let mut sum = 0.0;
    let mut n = 0.0;
    for px in x0..x1 {
        for py in y0..y1 {
            for i in 0..8 {
                for j in 0..8 {
                    let x = (px as f64 + (i as f64 + 0.5) / 8.0) / 4.0 - 8.0;
                    let y = 6.0 - (py as f64 + (j as f64 + 0.5) / 8.0) / 4.0;
                    sum += irradiance(x - lx, y - ly);
                    n += 1.0;
                }
            }
        }
    }
    0.5 / PI * sum / n
}

/// Irradiance on the ground at offset (dx, dy) from below a sphere of
/// radius `r` and radiance `l` (fully above the horizon): pi l r^2 cos / d^2.
fn sphere(l: f64, r: f64) -> impl Fn(f64, f64) -> f64 {
    move |dx, dy| {
        let d2 = dx * dx + dy * dy + HEIGHT * HEIGHT;
        PI * l * r * r * (HEIGHT / d2.sqrt()) / d2
    }
}

/// Irradiance on the ground at offset (dx, dy) from below a downward-facing
/// polygon `vertices` (x, y at height HEIGHT) of radiance `l`: Lambert's
/// formula, l / 2 x sum over edges of the angle they subtend times the
/// cosine of their plane's normal with the ground's.
fn polygon(l: f64, vertices: Vec<(f64, f64)>) -> impl Fn(f64, f64) -> f64 {
    move |dx, dy| {
        let v: Vec<[f64; 3]> = vertices
            .iter()
            .map(|&(x, y)| {
                let p = [x - dx, y - dy, HEIGHT];
                let len = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                p.map(|c| c / len)
            })
            .collect();
        let mut total = 0.0;
        for i in 0..v.len() {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            let cross = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let len = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
            let angle = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
                .clamp(-1.0, 1.0)
                .acos();
            total += angle * cross[2] / len;
        }
        0.5 * l * total.abs()
    }
}

/// A disk of radius `r` as a 256-gon of the same area.
fn disk(l: f64, r: f64) -> impl Fn(f64, f64) -> f64 {
    let n = 256;
    let scale = r * ((2.0 * PI / n as f64) / (2.0 * PI / n as f64).sin()).sqrt();
    polygon(
        l,
        (0..n)
            .map(|i| {
                let t = 2.0 * PI * i as f64 / n as f64;
                (scale * t.cos(), scale * t.sin())
            })
            .collect(),
    )
}

/// A `w` x `h` rectangle.
fn rect(l: f64, w: f64, h: f64) -> impl Fn(f64, f64) -> f64 {
    polygon(
        l,
        vec![
            (-w / 2.0, -h / 2.0),
            (w / 2.0, -h / 2.0),
            (w / 2.0, h / 2.0),
            (-w / 2.0, h / 2.0),
        ],
    )
}

/// Ok when slot `slot`'s region reads grey `value` within `relative`.
fn reads(shot: &Shot, slot: usize, value: f64, relative: f64) -> Result<(), String> {
    let (xs, ys) = region(slot);
    near(
        &format!("slot {slot}"),
        shot.mean(xs, ys),
        [value; 3],
        relative,
    )
}

/// The first stage: shapes and normalize, and two inputs being added.
fn shapes() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let disk = "float inputs:radius = 0.3\nfloat inputs:intensity = 5";
        let lights = [
            at(0, "SphereLight", "Sphere", "", "float inputs:radius = 0.2\nfloat inputs:intensity = 10"),
            at(1, "DiskLight", "Disk", "", disk),
            at(2, "RectLight", "Rect", "", "float inputs:width = 0.6\nfloat inputs:height = 0.3\nfloat inputs:intensity = 8"),
            at(3, "RectLight", "Normalized", "", "float inputs:width = 0.6\nfloat inputs:height = 0.3\nfloat inputs:intensity = 1.44\nbool inputs:normalize = 1"),
            at(4, "DiskLight", "NoDiffuse", "", &format!("{disk}\nfloat inputs:diffuse = 0")),
            at(5, "DiskLight", "Cone", "\"ShapingAPI\"", &format!("{disk}\nfloat inputs:shaping:cone:angle = 10")),
        ];
        sheet::render_sheet("lux_shapes", &stage(&lights.concat()), 256)
    })
}

/// An occluder under slot `slot`'s light, between it and the measured
/// region but out of the camera's view of it.
fn occluder(slot: usize) -> String {
    let (x, y) = SLOTS[slot];
    format!(
        "def Mesh \"Occluder{slot}\"\n{{\n    point3f[] points = [({a}, {c}, 0.25), ({b}, {c}, 0.25), ({b}, {d}, 0.25), ({a}, {d}, 0.25)]\n    \
         int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n}}\n",
        a = x + 0.15,
        b = x + 0.7,
        c = y - 0.3,
        d = y + 0.3
    )
}

/// The second stage: cylinder, point, shadows, specular, linking.
fn more() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let disk = "float inputs:radius = 0.3\nfloat inputs:intensity = 5";
        let (mx, my) = SLOTS[3];
        let metal = format!(
            "def Mesh \"Metal\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{{\n    \
             point3f[] points = [({a}, {c}, 0.001), ({b}, {c}, 0.001), ({b}, {d}, 0.001), ({a}, {d}, 0.001)]\n    \
             int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    rel material:binding = </MetalLook>\n}}\n{}",
            sheet::material("MetalLook", "color3f inputs:diffuseColor = (1, 1, 1)\nfloat inputs:metallic = 1\nfloat inputs:roughness = 0.5"),
            a = mx - 1.5,
            b = mx + 1.5,
            c = my - 1.0,
            d = my + 1.0
        );
        let lights = [
            at(
                0,
                "CylinderLight",
                "Cylinder",
                "",
                "float inputs:radius = 0.05\nfloat inputs:length = 2\nfloat inputs:intensity = 20\nbool treatAsLine = 1",
            ),
            at(
                1,
                "SphereLight",
                "Point",
                "",
                "float inputs:radius = 0.2\nfloat inputs:intensity = 10\nbool treatAsPoint = 1",
            ),
            at(
                2,
                "DiskLight",
                "Unshadowed",
                "\"ShadowAPI\"",
                &format!("{disk}\nbool inputs:shadow:enable = 0\ncolor3f inputs:shadow:color = (1, 0, 0)"),
            ),
            at(
                3,
                "DiskLight",
                "NoSpecular",
                "",
                &format!("{disk}\nfloat inputs:specular = 0"),
            ),
            at(
                4,
                "DiskLight",
                "Unlinked",
                "",
                &format!("{disk}\nuniform bool collection:lightLink:includeRoot = 0"),
            ),
            at(
                5,
                "DiskLight",
                "ShadowUnlinked",
                "",
                &format!("{disk}\nuniform bool collection:shadowLink:includeRoot = 0"),
            ),
            occluder(2),
            occluder(5),
            metal,
        ];
        sheet::render_sheet("lux_more", &stage(&lights.concat()), 128)
    })
}

/// The third stage: a distant light alone (colour, intensity, exposure,
/// normalize), as it lights the whole ground.
fn distant() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let light = "def DistantLight \"Sun\"\n{\n    float xformOp:rotateY = 30\n    \
                     uniform token[] xformOpOrder = [\"xformOp:rotateY\"]\n    float inputs:intensity = 3\n    \
                     float inputs:exposure = 1\n    color3f inputs:color = (1, 0.5, 0.25)\n    bool inputs:normalize = 1\n}\n";
        sheet::render_sheet("lux_distant", &stage(light), 8)
    })
}

/// The fourth stage: a mesh light (and a leftHanded one facing up, at
/// (-5, 0)), colour temperature, focus, an invisible light, cone
/// softness and IES profiles (plain, angle-scaled, normalized).
fn emitters() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let (x, y) = SLOTS[0];
        let mesh_light = format!(
            "def Mesh \"Panel\" (prepend apiSchemas = [\"MeshLightAPI\"])\n{{\n    \
             point3f[] points = [({a}, {c}, {HEIGHT}), ({a}, {d}, {HEIGHT}), ({b}, {d}, {HEIGHT}), ({b}, {c}, {HEIGHT})]\n    \
             int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    float inputs:intensity = 10\n}}\n",
            a = x - 0.2,
            b = x + 0.2,
            c = y - 0.2,
            d = y + 0.2
        );
        let upward = format!(
            "def Mesh \"LeftHanded\" (prepend apiSchemas = [\"MeshLightAPI\"])\n{{\n    uniform token orientation = \"leftHanded\"\n    \
             uniform bool collection:lightLink:includeRoot = 0\n    \
             point3f[] points = [(-5.3, -0.3, {HEIGHT}), (-5.3, 0.3, {HEIGHT}), (-4.7, 0.3, {HEIGHT}), (-4.7, -0.3, {HEIGHT})]\n    \
             int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    float inputs:intensity = 10\n}}\n"
        );
        let lights = [
            mesh_light,
            upward,
            at(1, "DiskLight", "Warm", "", "float inputs:radius = 0.3\nfloat inputs:intensity = 5\nbool inputs:enableColorTemperature = 1\nfloat inputs:colorTemperature = 2500"),
            at(2, "DiskLight", "Focused", "\"ShapingAPI\"", "float inputs:radius = 0.3\nfloat inputs:intensity = 5\nfloat inputs:shaping:focus = 10"),
            at(3, "DiskLight", "Hidden", "", "float inputs:radius = 0.3\nfloat inputs:intensity = 5\ntoken visibility = \"invisible\""),
            at(4, "DiskLight", "Softened", "\"ShapingAPI\"", &format!("{SMALL_DISK}\nfloat inputs:shaping:cone:angle = 70\nfloat inputs:shaping:cone:softness = 0.5")),
            at(5, "DiskLight", "Profiled", "\"ShapingAPI\"", &format!("{SMALL_DISK}\nasset inputs:shaping:ies:file = @ramp.ies@")),
            at(6, "DiskLight", "Stretched", "\"ShapingAPI\"", &format!("{SMALL_DISK}\nasset inputs:shaping:ies:file = @ramp.ies@\nfloat inputs:shaping:ies:angleScale = 2")),
            at(7, "DiskLight", "Conserved", "\"ShapingAPI\"", &format!("{SMALL_DISK}\nasset inputs:shaping:ies:file = @fine.ies@\nbool inputs:shaping:ies:normalize = 1")),
        ];
        sheet::render(
            "lux_emitters",
            &stage(&lights.concat()),
            (32, &["--res", "64x48"], sheet::RES),
            |dir| {
                std::fs::write(dir.join("ramp.ies"), RAMP_IES).unwrap();
                std::fs::write(dir.join("fine.ies"), fine_ramp()).unwrap();
            },
        )
    })
}

/// A disk small enough (radius 0.05, radiance 180: the power of the 0.3
/// disks of radiance 5) that the ground sees it from one direction, for
/// the shaping rows whose factor depends on that direction.
const SMALL_DISK: &str = "float inputs:radius = 0.05\nfloat inputs:intensity = 180";

/// An LM-63 profile, rotationally symmetric: 1 cd on the axis falling
/// linearly to 0 cd at 90 degrees off it (none beyond).
const RAMP_IES: &str =
    "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 10\n0 90 180\n0\n1 0 0\n";

/// [`RAMP_IES`] tabulated every 5 degrees from 0 to 180 (so that the
/// profile's mean intensity over the sphere, (1 - 2 / pi) / 2 cd, is what
/// any quadrature of it finds).
fn fine_ramp() -> String {
    let angles: Vec<String> = (0..=36).map(|i| (5 * i).to_string()).collect();
    let candela: Vec<String> = (0..=36)
        .map(|i| (1.0 - i as f64 / 18.0).max(0.0).to_string())
        .collect();
    format!(
        "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 37 1 1 2 0 0 0\n1 1 10\n{}\n0\n{}\n",
        angles.join(" "),
        candela.join(" ")
    )
}

/// The ramp's factor at `theta` (radians off the axis): 1 - theta / 90
/// degrees, 0 beyond.
fn ramp(theta: f64) -> f64 {
    (1.0 - theta / (PI / 2.0)).max(0.0)
}

/// The ground's irradiance from [`SMALL_DISK`] at offset (dx, dy), scaled
/// by `factor` of the angle (radians) off the light's downward axis.
fn shaped(factor: impl Fn(f64) -> f64) -> impl Fn(f64, f64) -> f64 {
    let open = disk(180.0, 0.05);
    move |dx, dy| open(dx, dy) * factor((dx * dx + dy * dy).sqrt().atan2(HEIGHT))
}

/// The smoothstep of `x` from `a` to `b` (0 below, 1 above).
fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Height of the occluder of the [`sun`] stage, and its edge's x (it
/// covers the ground beyond); the sun's angular diameter there (degrees).
const EDGE: (f64, f64) = (4.0, 2.0);
const SUN_ANGLE: f64 = 10.0;

/// The fifth stage: the sheet's sun (from +X, 30 degrees off straight
/// down) of angular diameter 10 degrees, a black half-plane 4 above the
/// ground casting a shadow whose penumbra the camera sees beside it, and a
/// dark DomeLight_1 whose pole is authored +Z.
fn sun() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    sheet::once(&SHOT, || {
        let (h, a) = EDGE;
        let lights = format!(
            "{}\ndef Mesh \"Occluder\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{{\n    \
             point3f[] points = [({a}, -40, {h}), (40, -40, {h}), (40, 40, {h}), ({a}, 40, {h})]\n    \
             int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    rel material:binding = </Black>\n}}\n{}\n\
             def DomeLight_1 \"Pole\"\n{{\n    float inputs:intensity = 0\n    uniform token poleAxis = \"Z\"\n}}\n",
            sheet::lights(sheet::Lighting::Sun).replace("}", &format!("    float inputs:angle = {SUN_ANGLE}\n}}")),
            sheet::material("Black", &sheet::lambert((0.0, 0.0, 0.0)))
        );
        sheet::render_sheet("lux_sun", &stage(&lights), 64)
    })
}

/// The part of the sun's irradiance that reaches the ground at x past the
/// occluder's edge (a cosine-weighted fraction of its disk, uniform in
/// radiance, integrated on a 64 x 64 grid of its angular offsets).
fn sun_fraction(x: f64) -> f64 {
    let (h, a) = EDGE;
    let radius = (SUN_ANGLE / 2.0).to_radians();
    // The elevation (from +X, in the XZ plane) of the occluder's edge.
    let edge = h.atan2(a - x);
    let (mut seen, mut all) = (0.0, 0.0);
    for i in 0..64 {
        for j in 0..64 {
            let (u, v) = (
                radius * ((i as f64 + 0.5) / 32.0 - 1.0),
                radius * ((j as f64 + 0.5) / 32.0 - 1.0),
            );
            if u * u + v * v > radius * radius {
                continue;
            }
            let elevation = 60f64.to_radians() + u;
            let cos = elevation.sin() * v.cos();
            all += cos;
            if elevation > edge {
                seen += cos;
            }
        }
    }
    seen / all
}

/// The mean of the middle 2 x 2 pixels of the fourth stage's leftHanded
/// mesh light, wound clockwise seen from above (the Mesh orientation row).
pub fn left_handed_panel() -> Rgb {
    emitters().mean((11, 13), (23, 25))
}

/// A dome over a Y-up Lambert ground (albedo 0.5) seen from above, lit by
/// `dome` (usda) whose texture `sky.exr` is written by `texture`.
fn dome_shot(
    name: &str,
    cache: &'static OnceLock<Shot>,
    dome: &'static str,
    size: (usize, usize),
    texel: fn(usize, usize) -> [f32; 3],
) -> &'static Shot {
    sheet::once(cache, || {
        let usda = format!(
            "#usda 1.0\n(\n    upAxis = \"Y\"\n    metersPerUnit = 1\n)\n\n\
             def Camera \"Camera\"\n{{\n    double3 xformOp:translate = (0, 10, 0)\n    float xformOp:rotateX = -90\n    \
             uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateX\"]\n    token projection = \"orthographic\"\n    \
             float horizontalAperture = 160\n    float verticalAperture = 120\n}}\n\n\
             def Mesh \"Ground\" (prepend apiSchemas = [\"MaterialBindingAPI\"])\n{{\n    \
             point3f[] points = [(-40, 0, -40), (-40, 0, 40), (40, 0, 40), (40, 0, -40)]\n    \
             int[] faceVertexCounts = [4]\n    int[] faceVertexIndices = [0, 1, 2, 3]\n    rel material:binding = </GroundLook>\n}}\n\n{}\n{dome}\n",
            sheet::material("GroundLook", &sheet::lambert((0.5, 0.5, 0.5)))
        );
        sheet::render(name, &usda, (16, &["--res", "64x48"], sheet::RES), |dir| {
            sheet::write_texture(&dir.join("sky.exr"), size, texel)
        })
    })
}

/// A lat-long sky: blue radiance 1 above the horizon, red below; a portal
/// high above (which must not change the image).
fn latlong() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    dome_shot(
        "lux_latlong",
        &SHOT,
        "def DomeLight \"Sky\"\n{\n    asset inputs:texture:file = @sky.exr@\n    token inputs:texture:format = \"latlong\"\n}\n\n\
         def PortalLight \"Portal\"\n{\n    double3 xformOp:translate = (0, 30, 0)\n    float xformOp:rotateX = 90\n    \
         uniform token[] xformOpOrder = [\"xformOp:translate\", \"xformOp:rotateX\"]\n    float inputs:width = 200\n    float inputs:height = 200\n}\n",
        (16, 8),
        |_, y| if y < 4 { [0.0, 0.0, 1.0] } else { [1.0, 0.0, 0.0] },
    )
}

/// A radially symmetric probe image of 64 x 64: blue inside radius `inner`
/// (of the disk's radius 1), red out to the rim, black outside.
fn probe(x: usize, y: usize, inner: f64) -> [f32; 3] {
    let (u, v) = ((x as f64 + 0.5) / 32.0 - 1.0, (y as f64 + 0.5) / 32.0 - 1.0);
    let r = (u * u + v * v).sqrt();
    if r < inner {
        [0.0, 0.0, 1.0]
    } else if r < 1.0 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0; 3]
    }
}

/// Ok when the ground (facing the probe's axis, the dome turned 90 degrees
/// about X) sees one colour only, at 0.5 x radiance 1: the hemisphere
/// around the probe's centre direction is one disk of the image (angular:
/// radius 1/2, mirroredBall: radius sin 45 degrees), the other hemisphere
/// the ring.
fn one_hemisphere(shot: &Shot) -> Result<(), String> {
    let c = shot.mean((16, 48), (12, 36));
    let (hi, lo) = (c[0].max(c[2]), c[0].min(c[2]));
    ensure((hi - 0.5).abs() < 0.05 && lo < 0.02, || {
        format!("{c:.3?}: not one hemisphere of the probe")
    })
}

fn angular() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    dome_shot(
        "lux_angular",
        &SHOT,
        "def DomeLight \"Sky\"\n{\n    float xformOp:rotateX = 90\n    uniform token[] xformOpOrder = [\"xformOp:rotateX\"]\n    \
         asset inputs:texture:file = @sky.exr@\n    token inputs:texture:format = \"angular\"\n}\n",
        (64, 64),
        |x, y| probe(x, y, 0.5),
    )
}

fn mirrored_ball() -> &'static Shot {
    static SHOT: OnceLock<Shot> = OnceLock::new();
    dome_shot(
        "lux_mirrored_ball",
        &SHOT,
        "def DomeLight \"Sky\"\n{\n    float xformOp:rotateX = 90\n    uniform token[] xformOpOrder = [\"xformOp:rotateX\"]\n    \
         asset inputs:texture:file = @sky.exr@\n    token inputs:texture:format = \"mirroredBall\"\n}\n",
        (64, 64),
        |x, y| probe(x, y, std::f64::consts::FRAC_1_SQRT_2),
    )
}

/// The region beside slot `slot`'s light at world offsets `dx`, `dy` (a
/// 2 x 2 pixel patch).
fn beside(shot: &Shot, slot: usize, dx: f64, dy: f64) -> Rgb {
    let (px, py) = pixel(SLOTS[slot].0 + dx, SLOTS[slot].1 + dy);
    shot.mean((px - 1, px + 1), (py - 1, py + 1))
}

pub fn rows() -> Vec<Row> {
    vec![
        row("LightAPI", "inputs:intensity, inputs:exposure, inputs:color", Honoured,
            "a distant light of intensity 3, exposure 1, colour (1, 0.5, 0.25) (normalized: irradiance 6 x colour facing it) lights the ground at 30 degrees to 0.5 / pi x 6 cos 30 x colour", || {
                let v = 0.5 / PI * 6.0 * (PI / 6.0).cos();
                near("distant", distant().mean((8, 56), (8, 40)), [v, v * 0.5, v * 0.25], 0.05)
            }),
        row("LightAPI", "inputs:enableColorTemperature, inputs:colorTemperature", Honoured,
            "a 2500 K disk light lights the ground orange (red over 2.5 x blue)", || {
                let (xs, ys) = region(1);
                let c = emitters().mean(xs, ys);
                ensure(c[0] > 2.5 * c[2] && c[1] > 0.0, || format!("{c:.4?}"))
            }),
        row("LightAPI", "inputs:normalize", Honoured, "a normalized rect light of intensity 1.44 and area 0.18 lights the ground as one of radiance 8", || {
            reads(shapes(), 3, expected(3, rect(8.0, 0.6, 0.3)), 0.06)
        }),
        row("LightAPI", "inputs:diffuse", Honoured, "a light of diffuse 0 leaves a Lambert ground dark", || {
            reads(shapes(), 4, 0.0, 0.0)
        }),
        row("LightAPI", "inputs:specular", Honoured, "a light of specular 0 leaves a rough metal dark", || {
            let c = beside(more(), 3, 0.75, 0.0);
            ensure(c[1] < 0.005, || format!("{c:.4?}"))
        }),
        row("LightAPI", "collection:lightLink", Honoured, "a light whose lightLink collection excludes everything lights nothing", || {
            reads(more(), 4, 0.0, 0.0)
        }),
        row("LightAPI", "collection:shadowLink", Honoured, "an occluder outside a light's shadowLink collection casts no shadow from it: the ground it would shade, beside its image, reads the unshadowed disk", || {
            // The column 1..1.25 right of the light, beyond the occluder's image.
            let (px, py) = pixel(SLOTS[5].0 + 1.125, SLOTS[5].1);
            let pixels = ((px, px + 1), (py - 1, py + 1));
            let c = more().mean(pixels.0, pixels.1);
            let open = expected_in(5, pixels, disk(5.0, 0.3));
            ensure((c[1] - open).abs() <= 0.1 * open, || format!("{c:.4?} against {open:.4} unshadowed"))
        }),
        row("ShadowAPI", "inputs:shadow:enable", Warned,
            "ignored (shadows cast as by default), with a warning naming the light and the input; so are the other ShadowAPI inputs", || {
                more().warned(&["/Unshadowed", "inputs:shadow:enable"])
            }),
        row("ShapingAPI", "inputs:shaping:cone:angle", Honoured, "a disk light coned to 10 degrees leaves the ground 56 degrees off its axis dark", || {
            reads(shapes(), 5, 0.0, 0.0)
        }),
        row("ShapingAPI", "inputs:shaping:focus", Honoured,
            "focus 10 (an off-axis cosine power) leaves the ground 56 degrees off the axis under a fifth of the unshaped light", || {
                let (xs, ys) = region(2);
                let c = emitters().mean(xs, ys);
                let open = expected(2, disk(5.0, 0.3));
                ensure(c[1] < 0.2 * open, || format!("{c:.4?} against {open:.4} unshaped"))
            }),
        row("LightAPI", "visibility (Imageable)", Honoured, "an invisible disk light lights nothing", || reads(emitters(), 3, 0.0, 0.0)),
        row("SphereLight", "inputs:radius", Honoured, "a sphere of radius 0.2, radiance 10 lights the ground as pi L r^2 cos / d^2", || {
            reads(shapes(), 0, expected(0, sphere(10.0, 0.2)), 0.06)
        }),
        row("SphereLight", "treatAsPoint", Honoured, "a point light of the sphere's power: the same irradiance, no visible body", || {
            let (px, py) = pixel(SLOTS[1].0, SLOTS[1].1);
            let body = more().mean((px - 1, px + 1), (py - 1, py + 1));
            reads(more(), 1, expected(1, sphere(10.0, 0.2)), 0.06)
                .and(ensure(body[1] < 3.0, || format!("the point shows a body {body:.3?}")))
        }),
        row("DiskLight", "inputs:radius", Honoured, "a disk of radius 0.3, radiance 5 lights the ground as Lambert's formula says", || {
            reads(shapes(), 1, expected(1, disk(5.0, 0.3)), 0.06)
        }),
        row("RectLight", "inputs:width, inputs:height", Honoured, "a 0.6 x 0.3 rect of radiance 8 lights the ground as Lambert's formula says", || {
            reads(shapes(), 2, expected(2, rect(8.0, 0.6, 0.3)), 0.06)
        }),
        row("CylinderLight", "inputs:length, inputs:radius", Honoured, "a cylinder 2 long along X lights the ground beside its middle over 3 x more than 0.5..1 beyond its end", || {
            let (side, end) = (beside(more(), 0, 0.0, -0.75)[1], beside(more(), 0, 1.75, 0.0)[1]);
            ensure(side > 3.0 * end && side > 0.01, || format!("beside {side:.4}, beyond the end {end:.4}"))
        }),
        row("MeshLightAPI", "collection:lightLink, collection:shadowLink", Warned, "a mesh light's own link collections are not read: a warning names the light and collection (it lights every part)", || {
            emitters().warned(&["/LeftHanded", "collection:lightLink"])
        }),
        row("MeshLightAPI", "inputs:intensity (on a Mesh)", Honoured, "a 0.4 x 0.4 mesh light of intensity 10 lights the ground under it", || {
            let open = expected(0, rect(10.0, 0.4, 0.4));
            let (xs, ys) = region(0);
            let c = emitters().mean(xs, ys);
            ensure(c[1] > 0.5 * open, || format!("{c:.4?} against {open:.4}"))
        }),
        row("DomeLight", "inputs:texture:file", Honoured, "a lat-long sky, blue above the horizon, lights an upward ground blue (0.5 x 1)", || {
            near("lat-long", latlong().mean((16, 48), (12, 36)), [0.0, 0.0, 0.5], 0.05)
        }),
        row("DomeLight", "inputs:texture:format angular", Honoured,
            "an angular probe (blue inside half its radius, red to the rim) turned to face the ground lights it with one colour", || one_hemisphere(angular())),
        row("DomeLight", "inputs:texture:format mirroredBall", Honoured,
            "a mirrored-ball probe (blue inside radius sin 45 degrees) turned to face the ground lights it with one colour", || one_hemisphere(mirrored_ball())),
        row("DistantLight", "inputs:angle", Honoured,
            "a sun of angular diameter 10 degrees casts a penumbra (from a black edge 4 above the ground) whose profile across 10 pixel columns follows the visible part of its disk", || {
                let shot = sun();
                let lit = shot.mean((8, 20), (8, 40))[1];
                let mut worst = (0.0f64, 0, 0.0, 0.0);
                for px in 26..36 {
                    let measured = shot.mean((px, px + 1), (8, 40))[1] / lit;
                    let expected = (0..8).map(|i| sun_fraction((px as f64 + (i as f64 + 0.5) / 8.0) / 4.0 - 8.0)).sum::<f64>() / 8.0;
                    if (measured - expected).abs() > worst.0 {
                        worst = ((measured - expected).abs(), px, measured, expected);
                    }
                }
                let (err, px, m, e) = worst;
                ensure(err < 0.05 && lit > 0.1, || format!("column {px}: {m:.3} of the lit {lit:.3}, expected {e:.3}"))
            }),
        row("ShapingAPI", "inputs:shaping:cone:softness", Honoured,
            "cone 70 degrees, softness 0.5: the ground 45..64 degrees off the axis reads the small disk's irradiance times 1 - smoothstep(35, 70 degrees)", || {
                let soft = shaped(|t| 1.0 - smoothstep(35f64.to_radians(), 70f64.to_radians(), t));
                reads(emitters(), 4, expected(4, soft), 0.06)
            }),
        row("ShapingAPI", "inputs:shaping:ies:file", Honoured,
            "an LM-63 profile falling linearly from 1 cd on the axis to 0 at 90 degrees scales the small disk's irradiance by 1 - theta / 90 degrees", || {
                reads(emitters(), 5, expected(5, shaped(ramp)), 0.06)
            }),
        row("ShapingAPI", "inputs:shaping:ies:angleScale", Honoured,
            "2 stretches the ramp profile to 1 - theta / 180 degrees (theta / angleScale is the profile's angle, as OpenUSD's hdEmbree applies it)", || {
                reads(emitters(), 6, expected(6, shaped(|t| ramp(t / 2.0))), 0.06)
            }),
        row("ShapingAPI", "inputs:shaping:ies:normalize", Honoured,
            "the ramp profile divided by its mean intensity over the sphere, (1 - 2 / pi) / 2 cd: the light keeps the power of the unshaped disk", || {
                let mean = (1.0 - 2.0 / PI) / 2.0;
                reads(emitters(), 7, expected(7, shaped(|t| ramp(t) / mean)), 0.06)
            }),
        row("CylinderLight", "treatAsLine", Warned, "rendered as a cylinder of its radius, with a warning naming the light and the attribute", || {
            more().warned(&["/Cylinder", "treatAsLine"])
        }),
        row("ShadowAPI", "inputs:shadow:color", Warned, "shadows stay black, with a warning naming the light and the input", || {
            more().warned(&["/Unshadowed", "inputs:shadow:color"])
        }),
        row("DomeLight_1", "poleAxis", Warned, "a pole authored +Z: the dome keeps its +Y pole, with a warning naming the light and poleAxis", || {
            sun().warned(&["/Pole", "poleAxis"])
        }),
        row("PortalLight", "inputs:width, inputs:height", Warned,
            "a portal guides the dome's sampling: the log names it, and the image is the portal-less one", || {
                latlong().warned(&["/Portal"])
            }),
    ]
}

#[test]
fn rows_hold() {
    super::check_rows(&rows());
}
