//! Contact sheet: every layer of an EXR tiled into one PNG, so the AOVs of a
//! render can be checked at a glance (`cirrus aovs`).
//!
//! Channels are grouped into layers by the prefix before their last `.`
//! (`diffuse_direct.R` is layer `diffuse_direct`, component `R`). Channels
//! without a dot are the base layer when they are `R`, `G`, `B` or `A`
//! (drawn as tile `RGB` and tile `A`); any other (`Z`) is a layer of its own.
//! The rank layers of one Cryptomatte (`CryptoObject00`, `CryptoObject01`, ...,
//! named by the `cryptomatte/<key>/name` header attribute, Cryptomatte v1.1)
//! share one tile. Each layer is drawn by what it holds:
//! - `R,G,B`: linear radiance through the preview's tone map (Khronos PBR
//!   Neutral, then sRGB), as the beauty PNG; a layer's own `A` is not drawn;
//! - `N.X/Y/Z`: the unit normal as 0.5 + 0.5 n;
//! - the base `A`: coverage as grey;
//! - Cryptomatte: per rank, a colour hashed from the id's bits weighted by
//!   the rank's coverage, summed over every rank;
//! - anything else (`P`, `Z`, `sample_count.Y`): up to three channels as
//!   R, G, B (one channel as grey), each scaled from its finite min..max to
//!   0..1 (a constant channel is mid grey, NaN black, +inf white).
//!
//! Layout: tiles keep the image's aspect ratio with the longer edge
//! `TILE_EDGE` = 256 pixels, 4 per row in the order above (layers in the order
//! of their first channel), with 2-pixel dark separators around and between
//! them: a sheet is `4 * tile_w + 5 * 2` wide (fewer columns when there are
//! fewer tiles) and `rows * tile_h + (rows + 1) * 2` high.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::preview::pbr_neutral;
use crate::image::{
    srgb_to_linear, write_display_png, ChannelFormat, ExrChannels, ImageError, StoredChannel,
    TextLabel,
};

/// Most tiles per row.
const COLUMNS: usize = 4;
/// Longer edge of every tile, pixels (the image is scaled up or down to it).
const TILE_EDGE: u32 = 256;
/// Width of the separators around and between tiles, pixels.
const SEPARATOR: u32 = 2;
/// Separators and empty cells: a dark grey, as a linear display value.
const BACKGROUND: f32 = 0.02;
/// Offset of a label from its tile's top-left corner, pixels.
const LABEL_INSET: i32 = 4;
/// Unlayered channels that form the base layer.
const BASE_COMPONENTS: [&str; 4] = ["R", "G", "B", "A"];

/// One tile of a written contact sheet.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SheetTile {
    /// Layer name as labelled: `RGB` and `A` for the base layer, the prefix
    /// otherwise (`diffuse_direct`, `Z`), the Cryptomatte's name for its ranks.
    pub layer: String,
    /// The channels it shows (indices into [`ExrChannels::channels`]).
    pub channels: Vec<usize>,
    /// Row of the grid, from the top.
    pub row: u32,
    /// Column of the grid, from the left.
    pub column: u32,
}

/// What [`write_contact_sheet`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ContactSheet {
    /// Sheet width in pixels.
    pub width: u32,
    /// Sheet height in pixels.
    pub height: u32,
    /// Every tile, in reading order (row by row).
    pub tiles: Vec<SheetTile>,
    /// Whether each tile carries its layer name: false when OpenImageIO
    /// found no font, and the caller should list the tile order instead.
    pub labelled: bool,
}

