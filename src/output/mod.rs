//! What leaves the renderer for people and compositors: a film's layers as
//! EXRs with the header every render carries (layers named as the
//! film names them, or as a USD render product's `RenderVar`s say), the tone-mapped PNG preview
//! beside each EXR, and the contact sheet of an EXR's layers. Files are
//! written through `image/`.

mod contact_sheet;
mod exr;
mod preview;
mod render_vars;

pub use contact_sheet::{contact_sheet_path, write_contact_sheet, ContactSheet, SheetTile};
pub use exr::{write_beauty, write_bytes_for, write_film, AovFiles, ExrHeader};
pub use preview::{preview_path, write_film_preview, write_preview};
pub use render_vars::{layer_of, LayerSource, Layers, NamedLayer, VarAttributes};
