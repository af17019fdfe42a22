//! Production looks end to end (issue 21): scenes exported by the real
//! exporter, their `scene.json` patched here to OpenPBR records with
//! primvar-driven inputs (as the MaterialX exporter writes them), rendered
//! by `cirrus render` and compared with closed forms or with the
//! UsdPreviewSurface equivalent, within 4 sigma (see tests/render.rs).

use crate::common;
use std::path::{Path, PathBuf};

use crate::common::render::{exported, Image, Render, PIXEL_ROUNDING};
use crate::common::{assert_within_4_sigma, estimate, Estimate};
use serde_json::{json, Value};

/// A copy of the exported scene folder `from` in `to`, its manifest and
/// blob passed through `patch` first.
fn patched(from: &Path, to: &Path, patch: impl FnOnce(&mut Value, &mut Vec<u8>)) -> PathBuf {
    let text = std::fs::read_to_string(from.join("scene.json")).unwrap();
    let mut manifest: Value = serde_json::from_str(&text).unwrap();
    let mut blob = std::fs::read(from.join("scene.bin")).unwrap();
    patch(&mut manifest, &mut blob);
    std::fs::write(to.join("scene.json"), manifest.to_string()).unwrap();
    std::fs::write(to.join("scene.bin"), blob).unwrap();
    to.to_owned()
}

/// Appends f32 `values` (`width` per element) to the blob at a 16-byte
/// boundary: their array reference.
fn append(blob: &mut Vec<u8>, width: usize, values: &[f32]) -> Value {
    blob.resize(blob.len().next_multiple_of(16), 0);
    let offset = blob.len();
    blob.extend(values.iter().flat_map(|v| v.to_le_bytes()));
    json!({"offset": offset, "count": values.len() / width, "type": "f32", "width": width})
}

/// The f32 triples of the array reference `array` in `blob`.
fn triples(blob: &[u8], array: &Value) -> Vec<[f32; 3]> {
    let offset = array["offset"].as_u64().unwrap() as usize;
    let count = array["count"].as_u64().unwrap() as usize;
    blob[offset..offset + 12 * count]
        .chunks_exact(12)
        .map(|c| [0, 4, 8].map(|i| f32::from_le_bytes(c[i..i + 4].try_into().unwrap())))
        .collect()
}

/// The tint primvar of [`open_pbr_base_color_reads_the_primvar`]: linear
/// in world x, so barycentric interpolation reproduces it on any triangle.
fn tint(x: f64) -> [f64; 3] {
    let t = (x + 10.0) / 20.0;
    [0.2 + 0.6 * t, 0.5, 0.8 - 0.6 * t]
}

/// The Lambert plane under a constant dome (scenes/tests/lambert_plane_dome.usda,
/// dome radiance (1.5, 3, 6)) as an OpenPBR surface without specular, metal
/// or diffuse roughness whose `base_color` reads a primvar `tint` linear in
/// x: every pixel is tint(x) x dome radiance (a box-filtered pixel averages
/// a linear function to its centre's value). The view is widened to 18
/// units so the tint spans 0.26..0.74 in red.
#[test]
fn open_pbr_base_color_reads_the_primvar() {
    let dir = common::scratch("looks_primvar");
    let scene = patched(&exported("lambert_plane_dome"), &dir, |m, blob| {
        let points = triples(blob, &m["meshes"][0]["points"]);
        let values: Vec<f32> = points
            .iter()
            .flat_map(|p| tint(f64::from(p[0])).map(|v| v as f32))
            .collect();
        m["meshes"][0]["primvars"] = json!({"tint": append(blob, 3, &values)});
        m["materials"][0] = json!({
            "path": "/World/Looks/Tinted", "model": "open_pbr",
            "shader": "ND_open_pbr_surface_surfaceshader",
            "open_pbr": {
                "specular_weight": 0, "base_metalness": 0, "base_diffuse_roughness": 0,
                "base_color": {"primvar": "tint", "channel": "rgb", "fallback": [1, 0, 1]}
            }
        });
        m["camera"]["horizontal_aperture"] = json!(180);
        m["camera"]["vertical_aperture"] = json!(180);
    });
    let res = 24;
    let image = Render {
        scene: scene.to_str().unwrap(),
        res: (res, res),
        spp: 16,
        seed: 3,
        extra: &[],
    }
    .run(&dir);
    let x = |column: usize| -9.0 + 18.0 * (column as f64 + 0.5) / f64::from(res);
    for (c, dome) in [1.5, 3.0, 6.0].into_iter().enumerate() {
        let ratios = (0..image.height).flat_map(|row| {
            let image = &image;
            (0..image.width).map(move |column| {
                let pixel = f64::from(image.rgb[c][row * image.width + column]);
                pixel / (tint(x(column))[c] * dome)
            })
        });
        let what = format!("pixel / (primvar tint x dome), channel {c}");
        assert_within_4_sigma(&what, estimate(ratios), 1.0, PIXEL_ROUNDING);
    }
    // The tint varies across the image: the primvar is read per hit.
    let (left, right) = (image.rgb[0][0], image.rgb[0][res as usize - 1]);
    assert!(
        right > 2.0 * left,
        "red {left} on the left, {right} on the right"
    );
}