/// Draws every layer of `exr` as a tile (see the module doc) and writes the
/// sheet to `path` as an 8-bit sRGB PNG, labelled with layer names when a font
/// is available. The file appears atomically.
pub fn write_contact_sheet(exr: &ExrChannels, path: &Path) -> Result<ContactSheet, ImageError> {
    let layers = layers(exr);
    let (tile_w, tile_h) = tile_size(exr.width, exr.height);
    let columns = layers.len().min(COLUMNS) as u32;
    let rows = layers.len().div_ceil(COLUMNS) as u32;
    let width = columns * tile_w + (columns + 1) * SEPARATOR;
    let height = rows * tile_h + (rows + 1) * SEPARATOR;

    let tiles: Vec<Vec<[f32; 3]>> = layers
        .par_iter()
        .map(|layer| draw_tile(&layer.view, exr, tile_w, tile_h))
        .collect();
    let mut rgb = vec![BACKGROUND; width as usize * height as usize * 3];
    let mut sheet_tiles = Vec::with_capacity(layers.len());
    let mut labels = Vec::with_capacity(layers.len());
    for (i, (layer, tile)) in layers.into_iter().zip(&tiles).enumerate() {
        let (row, column) = ((i / COLUMNS) as u32, (i % COLUMNS) as u32);
        let x0 = SEPARATOR + column * (tile_w + SEPARATOR);
        let y0 = SEPARATOR + row * (tile_h + SEPARATOR);
        for (ty, tile_row) in tile.chunks_exact(tile_w as usize).enumerate() {
            let start = ((y0 as usize + ty) * width as usize + x0 as usize) * 3;
            rgb[start..start + tile_row.len() * 3].copy_from_slice(tile_row.as_flattened());
        }
        labels.push(TextLabel {
            text: layer.name.clone(),
            x: x0 as i32 + LABEL_INSET,
            y: y0 as i32 + LABEL_INSET,
        });
        sheet_tiles.push(SheetTile {
            layer: layer.name,
            channels: layer.channels,
            row,
            column,
        });
    }
    let labelled = write_display_png(path, width, height, &rgb, &labels)?;
    Ok(ContactSheet {
        width,
        height,
        tiles: sheet_tiles,
        labelled,
    })
}

/// How one layer is drawn; every index is into [`ExrChannels::channels`].
#[derive(Clone, Debug, PartialEq)]
enum View {
    /// Linear R, G, B through the preview's tone map.
    Colour([usize; 3]),
    /// A unit normal's X, Y, Z as 0.5 + 0.5 n.
    Normal([usize; 3]),
    /// Coverage as grey, clamped to [0, 1].
    Alpha(usize),
    /// One to three channels as R, G, B (one: grey), each scaled from its
    /// finite min..max to 0..1.
    Normalised(Vec<usize>),
    /// Cryptomatte ranks as (id channel, coverage channel) pairs.
    Cryptomatte(Vec<[usize; 2]>),
}

/// A tile to draw: its label, the channels it shows, and how.
#[derive(Clone, Debug, PartialEq)]
struct Layer {
    name: String,
    channels: Vec<usize>,
    view: View,
}

/// Linear display RGB of a tile, `tile_w * tile_h` pixels in row order: each
/// tile pixel is the mean of the image pixels it covers (at least one), so
/// thumbnails are box-filtered down and pixel-replicated up.
fn draw_tile(view: &View, exr: &ExrChannels, tile_w: u32, tile_h: u32) -> Vec<[f32; 3]> {
    let ranges = match view {
        View::Normalised(channels) => channels.iter().map(|&c| finite_range(exr, c)).collect(),
        _ => Vec::new(),
    };
    let span = |t: u32, tile: u32, image: u32| {
        let begin = (t as u64 * image as u64 / tile as u64) as usize;
        let end = ((t as u64 + 1) * image as u64 / tile as u64) as usize;
        begin..end.max(begin + 1)
    };
    let mut out = Vec::with_capacity(tile_w as usize * tile_h as usize);
    for ty in 0..tile_h {
        let ys = span(ty, tile_h, exr.height);
        for tx in 0..tile_w {
            let xs = span(tx, tile_w, exr.width);
            let mut sum = [0.0f32; 3];
            for y in ys.clone() {
                for x in xs.clone() {
                    let c = shade(view, &ranges, exr, y * exr.width as usize + x);
                    sum = [sum[0] + c[0], sum[1] + c[1], sum[2] + c[2]];
                }
            }
            let n = (ys.len() * xs.len()) as f32;
            out.push(sum.map(|s| s / n));
        }
    }
    out
}

