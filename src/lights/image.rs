//! The image a light's `inputs:texture:file` names (dome and rect lights),
//! held as linear RGB and looked up without filtering: each texel is a
//! constant patch, so a piecewise-constant importance map over the texels
//! is exactly proportional to what the lookup returns.

use std::path::Path;

use glam::{Vec2, Vec3};

use crate::color::luminance;
use crate::scene::ColorSpace;

/// A light's texture: linear Rec.709 RGB texels, row 0 at the top.
#[derive(Clone, Debug)]
pub(crate) struct LightImage {
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` texels, row-major from the top row.
    pub texels: Vec<Vec3>,
}

impl LightImage {
    /// The texel holding `uv`: u in [0, 1) from the left edge, v in [0, 1)
    /// from the top edge (texel (i, j) covers [i/w, (i+1)/w) x [j/h, (j+1)/h)).
    pub fn texel(&self, uv: Vec2) -> Vec3 {
        let x = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        self.texels[y * self.width + x]
    }

    /// Mean luminance of the texels (for a light's power estimate).
    pub fn mean_luminance(&self) -> f32 {
        let sum: f64 = self.texels.iter().map(|&t| f64::from(luminance(t))).sum();
        (sum / self.texels.len() as f64) as f32
    }

    /// Reads `path` through `image::read_image`; one channel is grey, two
    /// are grey and alpha, three or more are RGB(A). Negative and non-finite
    /// texels become 0. `None` (with a warning naming the light) when the file
    /// cannot be read, so the light falls back to its constant emission.
    pub fn load(path: &Path, light: &str) -> Option<Self> {
        let image = match crate::image::read_image(path, ColorSpace::Auto) {
            Ok(image) => image,
            Err(e) => {
                log::warn!("light {light}: texture unusable ({e}); using constant emission");
                return None;
            }
        };
        let channels = image.channels as usize;
        if channels == 0 || image.width == 0 || image.height == 0 {
            log::warn!(
                "light {light}: texture {} is empty; using constant emission",
                path.display()
            );
            return None;
        }
        let clean = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
        let texels = image
            .pixels
            .chunks_exact(channels)
            .map(|p| match channels {
                1 | 2 => Vec3::splat(clean(p[0])),
                _ => Vec3::new(clean(p[0]), clean(p[1]), clean(p[2])),
            })
            .collect();
        Some(Self {
            width: image.width as usize,
            height: image.height as usize,
            texels,
        })
    }
}
