//! OpenPBR thick transmission end to end (issue 21): a glass slab exported
//! from USD (a MaterialX `open_pbr_surface` network) and rendered by
//! `cirrus render`, against the closed forms of a plane-parallel slab at
//! normal incidence, within 4 sigma (see tests/render.rs for the method).
//!
//! The slab is 1 unit thick, 6 wide, of ior 1.5 (Fresnel R = 0.04 at each
//! face) and smooth; an orthographic camera looks straight down through
//! it at a one-sided panel of radiance 1 below, and nothing else emits, so
//! a pixel is the slab's transmittance with every internal reflection:
//! - `transmission_depth` d > 0: the interior absorbs with sigma =
//!   -ln(c)/d, tau = exp(-sigma 1) = c^(1/d), and the colour does not tint
//!   the faces: T = (1 - R)^2 tau / (1 - R^2 tau^2);
//! - d = 0: the colour tints each refraction, the interior is clear:
//!   T = c^2 (1 - R)^2 / (1 - R^2) = c^2 (1 - R) / (1 + R).

use crate::common::render::{Image, Render, PIXEL_ROUNDING};
use crate::common::{assert_within_4_sigma, cirrus_ok, estimate, scratch};

/// Fresnel reflectance of ior 1.5 at normal incidence.
const R: f64 = 0.04;

/// `transmission_color` of every case.
const COLOR: [f64; 3] = [0.25, 0.5, 0.9];

/// The stage: the slab with an OpenPBR glass of `transmission_depth`
/// `depth` (and the thin film `film`, weight and thickness in um, if any),
/// the camera and the panel.
fn stage(depth: f64, film: Option<(f64, f64)>) -> String {
    let [r, g, b] = COLOR;
    let film = film.map_or(String::new(), |(weight, thickness)| {
        format!(
            "float inputs:thin_film_weight = {weight}\n                \
             float inputs:thin_film_thickness = {thickness}"
        )
    });
    format!(
        r#"#usda 1.0
(
    defaultPrim = "World"
    metersPerUnit = 1
    upAxis = "Y"
)

def Xform "World"
{{
    def Camera "Camera"
    {{
        double3 xformOp:translate = (0, 5, 0)
        float xformOp:rotateX = -90
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
        token projection = "orthographic"
        float horizontalAperture = 4
        float verticalAperture = 4
        float2 clippingRange = (0.01, 100)
    }}

    def Mesh "Slab" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {{
        point3f[] points = [(-3, -0.5, -3), (3, -0.5, -3), (3, -0.5, 3), (-3, -0.5, 3), (-3, 0.5, -3), (3, 0.5, -3), (3, 0.5, 3), (-3, 0.5, 3)]
        int[] faceVertexCounts = [4, 4, 4, 4, 4, 4]
        int[] faceVertexIndices = [0, 1, 2, 3, 4, 7, 6, 5, 0, 4, 5, 1, 1, 5, 6, 2, 2, 6, 7, 3, 3, 7, 4, 0]
        uniform token subdivisionScheme = "none"
        rel material:binding = </World/Looks/Glass>
    }}

    def Scope "Looks"
    {{
        def Material "Glass"
        {{
            token outputs:mtlx:surface.connect = </World/Looks/Glass/surface.outputs:out>

            def Shader "surface"
            {{
                uniform token info:id = "ND_open_pbr_surface_surfaceshader"
                float inputs:transmission_weight = 1
                color3f inputs:transmission_color = ({r}, {g}, {b})
                float inputs:transmission_depth = {depth}
                float inputs:specular_roughness = 0
                {film}
                token outputs:out
            }}
        }}
    }}

    def RectLight "Panel"
    {{
        double3 xformOp:translate = (0, -2, 0)
        float xformOp:rotateX = 90
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateX"]
        float inputs:width = 20
        float inputs:height = 20
        float inputs:intensity = 1
    }}
}}
"#
    )
}

/// The stage exported into `dir/out` (asserting the exporter warned about
/// nothing: depth and a film on transmission are both rendered) and
/// rendered at 16x16, 64 spp.
fn render(dir: &std::path::Path, text: &str) -> Image {
    let usda = dir.join("stage.usda");
    std::fs::write(&usda, text).unwrap();
    let out = dir.join("out");
    let log = cirrus_ok(&[
        "export".as_ref(),
        usda.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(log.contains(" 0 warning(s)"), "{log}");
    Render {
        scene: out.to_str().unwrap(),
        res: (16, 16),
        spp: 64,
        seed: 7,
        extra: &[],
    }
    .run(dir)
}

/// Each channel's pixels against `expected(c)`, 4 sigma.
fn assert_channels(what: &str, image: &Image, expected: impl Fn(f64) -> f64) {
    for (c, colour) in COLOR.into_iter().enumerate() {
        let measured = estimate(image.pixels(c, |_, _| true));
        let name = format!("{what}, channel {c} (colour {colour})");
        assert_within_4_sigma(&name, measured, expected(colour), PIXEL_ROUNDING);
    }
}

/// transmission_depth 2 over a thickness of 1: tau = c^(1/2), Beer-Lambert
/// inside, untinted faces.
#[test]
fn a_deep_slab_absorbs_inside_by_beer_lambert() {
    let dir = scratch("transmission_depth");
    let image = render(&dir, &stage(2.0, None));
    assert_channels("depth 2", &image, |c| {
        let tau = c.sqrt();
        (1.0 - R).powi(2) * tau / (1.0 - R * R * tau * tau)
    });
}

/// transmission_depth 0: the colour tints both refractions.
#[test]
fn without_depth_the_colour_tints_the_faces() {
    let dir = scratch("transmission_no_depth");
    let image = render(&dir, &stage(0.0, None));
    assert_channels("depth 0", &image, |c| c * c * (1.0 - R) / (1.0 + R));
}

/// A thin film far thicker than the coherence length (50 um) reflects the
/// incoherent sum of its two interfaces (tested in thin_film.rs): with the
/// default film ior 1.4 on glass 1.5, R' = R12 + (1 - R12)^2 R23 / (1 -
/// R12 R23) at each face, and the slab transmits with R' in place of R.
#[test]
fn a_thin_film_on_glass_transmits_what_it_does_not_reflect() {
    let dir = scratch("transmission_film");
    let image = render(&dir, &stage(2.0, Some((1.0, 50.0))));
    let fresnel = |n: f64| ((n - 1.0) / (n + 1.0)).powi(2);
    let (r12, r23) = (fresnel(1.4), fresnel(1.5 / 1.4));
    let r = r12 + (1.0 - r12).powi(2) * r23 / (1.0 - r12 * r23);
    assert_channels("film 50 um", &image, |c| {
        let tau = c.sqrt();
        (1.0 - r).powi(2) * tau / (1.0 - r * r * tau * tau)
    });
}