/// Linear display RGB of image pixel `pixel` as `view` draws it; `ranges`
/// holds the finite (min, max) of each channel of a `Normalised` view.
fn shade(view: &View, ranges: &[(f32, f32)], exr: &ExrChannels, pixel: usize) -> [f32; 3] {
    let nc = exr.channels.len();
    let px = &exr.pixels[pixel * nc..(pixel + 1) * nc];
    match view {
        View::Colour(rgb) => pbr_neutral(rgb.map(|c| px[c])),
        View::Normal(xyz) => xyz.map(|c| display(0.5 + 0.5 * px[c])),
        View::Alpha(a) => [display(px[*a]); 3],
        View::Normalised(channels) => {
            let mut out = [0.0; 3];
            for (k, (&c, &(lo, hi))) in channels.iter().zip(ranges).enumerate() {
                out[k] = display(if hi > lo {
                    (px[c] - lo) / (hi - lo)
                } else {
                    0.5
                });
            }
            if channels.len() == 1 {
                out = [out[0]; 3];
            }
            out
        }
        View::Cryptomatte(ranks) => ranks.iter().fold([0.0; 3], |sum, &[id, coverage]| {
            let colour = id_colour(px[id]);
            let w = px[coverage];
            [
                sum[0] + w * colour[0],
                sum[1] + w * colour[1],
                sum[2] + w * colour[2],
            ]
        }),
    }
}

/// A display value in [0, 1] (NaN reads as 0, so +inf is 1 and -inf 0) as the
/// linear value that the sRGB encoding of the sheet turns back into it.
fn display(v: f32) -> f32 {
    srgb_to_linear(if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) })
}

/// A colour for a Cryptomatte id (a float whose bits are a MurmurHash3 of a
/// name): MurmurHash3's 32-bit finaliser spreads the bits once more so
/// neighbouring ids get unrelated colours; bytes 0, 1, 2 are sRGB R, G, B.
fn id_colour(id: f32) -> [f32; 3] {
    let mut h = id.to_bits();
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^= h >> 16;
    [h, h >> 8, h >> 16].map(|b| srgb_to_linear((b & 0xff) as f32 / 255.0))
}

/// The smallest and largest finite value of channel `c`; (0, 0) when it has none.
fn finite_range(exr: &ExrChannels, c: usize) -> (f32, f32) {
    let (lo, hi) = exr
        .channel_values(c)
        .filter(|v| v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo <= hi {
        (lo, hi)
    } else {
        (0.0, 0.0)
    }
}

/// Tile size for a `width` x `height` image: same aspect, longer edge `TILE_EDGE`.
fn tile_size(width: u32, height: u32) -> (u32, u32) {
    let scale = TILE_EDGE as f64 / width.max(height) as f64;
    let edge = |n: u32| ((n as f64 * scale).round() as u32).max(1);
    (edge(width), edge(height))
}

/// The tiles of `exr`, grouped and ordered as the module doc says.
fn layers(exr: &ExrChannels) -> Vec<Layer> {
    // (layer name, [(component, channel index)]) in order of first channel.
    let mut groups: Vec<(&str, Vec<(&str, usize)>)> = Vec::new();
    for (i, channel) in exr.channels.iter().enumerate() {
        let name = channel.name.as_str();
        let (layer, component) = match name.rsplit_once('.') {
            Some(split) => split,
            None if BASE_COMPONENTS.contains(&name) => ("", name),
            None => (name, ""),
        };
        match groups.iter_mut().find(|(l, _)| *l == layer) {
            Some((_, components)) => components.push((component, i)),
            None => groups.push((layer, vec![(component, i)])),
        }
    }
    let cryptomattes: Vec<&str> = exr
        .strings
        .iter()
        .filter(|(key, _)| key.starts_with("cryptomatte/") && key.ends_with("/name"))
        .map(|(_, value)| value.as_str())
        .collect();

    let mut layers: Vec<Layer> = Vec::new();
    for (name, components) in groups {
        let find = |c: &str| components.iter().find(|(n, _)| *n == c).map(|&(_, i)| i);
        if let (Some(base), [Some(r), Some(g), Some(b), Some(a)]) = (
            cryptomatte_of(name, &cryptomattes),
            BASE_COMPONENTS.map(find),
        ) {
            let ranks = [[r, g], [b, a]];
            match layers.iter_mut().find(|l| l.name == base) {
                Some(Layer {
                    channels,
                    view: View::Cryptomatte(existing),
                    ..
                }) => {
                    channels.extend([r, g, b, a]);
                    existing.extend(ranks);
                }
                _ => layers.push(Layer {
                    name: base.to_owned(),
                    channels: vec![r, g, b, a],
                    view: View::Cryptomatte(ranks.to_vec()),
                }),
            }
            continue;
        }
        let is_base = name.is_empty();
        let shown: Vec<usize> = components
            .iter()
            .filter(|(c, _)| !(is_base && *c == "A"))
            .map(|&(_, i)| i)
            .collect();
        let rgb = [find("R"), find("G"), find("B")];
        let xyz = [find("X"), find("Y"), find("Z")];
        let view = match (rgb, xyz) {
            ([Some(r), Some(g), Some(b)], _) => Some(View::Colour([r, g, b])),
            (_, [Some(x), Some(y), Some(z)]) if name == "N" => Some(View::Normal([x, y, z])),
            (_, [Some(x), Some(y), Some(z)]) => Some(View::Normalised(vec![x, y, z])),
            _ if shown.is_empty() => None,
            _ => Some(View::Normalised(shown.iter().take(3).copied().collect())),
        };
        if let Some(view) = view {
            layers.push(Layer {
                name: if is_base { "RGB".into() } else { name.into() },
                channels: if is_base {
                    shown
                } else {
                    components.iter().map(|&(_, i)| i).collect()
                },
                view,
            });
        }
        if let Some(a) = find("A").filter(|_| is_base) {
            layers.push(Layer {
                name: "A".into(),
                channels: vec![a],
                view: View::Alpha(a),
            });
        }
    }
    layers
}

/// The Cryptomatte whose rank layer `layer` is: its name followed by two
/// digits, the name being one of `cryptomattes`.
fn cryptomatte_of<'a>(layer: &str, cryptomattes: &[&'a str]) -> Option<&'a str> {
    let (base, rank) = layer.split_at_checked(layer.len().checked_sub(2)?)?;
    let is_rank = rank.bytes().all(|b| b.is_ascii_digit());
    cryptomattes.iter().copied().find(|&c| is_rank && c == base)
}

