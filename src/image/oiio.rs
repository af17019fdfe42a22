//! Image files through the OpenImageIO bridge (`ffi/oiio/`): multi-channel EXR
//! writing (named half/float channels, compression, metadata), written
//! atomically; reading of texture images into linear floats; reading an EXR's
//! named channels and string metadata back; and labelled 8-bit PNGs for the
//! contact sheet. This is the only module that talks to OpenImageIO.

#[path = "../../ffi/oiio/bridge.rs"]
mod bridge;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use bridge::ffi;

use crate::scene::ColorSpace;

/// Why an image could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// Writing `path` (an EXR, or a PNG) failed; `message` is OpenImageIO's or the OS's reason.
    #[error("{path}: cannot write image: {message}", path = path.display())]
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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

crate::choice::choice!(Compression {
    None => "none",
    Zip => "zip",
    Piz => "piz",
    Dwaa => "dwaa",
});

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

/// Where an EXR's pixels sit in its image (OpenEXR's data and display
/// windows, y down from the top-left corner) and the shape of a pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExrFrame {
    /// The data window's top-left pixel in the image (x right, y down).
    pub origin: [u32; 2],
    /// The display window's width and height in pixels: the whole image.
    pub display: [u32; 2],
    /// `pixelAspectRatio`: a pixel's width over its height.
    pub pixel_aspect: f32,
}

impl ExrFrame {
    /// An image of `width` x `height` square pixels, all of them stored.
    pub fn whole(width: u32, height: u32) -> Self {
        Self {
            origin: [0, 0],
            display: [width, height],
            pixel_aspect: 1.0,
        }
    }
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

/// Writes `image` to `path` through OpenImageIO as the whole image, of
/// square pixels. The file appears atomically: it is written under a
/// temporary name in the same folder, then renamed, so a failure never
/// leaves a truncated file under `path`.
pub fn write_exr(path: &Path, image: &ExrImage) -> Result<(), ImageError> {
    write_framed_exr(path, image, &ExrFrame::whole(image.width, image.height))
}

/// Writes `image` to `path` (atomically, as [`write_exr`]) as the data
/// window of a larger image, `frame` saying where it sits: what Nuke and
/// husk write for a render of a window of the image.
pub fn write_framed_exr(path: &Path, image: &ExrImage, frame: &ExrFrame) -> Result<(), ImageError> {
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
    write_atomically(path, |temp| {
        ffi::write_exr(&ffi::ExrRequest {
            path: temp,
            width: image.width,
            height: image.height,
            x: frame.origin[0],
            y: frame.origin[1],
            full_width: frame.display[0],
            full_height: frame.display[1],
            pixel_aspect: frame.pixel_aspect,
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
        })
    })
}

/// Reads an image (png, jpg, tga, exr, ...) into linear f32. `color_space`
/// is `UsdUVTexture`'s `sourceColorSpace`: `Auto` decodes colour channels with
/// the sRGB transfer function when the file says it is sRGB (or is 8-bit and
/// untagged), `Srgb` always decodes them, `Raw` never does (normal maps,
/// roughness). Alpha is never decoded. An image that would take more than
/// half the memory available is refused before its pixels are allocated.
pub fn read_image(path: &Path, color_space: ColorSpace) -> Result<Image, ImageError> {
    if let Err(e) = std::fs::metadata(path) {
        return Err(ImageError::Read {
            path: path.to_path_buf(),
            message: e.to_string(),
        });
    }
    // Half of what is left: the scene's other textures and data need room too.
    let max_bytes = crate::host::available_bytes().map_or(u64::MAX, |b| b / 2);
    let data =
        ffi::read_image(&path.to_string_lossy(), max_bytes).map_err(|e| ImageError::Read {
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

/// How a channel is stored in an EXR that was read: OpenEXR's three pixel types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelFormat {
    /// 16-bit float.
    Half,
    /// 32-bit float.
    Float,
    /// 32-bit unsigned integer (e.g. another renderer's object IDs).
    Uint,
}

/// One channel of an EXR that was read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StoredChannel {
    /// Full channel name, layer prefix included (`diffuse.R`, `CryptoObject00.A`).
    pub name: String,
    /// Storage in the file.
    pub format: ChannelFormat,
}

/// An EXR's channels as read back by [`read_exr`], for tools and tests that
/// need channel names and metadata (`cirrus aovs`, Cryptomatte checks).
#[derive(Clone, Debug, PartialEq)]
pub struct ExrChannels {
    /// Pixels per row (of the data window).
    pub width: u32,
    /// Rows (of the data window).
    pub height: u32,
    /// Channels in the order OpenImageIO presents them. OpenEXR itself stores
    /// channels sorted by name; OpenImageIO regroups them by layer, with
    /// `R,G,B,A` first inside a layer, so this need not be the written order:
    /// look channels up by name ([`ExrChannels::channel_index`]).
    pub channels: Vec<StoredChannel>,
    /// `width * height * channels.len()` values, interleaved channel-fastest,
    /// row 0 at the top. Half and float values are exact; a uint is widened
    /// by value (not normalised), exact up to 2^24.
    pub pixels: Vec<f32>,
    /// Every string attribute of the header by name (`cryptomatte/<key>/name`,
    /// `cirrus/...`, `compression`, ...).
    pub strings: BTreeMap<String, String>,
}

impl ExrChannels {
    /// Index of the channel called `name` (full name, layer included).
    pub fn channel_index(&self, name: &str) -> Option<usize> {
        self.channels.iter().position(|c| c.name == name)
    }

    /// The values of channel `index`, one per pixel in row order.
    pub fn channel_values(&self, index: usize) -> impl Iterator<Item = f32> + '_ {
        self.pixels
            .iter()
            .skip(index)
            .step_by(self.channels.len())
            .copied()
    }
}

/// Reads every channel of the OpenEXR file at `path` (first part only, flat
/// images only) with its name, stored type and string metadata. A file that
/// is missing, unreadable, deep, or not an EXR is an [`ImageError::Read`]
/// naming it.
pub fn read_exr(path: &Path) -> Result<ExrChannels, ImageError> {
    let fail = |message: String| ImageError::Read {
        path: path.to_path_buf(),
        message,
    };
    std::fs::metadata(path).map_err(|e| fail(e.to_string()))?;
    let data = ffi::read_exr(&path.to_string_lossy()).map_err(|e| fail(e.what().to_owned()))?;
    let channels = data
        .channels
        .into_iter()
        .map(|c| StoredChannel {
            name: c.name,
            format: match c.format {
                ffi::ChannelFormat::Half => ChannelFormat::Half,
                ffi::ChannelFormat::Float => ChannelFormat::Float,
                _ => ChannelFormat::Uint,
            },
        })
        .collect();
    Ok(ExrChannels {
        width: data.width,
        height: data.height,
        channels,
        pixels: data.pixels,
        strings: data
            .strings
            .into_iter()
            .map(|s| (s.name, s.value))
            .collect(),
    })
}

/// A line of text to draw on a PNG, top-left corner at (`x`, `y`) pixels.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TextLabel {
    /// What to draw.
    pub text: String,
    /// Column of the text's left edge.
    pub x: i32,
    /// Row of the text's top edge.
    pub y: i32,
}

