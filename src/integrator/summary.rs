//! The log lines a finished render's statistics make: rays per second,
//! media lookups and collisions, and warnings for what may have biased it
//! (majorant violations) or was dropped (NaN/Inf samples).

use super::RenderStats;

impl RenderStats {
    /// Logs how the render went; warns about majorant violations and
    /// dropped NaN/Inf samples.
    pub fn log_summary(&self) {
        let secs = self.elapsed.as_secs_f64();
        let rays = self.rays.closest + self.rays.shadow;
        log::info!(
            "{} spp in {secs:.2} s: {:.2} M rays/s ({} camera, {} closest-hit, {} shadow)",
            self.samples_per_pixel,
            rays as f64 / secs.max(1e-9) / 1e6,
            self.rays.camera,
            self.rays.closest,
            self.rays.shadow,
        );
        let t = &self.tracking;
        if t.density_lookups > 0 {
            let collisions = (t.real_collisions + t.null_collisions).max(1);
            log::info!(
                "volumes: {:.1} density lookups per camera ray; {:.0}% of collisions null",
                t.density_lookups as f64 / self.rays.camera.max(1) as f64,
                100.0 * t.null_collisions as f64 / collisions as f64,
            );
        }
        if t.majorant_violations > 0 {
            log::warn!(
                "{} density lookups exceeded their majorant: delta tracking is biased there",
                t.majorant_violations
            );
        }
        if let Some((pixel, sample)) = self.non_finite.first {
            log::warn!(
                "{} NaN/Inf sample(s) dropped; the first at pixel ({}, {}), sample {sample}",
                self.non_finite.count,
                pixel.x,
                pixel.y
            );
        }
    }
}