/// The plane of `open_pbr_base_color_reads_the_primvar` as a black smooth
/// dielectric (specular only, roughness 0) seen straight down: it mirrors
/// the constant dome, so pixel / dome is the Fresnel factor at normal
/// incidence, F0 = 0.04 in every channel without a film. A thin film
/// (0.5 um of ior 2, OpenPBR's `thin_film_*` read from the scene) colours
/// it: the channels part by far more than 4 sigma.
#[test]
fn a_thin_film_colours_the_reflection() {
    let dir = common::scratch("looks_thin_film");
    let mirror = |film: f32| {
        let to = dir.join(format!("film{film}"));
        std::fs::create_dir_all(&to).unwrap();
        let scene = patched(&exported("lambert_plane_dome"), &to, |m, _| {
            m["materials"][0] = json!({
                "path": "/World/Looks/Film", "model": "open_pbr",
                "shader": "ND_open_pbr_surface_surfaceshader",
                "open_pbr": {
                    "base_color": [0, 0, 0], "specular_roughness": 0,
                    "thin_film_weight": film, "thin_film_thickness": 0.5, "thin_film_ior": 2.0
                }
            });
        });
        Render {
            scene: scene.to_str().unwrap(),
            res: (8, 8),
            spp: 4,
            seed: 5,
            extra: &[],
        }
        .run(&dir)
    };
    let fresnel = |image: &Image, c: usize| {
        let dome = [1.5, 3.0, 6.0][c];
        estimate(image.rgb[c].iter().map(|v| f64::from(*v) / dome))
    };
    let bare = mirror(0.0);
    for c in 0..3 {
        assert_within_4_sigma(
            &format!("bare F0, channel {c}"),
            fresnel(&bare, c),
            0.04,
            PIXEL_ROUNDING,
        );
    }
    let film = mirror(1.0);
    let [r, g, b] = [0, 1, 2].map(|c| fresnel(&film, c));
    let apart =
        |a: Estimate, b: Estimate| (a.mean - b.mean).abs() > 4.0 * (a.sigma + b.sigma) + 0.01;
    assert!(
        apart(r, g) || apart(g, b) || apart(r, b),
        "film F: {r:?} {g:?} {b:?}"
    );
}

/// A Lambert plane (albedo 0.5) lit only by a small double-sided emissive
/// quad 1.5 above it, seen straight down by an orthographic camera (4 x 4
/// units): the quad covers columns 2..=7 and rows 13..=18 of 32 x 32 pixels.
const EMITTER_STAGE: &str = r#"#usda 1.0
(
    metersPerUnit = 1
    upAxis = "Y"
)

