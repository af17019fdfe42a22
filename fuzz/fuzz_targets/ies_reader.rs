//! Fuzzes `IesProfile::parse`, the LM-63 (IES) reader behind
//! `shaping:ies:file`, on arbitrary text (bytes read as UTF-8, lossy, as
//! `IesProfile::read` does). Parsing must return `Ok` or `Err`, never panic,
//! and an accepted profile must be safe to render with: every candela value
//! looked up finite and >= 0, its mean intensity finite and >= 0, and its
//! last emitting vertical angle within [0, pi].

#![no_main]

use std::f32::consts::PI;

use cirrus::lights::IesProfile;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|input: &[u8]| {
    let Ok(profile) = IesProfile::parse(&String::from_utf8_lossy(input)) else {
        return;
    };
    for i in 0..=18 {
        for j in 0..=24 {
            let (theta, phi) = (i as f32 * PI / 18.0, j as f32 * PI / 6.0 - PI);
            let c = profile.candela(theta, phi);
            assert!(c.is_finite() && c >= 0.0, "candela {c} at ({theta}, {phi})");
        }
    }
    let mean = profile.mean_intensity();
    assert!(mean.is_finite() && mean >= 0.0, "mean {mean}");
    if let Some(t) = profile.max_theta() {
        assert!((0.0..=PI).contains(&t), "max theta {t}");
    }
});
