//! `UsdUVTexture`: an image read once, looked up with bilinear filtering at
//! USD texture coordinates, then scaled and biased.
//!
//! Conventions (UsdPreviewSurface specification, "UsdUVTexture"):
//! - `st = (0, 0)` is the image's bottom-left corner and `(1, 1)` its top-right,
//!   so `t` runs up while image rows run down: row = (1 - t) * height.
//! - Texel centres sit at half-integers: texel (i, j) is exactly returned at
//!   `s = (i + 0.5) / width`.
//! - Wrap modes act per axis on texel indices (so `repeat` tiles seamlessly
//!   and `clamp` holds the edge texel); `black` reads 0 in every channel
//!   outside the image, before scale and bias; `constant` (MaterialX) reads
//!   `fallback` wherever that axis's coordinate leaves [0, 1], and clamps
//!   the bilinear footprint inside.
//! - The value is `texel * scale + bias`; a missing file yields `fallback`
//!   unchanged (the exporter already warned; we warn once more naming it).

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Mat2, Vec2, Vec3, Vec4};

use crate::image::read_image;
use crate::scene::{self, ColorSpace, StTransform, Wrap};

/// One texture ready for lookups: its texels (or none when the file could
/// not be read) and its `UsdUVTexture` parameters.
#[derive(Clone, Debug)]
pub(crate) struct Texture {
    image: Option<Arc<Texels>>,
    wrap: [Wrap; 2],
    scale: Vec4,
    bias: Vec4,
    fallback: Vec4,
    st_from_uv: Option<StAffine>,
}

/// Linear texel values, row 0 at the top, `channels` interleaved per texel.
#[derive(Clone, Debug)]
pub(crate) struct Texels {
    width: u32,
    height: u32,
    channels: u32,
    values: Vec<f32>,
}

/// A `UsdTransform2d` as an affine map: `st = linear * uv + translation`.
#[derive(Clone, Copy, Debug)]
struct StAffine {
    linear: Mat2,
    translation: Vec2,
}

impl Texture {
    /// The texture's four output channels (r, g, b, a) at texture coordinates
    /// `uv`: `fallback` when the image is missing (or outside [0, 1] on a
    /// `constant` axis), else the bilinearly filtered texel times `scale`
    /// plus `bias`.
    pub(crate) fn eval(&self, uv: Vec2) -> Vec4 {
        let Some(image) = &self.image else {
            return self.fallback;
        };
        let st = match &self.st_from_uv {
            Some(t) => t.linear * uv + t.translation,
            None => uv,
        };
        let outside = |wrap: Wrap, x: f32| wrap == Wrap::Constant && !(0.0..=1.0).contains(&x);
        if outside(self.wrap[0], st.x) || outside(self.wrap[1], st.y) {
            return self.fallback;
        }
        image.bilinear(st, self.wrap) * self.scale + self.bias
    }
}

impl Texture {
    /// A texture without an image: every lookup reads its fallback `value`.
    #[cfg(test)]
    pub(crate) fn constant(value: [f32; 4]) -> Self {
        let record = scene::Texture {
            file: "absent.exr".into(),
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            scale: [1.0; 4],
            bias: [0.0; 4],
            fallback: value,
            color_space: ColorSpace::Raw,
            st_transform: None,
        };
        Self::new(&record, None)
    }

    /// True when `scale` is 1 and `bias` 0 on r, g and b: lookups return the
    /// stored [0, 1] values (a normal map then still needs `2 v - 1`).
    pub(crate) fn keeps_stored_range(&self) -> bool {
        self.scale.truncate() == Vec3::ONE && self.bias.truncate() == Vec3::ZERO
    }
}