/// Writes `rgb` (linear display-referred values in [0, 1], interleaved, row 0
/// at the top) as an 8-bit PNG with the sRGB transfer function applied, and
/// draws `labels` in white when OpenImageIO finds a font. Returns whether the
/// labels were drawn. Atomic like [`write_exr`].
pub fn write_display_png(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
    labels: &[TextLabel],
) -> Result<bool, ImageError> {
    let labels: Vec<ffi::TextLabel> = labels
        .iter()
        .map(|l| ffi::TextLabel {
            text: l.text.clone(),
            x: l.x,
            y: l.y,
        })
        .collect();
    let mut labelled = false;
    write_atomically(path, |temp| {
        labelled = ffi::write_display_png(&ffi::DisplayPngRequest {
            path: temp,
            width,
            height,
            pixels: rgb,
            labels,
        })?;
        Ok(())
    })?;
    Ok(labelled)
}

/// Writes `path` through `write` (an OpenImageIO call given the temporary
/// path) with [`super::replace_file`], reporting failures as
/// [`ImageError::Write`] naming `path`.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&str) -> Result<(), cxx::Exception>,
) -> Result<(), ImageError> {
    super::replace_file(path, |temp| {
        write(&temp.to_string_lossy()).map_err(|e| std::io::Error::other(e.what().to_owned()))
    })
    .map_err(|e| ImageError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
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
}