/// The contact sheet written beside the EXR `exr` by default: `NAME.aovs.png`
/// for `NAME.exr`.
pub fn contact_sheet_path(exr: &Path) -> PathBuf {
    exr.with_extension("aovs.png")
}

impl ContactSheet {
    /// The listing of this sheet of the EXR `exr` read from `path`: the
    /// file's size and channel count, then per tile its grid position, layer
    /// name, and channels with their stored type (once when they all share it).
    pub fn table(&self, path: &Path, exr: &ExrChannels) -> String {
        let mut out = format!(
            "{}: {}x{}, {} channels, {} layers\n",
            path.display(),
            exr.width,
            exr.height,
            exr.channels.len(),
            self.tiles.len()
        );
        out += &format!("  {:<4}{:<7}{:<20}channels\n", "row", "column", "layer");
        for tile in &self.tiles {
            let channels: Vec<&StoredChannel> =
                tile.channels.iter().map(|&c| &exr.channels[c]).collect();
            let shared = channels.iter().all(|c| c.format == channels[0].format);
            let listed: Vec<String> = if shared {
                let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
                vec![format!(
                    "{} ({})",
                    names.join(" "),
                    format_name(channels[0].format)
                )]
            } else {
                channels
                    .iter()
                    .map(|c| format!("{} ({})", c.name, format_name(c.format)))
                    .collect()
            };
            out += &format!(
                "  {:<4}{:<7}{:<20}{}\n",
                tile.row,
                tile.column,
                tile.layer,
                listed.join(" ")
            );
        }
        out
    }
}

