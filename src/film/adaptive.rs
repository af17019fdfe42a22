//! Adaptive sampling (`--noise-threshold`): which pixels keep sampling.
//!
//! Every pixel's samples are also summed in a second buffer that keeps only
//! the odd sample indices (a half buffer). At a pass boundary the relative
//! error of a pixel is the difference between the mean of all its samples
//! `I` and the mean of the odd half `A`, normalised by the pixel's
//! brightness (Dammertz et al. 2010, "A hierarchical automatic stopping
//! condition for Monte Carlo global illumination", §2.1; Cycles'
//! normalisation in `film_adaptive_sampling_convergence_check`):
//!
//! `error = (|I_r - A_r| + |I_g - A_g| + |I_b - A_b|) / (1e-4 + s)`, with
//! `s = sqrt(I_r + I_g + I_b)` below 1 and `I_r + I_g + I_b` above, so
//! highlights need less relative precision than mid-tones.
//!
//! A pixel whose error is under the threshold stops; once stopped it stays
//! stopped, except that the 3 x 3 neighbours of every pixel still sampling
//! keep sampling too (Cycles' `filter_x`/`filter_y` dilation: a lone noisy
//! pixel does not leave a hard-edged patch behind). Stopping a pixel on its
//! own noise estimate is a small bias (docs/rendering.md), which is why the
//! feature is opt-in.

use glam::UVec2;

/// The `--noise-threshold` and `--min-spp` of an adaptive render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSampling {
    /// Relative error under which a pixel stops (positive, finite).
    pub threshold: f32,
    /// Samples every pixel takes before its error is first checked (at least 2).
    pub min_samples: u32,
}

impl AdaptiveSampling {
    /// `threshold` with `min_samples`, or Cycles' automatic minimum when
    /// `None`: `max(4, ceil(16 / threshold^0.3))` (0.1 -> 32, 0.01 -> 64,
    /// 0.001 -> 128 samples; Cycles' `Integrator::get_adaptive_sampling`).
    pub fn new(threshold: f32, min_samples: Option<u32>) -> Self {
        let auto = || ((16.0 / threshold.powf(0.3)).ceil() as u32).max(4);
        Self {
            threshold,
            min_samples: min_samples.unwrap_or_else(auto),
        }
    }
}

/// One pixel's sums over its odd-indexed samples: the half buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HalfSum {
    /// Sum of the finite odd-indexed samples' RGB, W/(m^2 sr).
    pub rgb: [f64; 3],
    /// How many there are.
    pub count: u32,
}

impl HalfSum {
    /// Adds another sum of the same pixel.
    pub(super) fn add(&mut self, other: &HalfSum) {
        for c in 0..3 {
            self.rgb[c] += other.rgb[c];
        }
        self.count += other.count;
    }
}

/// What an adaptive film keeps beside its sums: the half buffer, and which
/// pixels sample in the current pass (decided at its start, kept in
/// checkpoints so a render resumed mid-pass samples the same pixels).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Halves {
    /// One per pixel of the film's window, row-major.
    pub(super) sums: Vec<HalfSum>,
    /// One per pixel: it takes the current pass's samples.
    pub(super) active: Vec<bool>,
}

impl Halves {
    /// Empty sums; every pixel samples.
    pub(super) fn new(pixels: usize) -> Self {
        Self {
            sums: vec![HalfSum::default(); pixels],
            active: vec![true; pixels],
        }
    }

    /// Decides which pixels of a `width`-pixel-wide window sample in the
    /// next pass, from the (RGB sum, finite samples) every pixel has now
    /// (`full`, row-major): an active pixel stops when its
    /// [`relative_error`] is under `threshold`, then every neighbour of a
    /// pixel still active is active again.
    pub(super) fn decide(
        &mut self,
        full: impl Iterator<Item = ([f64; 3], u32)>,
        width: usize,
        threshold: f32,
    ) {
        let mut keep: Vec<bool> = self
            .active
            .iter()
            .zip(full.zip(&self.sums))
            .map(|(&active, (f, h))| {
                active && relative_error(f, h).is_none_or(|e| e >= f64::from(threshold))
            })
            .collect();
        dilate(&mut keep, width);
        self.active = keep;
    }
}

/// The relative error of the mean of a pixel whose finite samples sum to
/// `rgb` over `count` (module docs), or `None` while it cannot be estimated
/// (no finite sample in one of the halves).
pub(super) fn relative_error((rgb, count): ([f64; 3], u32), half: &HalfSum) -> Option<f64> {
    let even = count.checked_sub(half.count)?;
    if even == 0 || half.count == 0 {
        return None;
    }
    let n = f64::from(count);
    let m = f64::from(half.count);
    let mut difference = 0.0;
    let mut intensity = 0.0;
    for (sum, half_sum) in rgb.iter().zip(half.rgb) {
        let mean = sum / n;
        difference += (mean - half_sum / m).abs();
        intensity += mean;
    }
    let scale = if intensity < 1.0 {
        intensity.max(0.0).sqrt()
    } else {
        intensity
    };
    Some(difference / (1e-4 + scale))
}

