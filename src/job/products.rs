//! The files a render writes as the stage's USD render settings ask
//! (`RenderProduct`s and their `RenderVar`s, exported into `scene.json`),
//! with the command line's flags winning: `-o` replaces the first product's
//! `productName`, `--aovs` every product's vars, `--res` and `--camera`
//! apply to every product. A part of a frame (`-o PART.film`) is the first
//! product's alone.
//!
//! The products share one render: those whose camera, resolution, pixel
//! aspect and data window equal the first's are written from its film; any
//! other is not rendered, with a warning naming it. The first product's
//! `pixelAspectRatio` shapes the camera's pixels (`camera::Raster`) and its
//! `dataWindowNDC` is the EXR's data window (the display window being the
//! whole image).

use std::path::{Path, PathBuf};

use glam::UVec2;

use super::{is_film_output, Claim, JobError, OutputFiles};
use crate::film::{AovSet, Tile};
use crate::image::PixelType;
use crate::output::{layer_of, AovFiles, LayerSource, Layers, NamedLayer, VarAttributes};
use crate::scene::{Render, RenderProduct};

/// One file of a render and its layers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ProductOutput {
    /// The EXR (the PNG preview goes beside it).
    pub path: PathBuf,
    /// Its layers.
    pub layers: Layers,
}

/// What a render writes.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputPlan {
    /// The files, the first one's checkpoint standing for the render.
    pub outputs: Vec<ProductOutput>,
    /// The AOVs the film accumulates: `--aovs`, else every var's.
    pub aovs: AovSet,
    /// The first product's `dataWindowNDC` when it is not the whole image.
    pub data_window_ndc: Option<[f32; 4]>,
}

impl OutputPlan {
    /// The pixels of an image of `resolution` the frame covers: the first
    /// product's data window, else the whole image.
    pub fn frame_window(&self, resolution: UVec2) -> Result<Tile, JobError> {
        match self.data_window_ndc {
            Some(ndc) => data_window(ndc, resolution),
            None => Ok(Tile {
                origin: UVec2::ZERO,
                size: resolution,
            }),
        }
    }

    /// Each output's files, claimed before rendering ([`OutputFiles::claim`]:
    /// folders made, writability checked); `None` when `skip_existing` and
    /// the first output is complete. `resume` continues the first one's
    /// checkpoint, which stands for the render.
    pub fn claim(
        &self,
        aov_files: AovFiles,
        skip_existing: bool,
        resume: bool,
    ) -> Result<Option<Vec<OutputFiles>>, JobError> {
        let files: Vec<OutputFiles> = (self.outputs.iter())
            .map(|o| OutputFiles::new(&o.path, aov_files, &self.aovs))
            .collect();
        if files[0].claim(skip_existing, resume)? == Claim::Complete {
            return Ok(None);
        }
        for other in &files[1..] {
            other.claim(false, false)?;
        }
        Ok(Some(files))
    }
}

/// The command line's say over the stage's products.
#[derive(Clone, Copy, Debug, Default)]
pub struct OutputFlags<'a> {
    /// `-o`: the first product's file (with none, the only file).
    pub output: Option<&'a Path>,
    /// `--aovs`: the layers of every file, named as the film names them.
    pub aovs: Option<&'a AovSet>,
    /// `--res` was given: products may differ in resolution.
    pub resolution: bool,
    /// `--camera` was given.
    pub camera: bool,
    /// Rendering a sequence: a product name without a frame token is refused.
    pub sequence: bool,
}

/// The files of a render of a scene whose render settings say `render`,
/// exported at `time_code` (the frame number of `productName`'s frame
/// tokens, rounded; 1 at the default time), with `flags`; what is not
/// written is warned about (`log::warn`), naming the product or var.
pub fn plan_outputs(
    render: &Render,
    time_code: Option<f64>,
    flags: &OutputFlags,
) -> Result<OutputPlan, JobError> {
    let Some(first) = render.products.first() else {
        let output = flags.output.ok_or_else(|| {
            let settings = render.settings.as_deref().map_or_else(
                || "the stage has no render settings".to_string(),
                |s| format!("render settings {s} have no raster RenderProduct"),
            );
            JobError::Refused(format!("no -o OUT.exr, and {settings} to name the output"))
        })?;
        return Ok(OutputPlan {
            outputs: vec![ProductOutput {
                path: output.to_path_buf(),
                layers: Layers::Film,
            }],
            aovs: flags.aovs.cloned().unwrap_or_default(),
            data_window_ndc: None,
        });
    };
    let frame = time_code.map_or(1, |t| t.round() as i64);
    let mut outputs = Vec::new();
    let mut aovs = Vec::new();
    // A part's film state (-o PART.film) is the first product's alone.
    let count = match flags.output {
        Some(output) if is_film_output(output) => 1,
        _ => render.products.len(),
    };
    for (i, product) in render.products.iter().enumerate().take(count) {
        if i > 0 && !shares_render(first, product, flags) {
            log::warn!(
                "render product {}: its camera, resolution, pixelAspectRatio or dataWindowNDC differs from {}'s, which is the one rendered; not written (give it its own RenderSettings and render those with --settings)",
                product.path,
                first.path
            );
            continue;
        }
        let aspect = product.pixel_aspect_ratio;
        if !(aspect.is_finite() && aspect > 0.0) {
            return Err(JobError::Refused(format!(
                "render product {}: pixelAspectRatio must be finite and positive, got {aspect}",
                product.path
            )));
        }
        let path = match flags.output {
            Some(output) if i == 0 => output.to_path_buf(),
            _ => product_path(product, frame, flags.sequence)?,
        };
        let layers = match flags.aovs {
            Some(_) => Layers::Film,
            None => Layers::Named(product_layers(product)),
        };
        if let Layers::Named(named) = &layers {
            aovs.extend(named.iter().flat_map(|l| l.aovs().iter().copied()));
        }
        outputs.push(ProductOutput { path, layers });
    }
    let whole = [0.0, 0.0, 1.0, 1.0];
    Ok(OutputPlan {
        outputs,
        aovs: flags
            .aovs
            .cloned()
            .unwrap_or_else(|| aovs.into_iter().collect()),
        data_window_ndc: Some(first.data_window_ndc).filter(|w| *w != whole),
    })
}