def Xform "World"
{
    def Camera "Camera"
    {
        double3 xformOp:translate = (0, 3, 0)
        float xformOp:rotateX = -90
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
        token projection = "orthographic"
        float horizontalAperture = 40
        float verticalAperture = 40
        float2 clippingRange = (0.01, 100)
    }

    def Mesh "Plane" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        point3f[] points = [(-10, 0, -10), (-10, 0, 10), (10, 0, 10), (10, 0, -10)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        rel material:binding = </World/Looks/Lambert>
    }

    def Mesh "Lamp" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        point3f[] points = [(-1.8, 1.5, -0.4), (-1.8, 1.5, 0.4), (-1, 1.5, 0.4), (-1, 1.5, -0.4)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        uniform bool doubleSided = 1
        rel material:binding = </World/Looks/Lamp>
    }

    def Scope "Looks"
    {
        def Material "Lambert"
        {
            token outputs:surface.connect = </World/Looks/Lambert/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (0.5, 0.5, 0.5)
                int inputs:useSpecularWorkflow = 1
                color3f inputs:specularColor = (0, 0, 0)
                token outputs:surface
            }
        }

        def Material "Lamp"
        {
            token outputs:surface.connect = </World/Looks/Lamp/Surface.outputs:surface>
            def Shader "Surface"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (0, 0, 0)
                color3f inputs:emissiveColor = (0.5, 1, 2)
                int inputs:useSpecularWorkflow = 1
                color3f inputs:specularColor = (0, 0, 0)
                token outputs:surface
            }
        }
    }
}
"#;

/// The emitter of [`EMITTER_STAGE`] as UsdPreviewSurface (emissiveColor
/// (0.5, 1, 2), black otherwise) and as OpenPBR (emission_luminance 2 x
/// emission_color (0.25, 0.5, 1), base and specular weight 0): seen
/// directly, the OpenPBR quad is exactly 2 c; it lights the plane as the
/// UsdPreviewSurface quad does (the mean per-pixel difference of the two
/// renders is 0 within 4 sigma), through light sampling as well.
#[test]
fn emissive_open_pbr_quads_are_lights_like_preview_surface_ones() {
    let dir = common::scratch("looks_emitter");
    let usda = dir.join("emitter.usda");
    std::fs::write(&usda, EMITTER_STAGE).unwrap();
    let exported = dir.join("preview");
    common::cirrus_ok(&[
        "export".as_ref(),
        usda.as_os_str(),
        "-o".as_ref(),
        exported.as_os_str(),
    ]);
    let open_pbr_dir = dir.join("open_pbr");
    std::fs::create_dir_all(&open_pbr_dir).unwrap();
    let open_pbr = patched(&exported, &open_pbr_dir, |m, _| {
        let materials = m["materials"].as_array_mut().unwrap();
        let lamp = materials
            .iter_mut()
            .find(|mat| mat["path"] == "/World/Looks/Lamp")
            .unwrap();
        *lamp = json!({
            "path": "/World/Looks/Lamp", "model": "open_pbr",
            "open_pbr": {"base_weight": 0, "specular_weight": 0,
                         "emission_luminance": 2, "emission_color": [0.25, 0.5, 1.0]}
        });
    });
    let render = |scene: &Path| -> Image {
        Render {
            scene: scene.to_str().unwrap(),
            res: (32, 32),
            spp: 64,
            seed: 5,
            extra: &[],
        }
        .run(&dir)
    };
    let (preview, open_pbr) = (render(&exported), render(&open_pbr));
    let lamp = |x: usize, y: usize| (2..=7).contains(&x) && (13..=18).contains(&y);
    let plane = |x: usize, _: usize| x >= 10;
    for (c, emitted) in [0.5, 1.0, 2.0].into_iter().enumerate() {
        for value in open_pbr.pixels(c, lamp) {
            assert!(
                (value - emitted).abs() <= 1e-6 * emitted,
                "lamp {c}: {value}"
            );
        }
        let (a, b) = (preview.pixels(c, plane), open_pbr.pixels(c, plane));
        let lit = estimate(&b);
        assert!(lit.mean > 20.0 * lit.sigma, "the plane is lit: {lit:?}");
        let differences = a.iter().zip(&b).map(|(a, b)| a - b);
        let what = format!("plane lit by OpenPBR - by UsdPreviewSurface, channel {c}");
        assert_within_4_sigma(&what, estimate(differences), 0.0, PIXEL_ROUNDING);
    }
}
