//! Everything that leaves the renderer as a file: multi-channel EXRs written
//! through OpenImageIO (`ffi/oiio/`), and image reading through the same bridge.

mod exr;

pub use exr::{
    read_image, write_exr, Channel, Compression, ExrImage, Image, ImageError, PixelType,
};