/// Whether `product` can be written from the render of `first`.
fn shares_render(first: &RenderProduct, product: &RenderProduct, flags: &OutputFlags) -> bool {
    (flags.resolution || product.resolution == first.resolution)
        && (flags.camera || product.camera == first.camera)
        && product.pixel_aspect_ratio == first.pixel_aspect_ratio
        && product.data_window_ndc == first.data_window_ndc
}

/// `productName` with its frame tokens replaced by `frame`.
fn product_path(product: &RenderProduct, frame: i64, sequence: bool) -> Result<PathBuf, JobError> {
    let pattern = Path::new(&product.name);
    if sequence && !super::frame_range::has_frame_number(pattern) {
        return Err(JobError::Refused(format!(
            "render product {}: productName {} has no frame token ($F4, <F4> or ####) for a sequence",
            product.path, product.name
        )));
    }
    Ok(super::frame_range::frame_output(pattern, Some(frame)))
}

/// The layers of `product`'s vars that we produce; each other var gets one
/// warning naming it and why. A product with none is written as the
/// beauty alone (RGBA), as a product without `orderedVars` is.
fn product_layers(product: &RenderProduct) -> Vec<NamedLayer> {
    let layers: Vec<NamedLayer> = product
        .vars
        .iter()
        .filter_map(|var| {
            let attributes = VarAttributes {
                name: &var.name,
                source_name: &var.source_name,
                source_type: &var.source_type,
                data_type: &var.data_type,
            };
            layer_of(&attributes)
                .map_err(|why| log::warn!("render var {}: {why}; skipped", var.path))
                .ok()
        })
        .collect();
    if !layers.is_empty() {
        return layers;
    }
    vec![NamedLayer {
        name: String::new(),
        source: LayerSource::Beauty,
        pixel_type: PixelType::Float,
    }]
}

/// The pixels of an image of `resolution` whose centres lie in the NDC
/// window `ndc` (`[xmin, ymin, xmax, ymax]`, y up); refused when none do.
fn data_window(ndc: [f32; 4], resolution: UVec2) -> Result<Tile, JobError> {
    let [x0, y0, x1, y1] = ndc;
    let (w, h) = (resolution.x as f32, resolution.y as f32);
    // Pixel i's centre (i + 0.5) / w lies in [a, b) for ceil(a w - 0.5) <= i < ceil(b w - 0.5).
    let edge = |t: f32, size: f32| (t * size - 0.5).ceil().clamp(0.0, size) as u32;
    let (left, right) = (edge(x0, w), edge(x1, w));
    // Rows count from the top: NDC y is 1 - (row + 0.5) / h.
    let (top, bottom) = (edge(1.0 - y1, h), edge(1.0 - y0, h));
    if left >= right || top >= bottom {
        return Err(JobError::Refused(format!(
            "dataWindowNDC {ndc:?} holds no pixel centre of the {}x{} image",
            resolution.x, resolution.y
        )));
    }
    Ok(Tile {
        origin: UVec2::new(left, top),
        size: UVec2::new(right - left, bottom - top),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_windows_take_the_pixels_whose_centres_they_hold() {
        let res = UVec2::new(10, 4);
        let whole = data_window([0.0, 0.0, 1.0, 1.0], res).unwrap();
        assert_eq!((whole.origin, whole.size), (UVec2::ZERO, res));
        // The left half and the top quarter: rows count from the top.
        let w = data_window([0.0, 0.75, 0.5, 1.0], res).unwrap();
        assert_eq!((w.origin, w.size), (UVec2::ZERO, UVec2::new(5, 1)));
        let w = data_window([0.5, 0.0, 1.0, 0.5], res).unwrap();
        assert_eq!((w.origin, w.size), (UVec2::new(5, 2), UVec2::new(5, 2)));
        assert!(data_window([0.3, 0.0, 0.31, 1.0], res).is_err());
    }
}
