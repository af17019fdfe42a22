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
        width: u32,
        height: u32,
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

    unsafe extern "C++" {
        include!("cirrus/ffi/oiio/shim.h");

        fn write_exr(request: &ExrRequest) -> Result<()>;
        fn read_image(path: &str) -> Result<ImageData>;
    }
}
