//! Everything that leaves the renderer as a file: multi-channel EXRs written
//! through OpenImageIO (`ffi/oiio/`), and image reading through the same bridge.

mod exr;
pub mod film;
pub mod filter;
mod preview;

pub use exr::{
    read_image, write_exr, Channel, Compression, ExrImage, Image, ImageError, PixelType,
};
pub use preview::write_preview;
