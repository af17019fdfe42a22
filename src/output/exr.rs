//! Writing a film as EXRs: the beauty and AOV layers in one file or one per
//! AOV, with the header every render's EXR carries. The header is computed
//! once from the render state and settings and kept in film-state files, so
//! `cirrus merge` writes the same EXR as the render would, without the render
//! state.

use std::path::Path;

use glam::UVec2;
use serde::{Deserialize, Serialize};

use crate::film::{Aov, AovSet, CryptoLayer, CryptoNames, Film, Layer, CRYPTOMATTES};
use crate::image::{
    write_framed_exr, Channel, Compression, ExrFrame, ExrImage, ImageError, PixelType,
};
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
    /// Per Cryptomatte (in `CRYPTOMATTES` order), when chosen: the names of
    /// the ids a film recorded, filled in by [`ExrHeader::named`] each time
    /// a film is written, so that a film-state file carries what its
    /// manifest needs and `cirrus merge` names the same ids a whole render
    /// would.
    #[serde(with = "names_as_pairs")]
    crypto_names: [Option<CryptoNames>; 3],
    /// `pixelAspectRatio`: a pixel's width over its height (1 in film
    /// states of version 2, which rendered square pixels).
    #[serde(default = "square")]
    pixel_aspect: f32,
    /// The layers a film state's image is written with (`cirrus merge`,
    /// the rescue command): a render product's vars (its first product's
    /// for a checkpoint or a part), or `None` for the film's own names (and
    /// in film states of version 2).
    #[serde(default)]
    layers: Option<Vec<LayerRecord>>,
}

/// Square pixels: what film states of version 2 rendered.
fn square() -> f32 {
    1.0
}

/// A [`NamedLayer`] in a film state: its name, its AOVs by name (`None`:
/// the beauty) and whether it is stored as half.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct LayerRecord {
    name: String,
    aovs: Option<Vec<String>>,
    half: bool,
}

impl LayerRecord {
    fn new(layer: &NamedLayer) -> Self {
        Self {
            name: layer.name.clone(),
            aovs: match &layer.source {
                LayerSource::Beauty => None,
                LayerSource::Aovs(aovs) => Some(aovs.iter().map(|a| a.name().into()).collect()),
            },
            half: layer.pixel_type == PixelType::Half,
        }
    }

    /// The layer back; an AOV name this Cirrus does not know is an error.
    fn layer(&self) -> Result<NamedLayer, String> {
        let source = match &self.aovs {
            None => LayerSource::Beauty,
            Some(names) => LayerSource::Aovs(
                names
                    .iter()
                    .map(|name| {
                        let set: AovSet = name.parse()?;
                        set.aovs()
                            .first()
                            .copied()
                            .ok_or(format!("no AOV '{name}'"))
                    })
                    .collect::<Result<_, String>>()?,
            ),
        };
        Ok(NamedLayer {
            name: self.name.clone(),
            source,
            pixel_type: if self.half {
                PixelType::Half
            } else {
                PixelType::Float
            },
        })
    }
}

/// Cryptomatte names in JSON as `[[id, name], ...]`: film-state headers are
/// read through `#[serde(flatten)]`, which cannot parse integer map keys.
mod names_as_pairs {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use crate::film::CryptoNames;

    type Pairs = [Option<Vec<(u32, String)>>; 3];

