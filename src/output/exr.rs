//! Image files through the OpenImageIO bridge (`ffi/oiio/`): multi-channel EXR
//! writing (named half/float channels, compression, metadata), written
//! atomically, and reading of texture images into linear floats. This is the
//! only module that talks to OpenImageIO.

#[path = "../../ffi/oiio/bridge.rs"]
mod bridge;

use std::path::{Path, PathBuf};

use bridge::ffi;

use crate::scene::ColorSpace;

/// Why an image could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// Writing `path` failed; `message` is OpenImageIO's or the OS's reason.
    #[error("{path}: cannot write EXR: {message}", path = path.display())]
    Write {
        /// The file asked for (not the temporary it is written under).
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// Reading `path` failed (missing, corrupt, not an image).
    #[error("{path}: cannot read image: {message}", path = path.display())]
    Read {
        /// The image file.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

/// How a channel is stored in the file (pixels are always handed over as f32).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelType {
    /// 16-bit float: colour AOVs.
    Half,
    /// 32-bit float: depth, positions, normals, IDs.
    Float,
}

/// OpenEXR compression. Zip is lossless and Nuke's usual default; Piz suits
/// noisy images; Dwaa is lossy and small.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Compression {
    /// Uncompressed.
    None,
    /// Lossless zlib over 16 scanlines (the default).
    #[default]
    Zip,
    /// Lossless wavelet, good on noisy images.
    Piz,
    /// Lossy DCT (DreamWorks), smallest files.
    Dwaa,
}

impl Compression {
    fn oiio_name(self) -> &'static str {
        match self {
            Compression::None => "none",
            Compression::Zip => "zip",
            Compression::Piz => "piz",
            Compression::Dwaa => "dwaa",
        }
    }
}

/// One named channel, e.g. `R`, `diffuse.G`, `N.X`, `Z`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Channel {
    /// Full channel name, layer prefix included (`diffuse.R`).
    pub name: String,
    /// Storage in the file.
    pub pixel_type: PixelType,
}

/// An EXR to write: `pixels` are interleaved f32, channel-fastest, row 0 at the top.
#[derive(Clone, Debug)]
pub struct ExrImage<'a> {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Channel names and storage, in the order of `pixels`' interleaving.
    pub channels: Vec<Channel>,
    /// `width * height * channels.len()` values.
    pub pixels: &'a [f32],
    /// File compression.
    pub compression: Compression,
    /// Header attributes of string type (e.g. `software`).
    pub strings: Vec<(String, String)>,
    /// Header attributes of 4x4 float matrix type (e.g. `worldToCamera`), row-major.
    pub matrices: Vec<(String, [f32; 16])>,
}

/// A decoded image: linear values, interleaved, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Values per pixel.
    pub channels: u32,
    /// `width * height * channels` linear values.
    pub pixels: Vec<f32>,
}

/// Writes `image` to `path` through OpenImageIO. The file appears atomically:
/// it is written under a temporary name in the same folder, then renamed, so a
/// failure never leaves a truncated file under `path`.
pub fn write_exr(path: &Path, image: &ExrImage) -> Result<(), ImageError> {
    let fail = |message: String| ImageError::Write {
        path: path.to_path_buf(),
        message,
    };
    let expected = image.width as usize * image.height as usize * image.channels.len();
    if image.pixels.len() != expected || expected == 0 {
        return Err(fail(format!(
            "{} pixel values for {}x{} pixels with {} channels",
            image.pixels.len(),
            image.width,
            image.height,
            image.channels.len()
        )));
    }
    let temp = temp_path(path);
    let request = ffi::ExrRequest {
        path: &temp.to_string_lossy(),
        width: image.width,
        height: image.height,
        channel_names: image.channels.iter().map(|c| c.name.clone()).collect(),
        channel_half: image
            .channels
            .iter()
            .map(|c| c.pixel_type == PixelType::Half)
            .collect(),
        compression: image.compression.oiio_name(),
        strings: image
            .strings
            .iter()
            .map(|(name, value)| ffi::StringAttribute {
                name: name.clone(),
                value: value.clone(),
            })
            .collect(),
        matrices: image
            .matrices
            .iter()
            .map(|(name, values)| ffi::MatrixAttribute {
                name: name.clone(),
                values: *values,
            })
            .collect(),
        pixels: image.pixels,
    };
    let written = ffi::write_exr(&request)
        .map_err(|e| fail(e.what().to_owned()))
        .and_then(|()| std::fs::rename(&temp, path).map_err(|e| fail(e.to_string())));
    if written.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    written
}

/// Reads an image (png, jpg, tga, exr, ...) into linear f32. `color_space`
/// is `UsdUVTexture`'s `sourceColorSpace`: `Auto` decodes colour channels with
/// the sRGB transfer function when the file says it is sRGB (or is 8-bit and
/// untagged), `Srgb` always decodes them, `Raw` never does (normal maps,
/// roughness). Alpha is never decoded.
pub fn read_image(path: &Path, color_space: ColorSpace) -> Result<Image, ImageError> {
    if let Err(e) = std::fs::metadata(path) {
        return Err(ImageError::Read {
            path: path.to_path_buf(),
            message: e.to_string(),
        });
    }
    let data = ffi::read_image(&path.to_string_lossy()).map_err(|e| ImageError::Read {
        path: path.to_path_buf(),
        message: e.what().to_owned(),
    })?;
    let mut pixels = data.pixels;
    let decode = match color_space {
        ColorSpace::Auto => data.is_srgb,
        ColorSpace::Srgb => true,
        ColorSpace::Raw => false,
    };
    if decode {
        let nc = data.channels as usize;
        for pixel in pixels.chunks_exact_mut(nc) {
            for (c, v) in pixel.iter_mut().enumerate() {
                if c as i32 != data.alpha_channel {
                    *v = srgb_to_linear(*v);
                }
            }
        }
    }
    Ok(Image {
        width: data.width,
        height: data.height,
        channels: data.channels,
        pixels,
    })
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1).
fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// `dir/.name.PID.tmp.exr`: same folder (so rename is atomic), same extension
/// (OpenImageIO picks the writer from it).
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "exr".into());
    path.with_file_name(format!(".{name}.{}.tmp.{ext}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_hits_the_standard_points() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // sRGB 0.5 is 21.4% linear.
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
    }

    #[test]
    fn temp_file_stays_beside_the_target_with_its_extension() {
        let t = temp_path(Path::new("/a/b/beauty.exr"));
        assert_eq!(t.parent(), Some(Path::new("/a/b")));
        assert_eq!(t.extension().unwrap(), "exr");
        assert_ne!(t.file_name().unwrap(), "beauty.exr");
    }
}
