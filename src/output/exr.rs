//! Writing a film as EXRs: the beauty and AOV layers in one file or one per
//! AOV, with the header every render's EXR carries. The header is computed
//! once from the render state and settings and kept in film-state files, so
//! `cirrus merge` writes the same EXR as the render would, without the render
//! state.

use std::path::Path;

use glam::UVec2;
use serde::{Deserialize, Serialize};

use crate::film::{Aov, AovSet, CryptoLayer, Film, Layer};
use crate::image::{write_exr, Channel, Compression, ExrImage, ImageError, PixelType};
use crate::integrator::{RenderSettings, RenderStats};
use crate::render_state::RenderState;

use super::render_vars::{LayerSource, Layers, NamedLayer};

/// How AOVs are split over files (`--aov-files`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AovFiles {
    /// One multi-channel EXR: beauty in the base layer, AOVs as layers.
    #[default]
    Single,
    /// The beauty in OUT.exr and each AOV in OUT.<aov>.exr.
    Separate,
}

crate::choice::choice!(AovFiles {
    Single => "single",
    Separate => "separate",
});

/// What every EXR of a render carries besides its pixels and run statistics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExrHeader {
    /// `software` and the settings as `cirrus/*` strings.
    strings: Vec<(String, String)>,
    /// `worldToCamera` and `worldToNDC` (Imath's row-vector layout, which is
    /// glam's column-major array of the column-vector matrix).
    matrices: Vec<(String, [f32; 16])>,
    /// Names of the CryptoObject and CryptoMaterial ids (Mesh and Material
    /// prim paths, indexed like the film's ids), when chosen.
    crypto_names: [Option<Vec<String>>; 2],
}

impl ExrHeader {
    /// The header of a render of `state` with `settings`, with the
    /// Cryptomatte names of the chosen Cryptomatte AOVs.
    pub fn new(state: &RenderState, settings: &RenderSettings) -> Self {
        let attribute = |k: &str, v: String| (format!("cirrus/{k}"), v);
        let p = &settings.path;
        let strings = vec![
            (
                "software".to_string(),
                format!("Cirrus {}", env!("CARGO_PKG_VERSION")),
            ),
            attribute("version", env!("CARGO_PKG_VERSION").into()),
            attribute("seed", settings.seed.to_string()),
            attribute("sampler", format!("{:?}", settings.sampler)),
            attribute("strategy", format!("{:?}", p.strategy)),
            attribute("max_depth", p.max_depth.to_string()),
            attribute("volume_estimator", format!("{:?}", p.volume_estimator)),
            attribute("equiangular", p.equiangular.to_string()),
            attribute("majorant", format!("{:?}", state.options.majorant)),
            attribute(
                "volume_light_sampling",
                state.options.volume_lights.to_string(),
            ),
            attribute("aovs", settings.aovs.to_string()),
            attribute("shutter", state.camera.shutter().to_string()),
        ];
        let camera = &state.camera;
        let names = |aov: Aov, paths: Vec<String>| settings.aovs.contains(aov).then_some(paths);
        let crypto_names = [
            names(Aov::CryptoObject, state.id_names.objects.clone()),
            names(Aov::CryptoMaterial, state.id_names.materials.clone()),
        ];
        Self {
            strings,
            matrices: vec![
                (
                    "worldToCamera".into(),
                    camera.world_to_camera().to_cols_array(),
                ),
                ("worldToNDC".into(), camera.world_to_ndc().to_cols_array()),
            ],
            crypto_names,
        }
    }

    /// The Cryptomatte layers of the chosen AOVs.
    fn crypto_layers(&self, aovs: &AovSet) -> [Option<CryptoLayer>; 2] {
        let layer = |aov: Aov, names: &Option<Vec<String>>| {
            names
                .as_ref()
                .filter(|_| aovs.contains(aov))
                .map(|n| CryptoLayer::new(aov.name(), n.clone()))
        };
        [
            layer(Aov::CryptoObject, &self.crypto_names[0]),
            layer(Aov::CryptoMaterial, &self.crypto_names[1]),
        ]
    }
}

/// Bytes writing a film of `pixels` pixels with `aovs` holds at its peak
/// beside the film: the layers (beauty RGBA and every AOV's channels, as
/// `f32`), their interleaved copy and the bridge's copy for OpenImageIO;
/// or, when larger, the preview's beauty RGB, its tone-mapped copy and
/// OpenImageIO's 8-bit buffer.
pub fn write_bytes_for(pixels: u64, aovs: &AovSet) -> u64 {
    let channels = 4 + aovs
        .aovs()
        .iter()
        .map(|a| a.channels().len())
        .sum::<usize>();
    let layers = 3 * 4 * channels as u64;
    let preview = 12 + 12 + 3;
    pixels * layers.max(preview)
}