impl Texels {
    /// Bilinear interpolation of the four texels around `st`, with texel
    /// centres at half-integers and `t` flipped (row 0 is the top).
    fn bilinear(&self, st: Vec2, wrap: [Wrap; 2]) -> Vec4 {
        let x = st.x * self.width as f32 - 0.5;
        let y = (1.0 - st.y) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        // Each of the two columns and rows is wrapped once, not once per texel.
        let columns = [x0, x0 + 1].map(|i| wrap_index(i, self.width, wrap[0]));
        let rows = [y0, y0 + 1].map(|j| wrap_index(j, self.height, wrap[1]));
        let texel = |i: Option<u32>, j: Option<u32>| -> Vec4 {
            match (i, j) {
                (Some(i), Some(j)) => self.texel(i, j),
                _ => Vec4::ZERO,
            }
        };
        let top = texel(columns[0], rows[0]).lerp(texel(columns[1], rows[0]), fx);
        let bottom = texel(columns[0], rows[1]).lerp(texel(columns[1], rows[1]), fx);
        top.lerp(bottom, fy)
    }

    /// Texel (column `i`, row `j`) as rgba: a one- or two-channel image is
    /// grey (its first channel read as r, g and b); missing alpha reads 1.
    fn texel(&self, i: u32, j: u32) -> Vec4 {
        let nc = self.channels as usize;
        let at = (j as usize * self.width as usize + i as usize) * nc;
        let c = &self.values[at..at + nc];
        match nc {
            1 => Vec4::new(c[0], c[0], c[0], 1.0),
            2 => Vec4::new(c[0], c[0], c[0], c[1]),
            3 => Vec4::new(c[0], c[1], c[2], 1.0),
            _ => Vec4::new(c[0], c[1], c[2], c[3]),
        }
    }
}

/// Texel index `i` on an axis of `n` texels under `wrap`; `None` = black.
/// An index inside the image is itself under every mode, and returned
/// without the modes' divisions (most lookups of an untiled texture).
fn wrap_index(i: i64, n: u32, wrap: Wrap) -> Option<u32> {
    if (0..i64::from(n)).contains(&i) {
        return Some(i as u32);
    }
    let n = i64::from(n);
    let i = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        // A constant axis only gets here inside [0, 1] (see `Texture::eval`).
        Wrap::Clamp | Wrap::Constant => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let k = i.rem_euclid(2 * n);
            if k < n {
                k
            } else {
                2 * n - 1 - k
            }
        }
        Wrap::Black => return None,
    };
    Some(i as u32)
}

impl Texture {
    /// Every texture of a scene, each image file read once per colour space
    /// however many `UsdUVTexture`s name it (one file often feeds several
    /// inputs: roughness from r, metallic from g).
    pub(crate) fn load_all(records: &[scene::Texture]) -> Vec<Self> {
        let mut images: HashMap<(&Path, u8), Option<Arc<Texels>>> = HashMap::new();
        records
            .iter()
            .map(|record| {
                let image = images
                    .entry((record.file.as_path(), record.color_space as u8))
                    .or_insert_with(|| Texels::read(&record.file, record.color_space).map(Arc::new))
                    .clone();
                Self::new(record, image)
            })
            .collect()
    }

    /// `record`'s parameters over `image` (`None`: the file is unusable).
    pub(crate) fn new(record: &scene::Texture, image: Option<Arc<Texels>>) -> Self {
        Self {
            image,
            wrap: [record.wrap_s, record.wrap_t],
            scale: Vec4::from(record.scale),
            bias: Vec4::from(record.bias),
            fallback: Vec4::from(record.fallback),
            st_from_uv: record.st_transform.as_ref().map(StAffine::from_record),
        }
    }
}

impl Texels {
    /// The image at `path`, decoded as `color_space` says. A missing or
    /// unreadable file is not an error: one warning names it, and its
    /// textures return their fallback. An empty path (no `inputs:file`
    /// authored; the exporter already warned) reads nothing, silently.
    fn read(path: &Path, color_space: ColorSpace) -> Option<Self> {
        if path.as_os_str().is_empty() {
            return None;
        }
        match read_image(path, color_space) {
            Ok(image) if image.width > 0 && image.height > 0 && image.channels > 0 => Some(Self {
                width: image.width,
                height: image.height,
                channels: image.channels,
                values: image.pixels,
            }),
            Ok(_) => {
                log::warn!(
                    "texture {}: empty image, using its fallback value",
                    path.display()
                );
                None
            }
            Err(e) => {
                log::warn!("texture {e}; using its fallback value");
                None
            }
        }
    }
}

