//! Error of an image against a reference: MSE (RMSE is its root), relative
//! MSE and the mean signed bias, over pixels and RGB channels.

/// How an image's error against the reference is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ErrorMetric {
    /// Mean squared error over pixels and RGB channels.
    Mse,
    /// Relative MSE: mean over pixels and channels of (x - r)^2 / (r^2 +
    /// 0.01), as in Rousselle et al. 2011 and most denoising and path
    /// guiding papers, so bright and dark regions weigh alike (the 0.01
    /// keeps black reference pixels finite).
    RelMse,
    /// Mean signed difference x - r over pixels and channels (radiance): the
    /// image's bias against the reference, positive when too bright. Not an
    /// error to chart on a log axis.
    Bias,
}

impl ErrorMetric {
    /// The error of `image` against `reference` (same layout, linear RGB).
    pub(crate) fn error(self, image: &[f32], reference: &[f32]) -> f64 {
        let sum: f64 = image
            .iter()
            .zip(reference)
            .map(|(&a, &b)| {
                let difference = f64::from(a - b);
                match self {
                    Self::Mse => difference.powi(2),
                    Self::RelMse => difference.powi(2) / (f64::from(b).powi(2) + 0.01),
                    Self::Bias => difference,
                }
            })
            .sum();
        sum / image.len() as f64
    }

    /// The metric's name in tables and charts.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Mse => "MSE",
            Self::RelMse => "relMSE",
            Self::Bias => "bias",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_match_their_formulas() {
        let reference = [0.0, 1.0, 3.0];
        let image = [0.1, 1.5, 2.0];
        let mse = (0.01 + 0.25 + 1.0) / 3.0;
        let rel = (0.01 / 0.01 + 0.25 / 1.01 + 1.0 / 9.01) / 3.0;
        assert!((ErrorMetric::Mse.error(&image, &reference) - mse).abs() < 1e-7);
        assert!((ErrorMetric::RelMse.error(&image, &reference) - rel).abs() < 1e-7);
        let bias = (0.1 + 0.5 - 1.0) / 3.0;
        assert!((ErrorMetric::Bias.error(&image, &reference) - bias).abs() < 1e-7);
    }
}
