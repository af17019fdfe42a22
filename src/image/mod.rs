//! Image files, through the OpenImageIO bridge (`ffi/oiio/`, mounted only by
//! `oiio.rs`): texture images read into linear floats, multi-channel EXRs
//! written (named half/float channels, compression, metadata) and read back,
//! labelled 8-bit PNGs; and atomic writes (`atomic.rs`), so every file Cirrus
//! writes appears whole or not at all. Loading reads textures here; the
//! output stage writes here; neither depends on the other.

mod atomic;
mod oiio;

pub use atomic::{replace_file, write_file};
pub use oiio::{
    read_exr, read_image, srgb_to_linear, write_display_png, write_exr, write_framed_exr, Channel,
    ChannelFormat, Compression, ExrChannels, ExrFrame, ExrImage, Image, ImageError, PixelType,
    StoredChannel, TextLabel,
};