    pub fn serialize<S: Serializer>(
        names: &[Option<CryptoNames>; 3],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let pairs = names.each_ref().map(|n| {
            n.as_ref()
                .map(|n| n.iter().map(|(&id, name)| (id, name.clone())).collect())
        });
        Pairs::serialize(&pairs, s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<[Option<CryptoNames>; 3], D::Error> {
        let pairs = Pairs::deserialize(d)?;
        Ok(pairs.map(|p| p.map(|p| p.into_iter().collect())))
    }
}

impl ExrHeader {
    /// The header of a render of `state` with `settings`; its Cryptomatte
    /// names are filled in by [`ExrHeader::named`].
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
            attribute("exposure_scale", state.camera.exposure_scale().to_string()),
        ];
        let camera = &state.camera;
        let crypto_names =
            CRYPTOMATTES.map(|aov| settings.aovs.contains(aov).then(CryptoNames::new));
        Self {
            strings,
            pixel_aspect: camera.pixel_aspect(),
            layers: None,
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

    /// This header with the names of every Cryptomatte id `film` (a film
    /// of a render of `state`) recorded, for writing the film or its state.
    pub fn named(&self, state: &RenderState, film: &Film) -> Self {
        let mut header = self.clone();
        for (names, aov) in header.crypto_names.iter_mut().zip(CRYPTOMATTES) {
            if let Some(names) = names {
                names.extend(state.id_names.names(aov, &film.crypto_ids(aov)));
            }
        }
        header
    }

    /// This header writing a film state's image with `layers`.
    pub fn with_layers(&self, layers: &Layers) -> Self {
        let records = match layers {
            Layers::Film => None,
            Layers::Named(named) => Some(named.iter().map(LayerRecord::new).collect()),
        };
        Self {
            layers: records,
            ..self.clone()
        }
    }

    /// The layers a film state's image is written with (see
    /// [`ExrHeader::with_layers`]); an error names an AOV this Cirrus
    /// does not know.
    pub fn layers(&self) -> Result<Layers, String> {
        Ok(match &self.layers {
            None => Layers::Film,
            Some(records) => Layers::Named(
                records
                    .iter()
                    .map(LayerRecord::layer)
                    .collect::<Result<_, _>>()?,
            ),
        })
    }

    /// Adds the Cryptomatte names `other` (another part of the same frame)
    /// carries: `cirrus merge` names the ids of every part.
    pub fn add_names_of(&mut self, other: &ExrHeader) {
        for (names, more) in self.crypto_names.iter_mut().zip(&other.crypto_names) {
            if let (Some(names), Some(more)) = (names, more) {
                names.extend(more.iter().map(|(&id, name)| (id, name.clone())));
            }
        }
    }

    /// The Cryptomatte of `aov` over `layer` (its pixels), written as the
    /// layer `name`: the names of the ids the layer holds; `None` for other
    /// AOVs.
    fn crypto_layer(&self, aov: Aov, name: &str, layer: &Layer) -> Option<CryptoLayer> {
        let slot = CRYPTOMATTES.iter().position(|&a| a == aov)?;
        let names = self.crypto_names[slot].clone().unwrap_or_default();
        Some(CryptoLayer::new(name, names).present_in(&layer.pixels))
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
/// a Cryptomatte's own metadata. A film of a window of the image (a render
/// product's `dataWindowNDC`) is written as the EXR's data window, the
/// display window being the whole image.
pub fn write_film(
    output: &Path,
    files: AovFiles,
    film: &Film,
    header: &ExrHeader,
    stats: &RenderStats,
    compression: Compression,
    layers: &Layers,
) -> Result<(), ImageError> {
    let beauty = || FileLayer {
        name: None,
        layer: film.beauty_layer(),
        metadata: Vec::new(),
    };
    let mut all = match layers {
        Layers::Film => std::iter::once(beauty())
            .chain(film.aov_set().aovs().iter().map(|&aov| {
                let layer = film.aov_layer(aov);
                let crypto = header.crypto_layer(aov, &aov.name(), &layer);
                FileLayer {
                    name: Some(aov.name().to_string()),
                    layer,
                    metadata: crypto
                        .as_ref()
                        .map(CryptoLayer::metadata)
                        .unwrap_or_default(),
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
            frame: ExrFrame {
                origin: film.window.origin.to_array(),
                display: film.resolution.to_array(),
                pixel_aspect: header.pixel_aspect,
            },
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
            let mut layer = film.aov_layer(aov);
            let crypto = header.crypto_layer(aov, &named.name, &layer);
            for other in &aovs[1..] {
                let more = film.aov_layer(*other);
                layer
                    .pixels
                    .iter_mut()
                    .zip(&more.pixels)
                    .for_each(|(v, m)| *v += m);
            }
            for channel in &mut layer.channels {
                let suffix = channel.name.strip_prefix(&*aov.name()).unwrap_or_default();
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
        frame: ExrFrame {
            pixel_aspect: header.pixel_aspect,
            ..ExrFrame::whole(size.x, size.y)
        },
        layers: &[&layer],
        compression: Compression::Zip,
    };
    write_layers(path, &image, Vec::new(), header, stats)
}

/// Layers of one size to interleave into one EXR.
struct Image<'a> {
    size: UVec2,
    /// Where they sit in the image.
    frame: ExrFrame,
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
    write_framed_exr(
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
        &image.frame,
    )
}
