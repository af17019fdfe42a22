//! Everything that leaves the renderer as a file: multi-channel EXRs written
//! through OpenImageIO (`ffi/oiio/`), and image reading through the same bridge.

pub mod aov;
pub mod atomic;
pub mod contact_sheet;
pub mod cryptomatte;
mod exr;
pub mod film;
pub mod film_state;
pub mod filter;
mod preview;

pub use exr::{
    read_exr, read_image, write_exr, Channel, ChannelFormat, Compression, ExrChannels, ExrImage,
    Image, ImageError, PixelType, StoredChannel,
};
pub use preview::write_preview;
