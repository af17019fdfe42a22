//! Cirrus's integration tests: one test crate (`cargo test --release --test it`)
//! with a module per stage or feature, so OpenVDB, OpenImageIO and OpenSubdiv
//! are linked once instead of once per file (as pbrt-v4 builds one `pbrt_test`
//! binary from every `*_test.cpp`). `common/` holds the shared helpers; how to
//! run one test, and what each needs installed, is in `tests/README.md`.

#[macro_use]
mod common;

mod adaptive;
mod aovs;
mod aovs_card;
mod aovs_sheet;
mod bad_input;
mod conformance;
mod converge;
mod cryptomatte;
mod export;
mod exr;
mod farm;
mod fire;
mod fuzz_inputs;
mod gallery;
mod house;
mod instance_primvars;
mod light_controls;
mod linking;
mod looks;
mod materialx;
mod media;
mod motion;
mod motion_curves;
mod motion_lights;
mod outputs;
mod peers;
mod points_curves;
mod primvar_aovs;
mod reliability;
mod render;
mod render_settings;
mod scene;
mod shaping;
mod skinning;
mod stability;
mod subdivision;
mod transmission;
mod usd_letter;
mod usd_render_letter;
mod vdb;
mod volume_motion;
mod volumes;