impl StAffine {
    /// `UsdTransform2d`: scale, then rotate counter-clockwise by
    /// `rotation_deg`, then translate.
    fn from_record(t: &StTransform) -> Self {
        Self {
            linear: Mat2::from_angle(t.rotation_deg.to_radians())
                * Mat2::from_diagonal(Vec2::from(t.scale)),
            translation: Vec2::from(t.translation),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;
    use crate::image::{write_exr, Channel as ExrChannel, Compression, ExrImage, PixelType};

    const W: u32 = 4;
    const H: u32 = 2;

    /// Texel (column i, row j from the top): r = 1 + i + 10 j, g = 2 r, b = -r.
    fn texel_r(i: u32, j: u32) -> f32 {
        1.0 + i as f32 + 10.0 * j as f32
    }

    /// A 4x2 float RGB EXR in a folder unique to this process and test.
    fn write_image(test: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("cirrus-texture-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut pixels = Vec::new();
        for j in 0..H {
            for i in 0..W {
                let r = texel_r(i, j);
                pixels.extend([r, 2.0 * r, -r]);
            }
        }
        let channels = ["R", "G", "B"]
            .map(|name| ExrChannel {
                name: name.into(),
                pixel_type: PixelType::Float,
            })
            .to_vec();
        let path = dir.join("ramp.exr");
        let image = ExrImage {
            width: W,
            height: H,
            channels,
            pixels: &pixels,
            compression: Compression::None,
            strings: Vec::new(),
            matrices: Vec::new(),
        };
        write_exr(&path, &image).unwrap();
        path
    }

    fn record(file: PathBuf, wrap: Wrap) -> scene::Texture {
        scene::Texture {
            file,
            wrap_s: wrap,
            wrap_t: wrap,
            scale: [1.0; 4],
            bias: [0.0; 4],
            fallback: [0.1, 0.2, 0.3, 0.4],
            color_space: ColorSpace::Auto,
            st_transform: None,
        }
    }

    /// The texture coordinates of texel (i, j)'s centre; `j` counts rows from the top.
    fn centre(i: f32, j: f32) -> Vec2 {
        Vec2::new((i + 0.5) / W as f32, 1.0 - (j + 0.5) / H as f32)
    }

    fn load(record: &scene::Texture) -> Texture {
        Texture::load_all(std::slice::from_ref(record)).remove(0)
    }

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-5
    }

    #[test]
    fn texel_centres_are_exact_and_t_runs_up() {
        let tex = load(&record(write_image("centres"), Wrap::Clamp));
        for j in 0..H {
            for i in 0..W {
                let v = tex.eval(centre(i as f32, j as f32));
                let r = texel_r(i, j);
                assert!(
                    close(v.x, r) && close(v.y, 2.0 * r) && close(v.z, -r),
                    "{i} {j}: {v}"
                );
                assert!(close(v.w, 1.0), "a missing alpha reads 1");
            }
        }
        // t = 0 is the bottom row (row 1 of the file).
        assert!(close(
            tex.eval(Vec2::new(0.5 / W as f32, 0.0)).x,
            texel_r(0, 1)
        ));
    }

    #[test]
    fn bilinear_weights_follow_the_distance_to_texel_centres() {
        let tex = load(&record(write_image("bilinear"), Wrap::Clamp));
        // A quarter of the way from texel (1, 0) to (2, 1) on both axes.
        let v = tex.eval(centre(1.25, 0.25)).x;
        let expected = 0.75 * 0.75 * texel_r(1, 0)
            + 0.25 * 0.75 * texel_r(2, 0)
            + 0.75 * 0.25 * texel_r(1, 1)
            + 0.25 * 0.25 * texel_r(2, 1);
        assert!(close(v, expected), "{v} vs {expected}");
    }

    #[test]
    fn wrap_modes_pick_the_texels_outside_the_image() {
        let file = write_image("wrap");
        // Two texels left of column 0 (row 0), and a quarter texel left of it.
        let two_left = centre(-2.0, 0.0);
        let quarter_left = centre(-0.25, 0.0);
        let r = |i| texel_r(i, 0);
        for (wrap, at_two, at_quarter) in [
            (Wrap::Repeat, r(W - 2), 0.25 * r(W - 1) + 0.75 * r(0)),
            (Wrap::Clamp, r(0), r(0)),
            (Wrap::Mirror, r(1), r(0)),
            (Wrap::Black, 0.0, 0.75 * r(0)),
        ] {
            let tex = load(&record(file.clone(), wrap));
            assert!(close(tex.eval(two_left).x, at_two), "{wrap:?}");
            assert!(close(tex.eval(quarter_left).x, at_quarter), "{wrap:?}");
        }
        // Constant: the fallback anywhere outside [0, 1], clamped inside.
        let tex = load(&record(file.clone(), Wrap::Constant));
        assert_eq!(tex.eval(two_left), Vec4::new(0.1, 0.2, 0.3, 0.4));
        assert_eq!(
            tex.eval(Vec2::new(0.5, 1.01)),
            Vec4::new(0.1, 0.2, 0.3, 0.4)
        );
        assert!(close(tex.eval(Vec2::new(0.0, centre(0.0, 0.0).y)).x, r(0)));
        // Wrap modes are per axis: black along t only.
        let mut rec = record(file, Wrap::Repeat);
        rec.wrap_t = Wrap::Black;
        let tex = load(&rec);
        assert_eq!(tex.eval(centre(1.0, -1.0)), Vec4::ZERO);
        assert!(close(tex.eval(centre(1.0 + W as f32, 0.0)).x, r(1)));
    }

    #[test]
    fn st_transform_scale_and_bias_apply_in_usd_order() {
        let file = write_image("transform");
        let plain = load(&record(file.clone(), Wrap::Repeat));
        let mut rec = record(file, Wrap::Repeat);
        rec.st_transform = Some(StTransform {
            translation: [0.25, 0.5],
            rotation_deg: 90.0,
            scale: [2.0, 0.5],
        });
        rec.scale = [2.0, 2.0, 2.0, 1.0];
        rec.bias = [-1.0, 0.0, 0.0, 0.5];
        let tex = load(&rec);
        let uv = Vec2::new(0.1, 0.3);
        // Scale (0.2, 0.15), rotate 90 deg counter-clockwise (-0.15, 0.2),
        // translate (0.1, 0.7).
        let st = Vec2::new(0.1, 0.7);
        let expected =
            plain.eval(st) * Vec4::new(2.0, 2.0, 2.0, 1.0) + Vec4::new(-1.0, 0.0, 0.0, 0.5);
        assert!(
            (tex.eval(uv) - expected).abs().max_element() < 1e-4,
            "{} vs {expected}",
            tex.eval(uv)
        );
    }

    #[test]
    fn a_file_named_twice_is_read_once() {
        let file = write_image("shared");
        let textures = Texture::load_all(&[
            record(file.clone(), Wrap::Repeat),
            record(file, Wrap::Clamp),
        ]);
        let (a, b) = (&textures[0].image, &textures[1].image);
        assert!(Arc::ptr_eq(a.as_ref().unwrap(), b.as_ref().unwrap()));
        assert_eq!(textures[1].wrap, [Wrap::Clamp; 2]);
    }

    #[test]
    fn a_missing_file_reads_the_fallback() {
        let missing =
            std::env::temp_dir().join(format!("cirrus-missing-{}.png", std::process::id()));
        let mut rec = record(missing, Wrap::Repeat);
        rec.scale = [2.0; 4];
        let tex = load(&rec);
        assert_eq!(tex.eval(Vec2::new(0.3, 0.8)), Vec4::new(0.1, 0.2, 0.3, 0.4));
        assert_eq!(tex.eval(Vec2::ZERO).z, 0.3);
    }
}
