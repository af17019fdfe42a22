//! The film: what the integrator's samples become before they are files.
//! Per-pixel sums of radiance and of the chosen AOVs, filled tile by tile and
//! merged in a fixed order (`sums.rs`); the pixel filter that places camera
//! samples (`filter.rs`); the AOVs and what one path sample adds to each
//! (`aov.rs`); adaptive sampling's half buffer and stopping rule
//! (`adaptive.rs`); Cryptomatte ids and coverage ranks (`cryptomatte.rs`); and the
//! film-state file, a film's exact sums with a caller's header, that
//! checkpoints and farm parts are saved in (`state.rs`).

mod adaptive;
mod aov;
mod cryptomatte;
mod filter;
mod state;
mod sums;

pub use adaptive::{ActivePixels, AdaptiveSampling};
pub use aov::{
    primvar_of, Aov, AovSample, AovSet, CameraHit, CryptoIds, ALL as ALL_AOVS, CRYPTOMATTES,
    MAX_PRIMVARS,
};
pub use cryptomatte::{
    layer_key, murmur3_32, name_to_id, CryptoCoverage, CryptoLayer, CryptoNames, Murmur3,
};
pub use filter::{FilterKind, PixelFilter};
pub use state::{read_film_state, write_film_state, FilmStateError, FILM_STATE_VERSION};
pub use sums::{Film, Layer, NonFiniteSamples, PixelSum, Tile, TileFilm};