/// Writes the film: its `layers` (the beauty and every chosen AOV, or a
/// render product's vars), in one EXR or one per AOV (`OUT.<layer>.exr`,
/// the beauty in OUT.exr), each with the header, the run's statistics and
/// a Cryptomatte's own metadata.
pub fn write_film(
    output: &Path,
    files: AovFiles,
    film: &Film,
    header: &ExrHeader,
    stats: &RenderStats,
    compression: Compression,
    layers: &Layers,
) -> Result<(), ImageError> {
    let crypto = header.crypto_layers(film.aov_set());
    let crypto_of = |aov| match aov {
        Aov::CryptoObject => crypto[0].as_ref(),
        Aov::CryptoMaterial => crypto[1].as_ref(),
        _ => None,
    };
    let beauty = || FileLayer {
        name: None,
        layer: film.beauty_layer(),
        metadata: Vec::new(),
    };
    let mut all = match layers {
        Layers::Film => std::iter::once(beauty())
            .chain(film.aov_set().aovs().iter().map(|&aov| {
                let crypto = crypto_of(aov);
                FileLayer {
                    name: Some(aov.name().to_string()),
                    layer: film.aov_layer(aov, crypto),
                    metadata: crypto.map(CryptoLayer::metadata).unwrap_or_default(),
                }
            }))
            .collect(),
        Layers::Named(named) => named
            .iter()
            .map(|n| named_layer(film, header, n))
            .collect::<Vec<_>>(),
    };
    let write = |path: &Path, layers: &[&FileLayer]| {
        let image = Image {
            size: film.window.size,
            layers: &layers.iter().map(|l| &l.layer).collect::<Vec<_>>(),
            compression,
        };
        let metadata = layers.iter().flat_map(|l| l.metadata.clone()).collect();
        write_layers(path, &image, metadata, header, stats)
    };
    match files {
        AovFiles::Single => write(output, &all.iter().collect::<Vec<_>>()),
        AovFiles::Separate => {
            // The beauty in OUT.exr (the film's, when the layers hold none).
            if all.iter().all(|l| l.name.is_some()) {
                all.insert(0, beauty());
            }
            let (base, others): (Vec<&FileLayer>, Vec<&FileLayer>) =
                all.iter().partition(|l| l.name.is_none());
            write(output, &base)?;
            for layer in others {
                let name = layer.name.as_deref().unwrap_or_default();
                write(&output.with_extension(format!("{name}.exr")), &[layer])?;
            }
            Ok(())
        }
    }
}

/// One layer of a file: its name (`None`: the unprefixed beauty), pixels
/// and header attributes (a Cryptomatte's).
struct FileLayer {
    name: Option<String>,
    layer: Layer,
    metadata: Vec<(String, String)>,
}

/// A render product's layer: the film's beauty, or the sum of its AOVs'
/// layers with the channels renamed after the var (`N.X` -> `normal.X`,
/// `Z` -> `depth`, `CryptoObject00.R` -> `crypto_object00.R`).
fn named_layer(film: &Film, header: &ExrHeader, named: &NamedLayer) -> FileLayer {
    let (name, mut layer, metadata) = match &named.source {
        LayerSource::Beauty => (None, film.beauty_layer(), Vec::new()),
        LayerSource::Aovs(aovs) => {
            let aov = aovs[0];
            let names = match aov {
                Aov::CryptoObject => header.crypto_names[0].clone(),
                Aov::CryptoMaterial => header.crypto_names[1].clone(),
                _ => None,
            };
            let crypto = names.map(|names| CryptoLayer::new(&named.name, names));
            let mut layer = film.aov_layer(aov, crypto.as_ref());
            for other in &aovs[1..] {
                let more = film.aov_layer(*other, None);
                layer
                    .pixels
                    .iter_mut()
                    .zip(&more.pixels)
                    .for_each(|(v, m)| *v += m);
            }
            for channel in &mut layer.channels {
                let suffix = channel.name.strip_prefix(aov.name()).unwrap_or_default();
                channel.name = format!("{}{suffix}", named.name);
            }
            let metadata = crypto.as_ref().map(CryptoLayer::metadata);
            let metadata = metadata.unwrap_or_default();
            (Some(named.name.clone()), layer, metadata)
        }
    };
    for channel in &mut layer.channels {
        channel.pixel_type = named.pixel_type;
    }
    FileLayer {
        name,
        layer,
        metadata,
    }
}

/// Writes a beauty-only EXR (float R, G, B) of `size` pixels with the
/// header: the benchmarks' references.
pub fn write_beauty(
    path: &Path,
    size: UVec2,
    rgb: &[f32],
    header: &ExrHeader,
    stats: &RenderStats,
) -> Result<(), ImageError> {
    let layer = Layer {
        channels: ["R", "G", "B"]
            .map(|name| Channel {
                name: name.into(),
                pixel_type: PixelType::Float,
            })
            .to_vec(),
        pixels: rgb.to_vec(),
    };
    let image = Image {
        size,
        layers: &[&layer],
        compression: Compression::Zip,
    };
    write_layers(path, &image, Vec::new(), header, stats)
}

/// Layers of one size to interleave into one EXR.
struct Image<'a> {
    size: UVec2,
    layers: &'a [&'a Layer],
    compression: Compression,
}

/// Writes `image`'s layers interleaved, with `strings`, the header and the
/// run's statistics (`cirrus/spp`, `cirrus/complete`, `cirrus/render_seconds`).
fn write_layers(
    path: &Path,
    image: &Image,
    mut strings: Vec<(String, String)>,
    header: &ExrHeader,
    stats: &RenderStats,
) -> Result<(), ImageError> {
    let pixel_count = image.size.x as usize * image.size.y as usize;
    let channels: Vec<Channel> = image
        .layers
        .iter()
        .flat_map(|l| l.channels.clone())
        .collect();
    let mut pixels = Vec::with_capacity(channels.len() * pixel_count);
    for i in 0..pixel_count {
        for layer in image.layers {
            let n = layer.channels.len();
            pixels.extend_from_slice(&layer.pixels[i * n..(i + 1) * n]);
        }
    }
    strings.extend(header.strings.iter().cloned());
    strings.extend([
        ("cirrus/spp".into(), stats.samples_per_pixel.to_string()),
        ("cirrus/complete".into(), stats.complete.to_string()),
        (
            "cirrus/render_seconds".into(),
            format!("{:.3}", stats.elapsed.as_secs_f64()),
        ),
    ]);
    write_exr(
        path,
        &ExrImage {
            width: image.size.x,
            height: image.size.y,
            channels,
            pixels: &pixels,
            compression: image.compression,
            strings,
            matrices: header.matrices.clone(),
        },
    )
}