/// Marks the 3 x 3 neighbours of every marked pixel (of a row-major image
/// `width` wide): a box filter in x, then in y.
fn dilate(marked: &mut [bool], width: usize) {
    let rows: Vec<bool> = (0..marked.len())
        .map(|i| {
            let x = i % width;
            marked[i] || (x > 0 && marked[i - 1]) || (x + 1 < width && marked[i + 1])
        })
        .collect();
    for (i, m) in marked.iter_mut().enumerate() {
        *m = rows[i]
            || (i >= width && rows[i - width])
            || rows.get(i + width).copied().unwrap_or(false);
    }
}

/// The pixels that sample in the current pass: a read-only copy the tiles
/// consult while the film takes their sums.
#[derive(Clone, Debug)]
pub struct ActivePixels {
    /// The film window's top-left pixel and width.
    origin: UVec2,
    width: u32,
    /// One per pixel of the window, row-major.
    active: Vec<bool>,
}

impl ActivePixels {
    pub(super) fn new(origin: UVec2, width: u32, active: Vec<bool>) -> Self {
        Self {
            origin,
            width,
            active,
        }
    }

    /// Whether image pixel `p` (inside the window) samples.
    pub fn contains(&self, p: UVec2) -> bool {
        let local = p - self.origin;
        self.active[local.y as usize * self.width as usize + local.x as usize]
    }

    /// How many pixels sample.
    pub fn count(&self) -> usize {
        self.active.iter().filter(|&&a| a).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pixel's (RGB sum, count) and half sum after grey samples `values`.
    fn sums(values: &[f64]) -> (([f64; 3], u32), HalfSum) {
        let mut full = ([0.0; 3], 0);
        let mut half = HalfSum::default();
        for (i, &v) in values.iter().enumerate() {
            full.0 = full.0.map(|s| s + v);
            full.1 += 1;
            if i % 2 == 1 {
                half.rgb = half.rgb.map(|s| s + v);
                half.count += 1;
            }
        }
        (full, half)
    }

    #[test]
    fn the_error_is_the_halves_difference_over_the_root_of_the_intensity() {
        // Mean 0.15 per channel, odd half 0.2: 3 * 0.05 / (1e-4 + sqrt(0.45)).
        let (full, half) = sums(&[0.1, 0.2, 0.1, 0.2]);
        let e = relative_error(full, &half).unwrap();
        assert!((e - 0.15 / (1e-4 + 0.45f64.sqrt())).abs() < 1e-12, "{e}");
        // Bright: divided by the intensity itself (mean 10.5, odd half 11).
        let (full, half) = sums(&[10.0, 11.0]);
        let e = relative_error(full, &half).unwrap();
        assert!((e - 1.5 / (1e-4 + 31.5)).abs() < 1e-12, "{e}");
        // Constant: no error; one sample: no estimate.
        assert_eq!(
            relative_error(sums(&[2.0; 4]).0, &sums(&[2.0; 4]).1),
            Some(0.0)
        );
        assert_eq!(relative_error(sums(&[2.0]).0, &sums(&[2.0]).1), None);
    }

    #[test]
    fn neighbours_of_active_pixels_stay_active_and_stopped_pixels_stay_stopped() {
        // 5 x 4 pixels, all converged (constant) but one noisy at (1, 1).
        let (quiet, quiet_half) = sums(&[1.0; 4]);
        let (noisy, noisy_half) = sums(&[0.0, 4.0, 0.0, 4.0]);
        let mut full = vec![quiet; 20];
        let mut halves = Halves::new(20);
        halves.sums = vec![quiet_half; 20];
        full[6] = noisy;
        halves.sums[6] = noisy_half;
        halves.decide(full.iter().copied(), 5, 0.01);
        let active: Vec<usize> = (0..20).filter(|&i| halves.active[i]).collect();
        assert_eq!(active, [0, 1, 2, 5, 6, 7, 10, 11, 12]);
        // The noisy pixel converges: all stop, and a stopped one never restarts.
        full[6] = quiet;
        halves.sums[6] = quiet_half;
        halves.decide(full.iter().copied(), 5, 0.01);
        assert!(halves.active.iter().all(|a| !a));
        full[0] = noisy;
        halves.sums[0] = noisy_half;
        halves.decide(full.iter().copied(), 5, 0.01);
        assert!(halves.active.iter().all(|a| !a));
    }

    #[test]
    fn the_automatic_minimum_follows_cycles() {
        let min = |t| AdaptiveSampling::new(t, None).min_samples;
        assert_eq!((min(0.1), min(0.01), min(0.001)), (32, 64, 128));
        assert_eq!(AdaptiveSampling::new(0.1, Some(8)).min_samples, 8);
    }
}
