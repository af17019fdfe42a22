//! cxx bridge to `shim.cc`: the only way Rust reaches OpenImageIO. Mounted as a
//! private child of `src/output/exr.rs`; nothing else may name it.

#[cxx::bridge(namespace = "cirrus::oiio")]
pub(super) mod ffi {
    /// A named float attribute set (matrix metadata): `values` holds 16 floats, row-major.
    struct MatrixAttribute {
        name: String,
        values: [f32; 16],
    }

    /// A named string attribute.
    struct StringAttribute {
        name: String,
        value: String,
    }

    /// Everything one EXR file needs; pixels are interleaved f32, channel-fastest.
    struct ExrRequest<'a> {
        path: &'a str,
        /// The data window: `width` x `height` pixels whose top-left pixel
        /// is (`x`, `y`) of the display window (x right, y down).
        width: u32,
        height: u32,
        x: u32,
        y: u32,
        /// The display window's size, from (0, 0): the whole image.
        full_width: u32,
        full_height: u32,
        /// A pixel's width over its height (`pixelAspectRatio`).
        pixel_aspect: f32,
        channel_names: Vec<String>,
        /// One per channel: true stores the channel as half, false as float.
        channel_half: Vec<bool>,
        /// OpenEXR compression name as OIIO spells it: "zip", "piz", "dwaa", ...
        compression: &'a str,
        strings: Vec<StringAttribute>,
        matrices: Vec<MatrixAttribute>,
        pixels: &'a [f32],
    }

    /// An image as stored, converted to f32 but not yet linearised.
    struct ImageData {
        width: u32,
        height: u32,
        channels: u32,
        /// Index of the alpha channel, or -1.
        alpha_channel: i32,
        /// True when the file's colour channels hold sRGB-encoded values: OIIO
        /// says "sRGB", or it names no colour space and stores 8-bit integers.
        is_srgb: bool,
        /// Interleaved, row 0 at the top.
        pixels: Vec<f32>,
    }

    /// OpenEXR's three pixel types, as a channel is stored in a file.
    enum ChannelFormat {
        Half,
        Float,
        Uint,
    }

    /// One channel of an EXR as read: its full name and stored type.
    struct ChannelInfo {
        name: String,
        format: ChannelFormat,
    }

    /// An EXR's channels as read: every value widened to f32 by value (uint
    /// channels too, not normalised), interleaved channel-fastest, row 0 at
    /// the top, channels in the order OpenImageIO presents them.
    struct ExrData {
        width: u32,
        height: u32,
        channels: Vec<ChannelInfo>,
        pixels: Vec<f32>,
        /// Every header attribute of string type.
        strings: Vec<StringAttribute>,
    }

    /// A line of text drawn onto an image; (x, y) is its top-left corner in pixels.
    struct TextLabel {
        text: String,
        x: i32,
        y: i32,
    }

    /// An 8-bit sRGB PNG to write from linear display-referred RGB in [0, 1].
    struct DisplayPngRequest<'a> {
        path: &'a str,
        width: u32,
        height: u32,
        /// Interleaved RGB, row 0 at the top.
        pixels: &'a [f32],
        labels: Vec<TextLabel>,
    }

    unsafe extern "C++" {
        include!("cirrus/ffi/oiio/shim.h");

        fn write_exr(request: &ExrRequest) -> Result<()>;
        /// Reads an image as f32; refuses (before allocating) one whose
        /// pixels would take more than `max_bytes` while read.
        fn read_image(path: &str, max_bytes: u64) -> Result<ImageData>;
        fn read_exr(path: &str) -> Result<ExrData>;
        /// Returns whether the labels were drawn (false: no font found).
        fn write_display_png(request: &DisplayPngRequest) -> Result<bool>;
    }
}
