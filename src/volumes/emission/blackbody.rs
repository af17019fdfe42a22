//! Volume emission from a temperature grid: the blackbody radiance of the
//! gas, scaled by the Volume's `heatScale` (docs/volumes.md, "Authoring a volume: the primvars").
//!
//! Temperature T = temperatureOffset + temperatureScale x grid value, in
//! kelvin. The emitted radiance is heatScale x B(T) / Y(B(1500 K)), where B
//! is Planck's blackbody radiance in linear Rec.709 (CIE 1931 observer) and Y
//! its luminance: so `heatScale` is the luminance, W/(m^2 sr), of gas at
//! 1500 K, and hotter gas is brighter by Planck's law (2000 K about 60x,
//! 2600 K about 1000x, 1000 K about 3000x dimmer), with the blackbody's
//! colour. The RTE's source term is sigma_a x Le: a medium that only
//! scatters (albedo 1) emits nothing.

use glam::Vec3;

use crate::color::{blackbody_radiance, luminance};

/// The temperature at which `heatScale` is the emitted luminance, kelvin.
pub const REFERENCE_TEMPERATURE_K: f32 = 1500.0;

/// Table step, kelvin.
const STEP_K: f32 = 10.0;

/// Highest tabulated temperature, kelvin; hotter reads as this (rare in
/// fire, and it keeps the table small).
const MAX_K: f32 = 12_000.0;

/// Blackbody radiance per kelvin, tabulated once (each value integrates 471
/// wavelengths), relative to the luminance at [`REFERENCE_TEMPERATURE_K`].
pub struct BlackbodyTable {
    table: Vec<Vec3>,
}

impl BlackbodyTable {
    /// Linear Rec.709 radiance at `temperature_k` per unit `heatScale`:
    /// linear between table entries; 0 at or below 0 K.
    pub fn radiance(&self, temperature_k: f32) -> Vec3 {
        let x = (temperature_k.clamp(0.0, MAX_K) / STEP_K).max(0.0);
        let i = (x as usize).min(self.table.len() - 2);
        let f = x - i as f32;
        self.table[i] * (1.0 - f) + self.table[i + 1] * f
    }

    /// Tabulates 0 .. 12,000 K every 10 K.
    pub fn new() -> Self {
        let reference = blackbody_radiance(REFERENCE_TEMPERATURE_K);
        let y = luminance(reference);
        let n = (MAX_K / STEP_K) as usize + 1;
        let table = (0..n)
            .map(|i| blackbody_radiance(i as f32 * STEP_K) / y)
            .collect();
        Self { table }
    }
}

impl Default for BlackbodyTable {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_temperature_has_unit_luminance_and_planck_ratios() {
        let table = BlackbodyTable::new();
        let y = |t: f32| luminance(table.radiance(t));
        assert!((y(REFERENCE_TEMPERATURE_K) - 1.0).abs() < 1e-5);
        // Hotter is brighter and bluer; 0 K is dark.
        assert!(y(2000.0) > 5.0 * y(1500.0) && y(1000.0) < 0.1 * y(1500.0));
        assert_eq!(table.radiance(0.0), Vec3::ZERO);
        assert_eq!(table.radiance(-50.0), Vec3::ZERO);
        let (warm, hot) = (table.radiance(1500.0), table.radiance(6000.0));
        assert!(warm.x / warm.z > hot.x / hot.z);
        // Between entries the table interpolates the exact values closely.
        let exact =
            blackbody_radiance(1234.5) / luminance(blackbody_radiance(REFERENCE_TEMPERATURE_K));
        assert!((table.radiance(1234.5) - exact).abs().max_element() < 0.01 * exact.max_element());
    }
}