/// How OpenEXR names a pixel type.
fn format_name(format: ChannelFormat) -> &'static str {
    match format {
        ChannelFormat::Half => "half",
        ChannelFormat::Float => "float",
        ChannelFormat::Uint => "uint",
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;

    #[test]
    fn sheet_goes_beside_the_exr() {
        assert_eq!(
            contact_sheet_path(Path::new("/renders/shot.0101.exr")),
            Path::new("/renders/shot.0101.aovs.png")
        );
    }

    /// A 2x1 image with these channels, all zero, and these string attributes.
    fn image(names: &[&str], strings: &[(&str, &str)]) -> ExrChannels {
        ExrChannels {
            width: 2,
            height: 1,
            channels: names
                .iter()
                .map(|n| StoredChannel {
                    name: (*n).into(),
                    format: ChannelFormat::Half,
                })
                .collect(),
            pixels: vec![0.0; 2 * names.len()],
            strings: strings
                .iter()
                .map(|&(k, v)| (k.to_owned(), v.to_owned()))
                .collect::<BTreeMap<_, _>>(),
        }
    }

    #[test]
    fn channels_group_into_layers_by_prefix() {
        let names = [
            "R",
            "G",
            "B",
            "A",
            "N.X",
            "N.Y",
            "N.Z",
            "P.X",
            "P.Y",
            "P.Z",
            "Z",
            "diffuse_direct.R",
            "diffuse_direct.G",
            "diffuse_direct.B",
            "sample_count.Y",
            "CryptoObject00.R",
            "CryptoObject00.G",
            "CryptoObject00.B",
            "CryptoObject00.A",
            "CryptoObject01.R",
            "CryptoObject01.G",
            "CryptoObject01.B",
            "CryptoObject01.A",
        ];
        let exr = image(&names, &[("cryptomatte/f834d0a/name", "CryptoObject")]);
        let got: Vec<(String, View)> = layers(&exr).into_iter().map(|l| (l.name, l.view)).collect();
        let want = vec![
            ("RGB".to_owned(), View::Colour([0, 1, 2])),
            ("A".to_owned(), View::Alpha(3)),
            ("N".to_owned(), View::Normal([4, 5, 6])),
            ("P".to_owned(), View::Normalised(vec![7, 8, 9])),
            ("Z".to_owned(), View::Normalised(vec![10])),
            ("diffuse_direct".to_owned(), View::Colour([11, 12, 13])),
            ("sample_count".to_owned(), View::Normalised(vec![14])),
            (
                "CryptoObject".to_owned(),
                View::Cryptomatte(vec![[15, 16], [17, 18], [19, 20], [21, 22]]),
            ),
        ];
        assert_eq!(got, want);
    }

    #[test]
    fn rank_layers_need_their_cryptomatte_named_in_the_header() {
        let names = [
            "CryptoObject00.R",
            "CryptoObject00.G",
            "CryptoObject00.B",
            "CryptoObject00.A",
        ];
        let got = layers(&image(&names, &[]));
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].name, "CryptoObject00");
        assert_eq!(got[0].view, View::Colour([0, 1, 2]));
        assert_eq!(cryptomatte_of("CryptoObject0x", &["CryptoObject"]), None);
        assert_eq!(cryptomatte_of("0", &["CryptoObject"]), None);
        assert_eq!(
            cryptomatte_of("CryptoAsset07", &["CryptoAsset"]),
            Some("CryptoAsset")
        );
    }

    #[test]
    fn normalised_values_span_the_finite_range() {
        let mut exr = image(&["Z"], &[]);
        exr.width = 4;
        exr.pixels = vec![2.0, 4.0, f32::INFINITY, f32::NAN];
        let range = finite_range(&exr, 0);
        assert_eq!(range, (2.0, 4.0));
        let view = View::Normalised(vec![0]);
        let shaded: Vec<f32> = (0..4).map(|p| shade(&view, &[range], &exr, p)[0]).collect();
        assert_eq!(shaded, vec![0.0, 1.0, 1.0, 0.0]);
        // A constant channel is mid grey (0.5 after encoding).
        let flat = shade(&view, &[(3.0, 3.0)], &exr, 0)[0];
        assert!((flat - srgb_to_linear(0.5)).abs() < 1e-6);
    }

    #[test]
    fn cryptomatte_colour_is_weighted_by_coverage() {
        let mut exr = image(&["R", "G", "B", "A"], &[]);
        exr.width = 1;
        exr.pixels = vec![1.5e-3, 0.25, -7.0e8, 0.75];
        let view = View::Cryptomatte(vec![[0, 1], [2, 3]]);
        let got = shade(&view, &[], &exr, 0);
        let (a, b) = (id_colour(1.5e-3), id_colour(-7.0e8));
        for k in 0..3 {
            assert!((got[k] - (0.25 * a[k] + 0.75 * b[k])).abs() < 1e-6);
        }
        assert_ne!(a, b, "different ids should get different colours");
    }

    #[test]
    fn tiles_keep_the_aspect_ratio() {
        assert_eq!(tile_size(1920, 1080), (256, 144));
        assert_eq!(tile_size(32, 16), (256, 128));
        assert_eq!(tile_size(1, 5000), (1, 256));
    }
}
