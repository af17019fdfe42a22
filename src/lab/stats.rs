//! Statistics over repeated measurements: medians, Student-t confidence
//! intervals of a mean, and power-law slopes on log-log axes.

/// The median of `xs` (the mean of the middle two for an even count).
pub(crate) fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// Two-sided 95% quantiles of Student's t for 1 to 30 degrees of freedom.
const T_975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
    2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
    2.052, 2.048, 2.045, 2.042,
];

/// The 97.5% quantile of Student's t with `dof` degrees of freedom: the
/// table up to 30, then the normal quantile 1.96 with its first
/// Cornish-Fisher correction, 1.96 + (1.96^3 + 1.96) / (4 dof), within 0.2%.
pub(crate) fn t_975(dof: usize) -> f64 {
    match dof {
        0 => f64::NAN,
        1..=30 => T_975[dof - 1],
        _ => 1.96 + (1.96f64.powi(3) + 1.96) / (4.0 * dof as f64),
    }
}

/// The mean of independent samples and the half width of its 95%
/// confidence interval (Student's t over the samples).
#[derive(Clone, Copy, Debug)]
pub(crate) struct MeanInterval {
    pub mean: f64,
    pub half_width: f64,
}

impl MeanInterval {
    /// The interval of `samples` (two at least for a finite width).
    pub(crate) fn of(samples: &[f64]) -> Self {
        let n = samples.len();
        let mean = samples.iter().sum::<f64>() / n as f64;
        let variance =
            samples.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / (n as f64 - 1.0).max(1.0);
        Self {
            mean,
            half_width: t_975(n - 1) * (variance / n as f64).sqrt(),
        }
    }
}

/// Least-squares slope of ln y against ln x over `points` (x, y): the
/// exponent of a power law y = c x^k.
pub(crate) fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let points: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x.ln(), y.ln())).collect();
    let n = points.len() as f64;
    let (mx, my) = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.0 / n, y + p.1 / n));
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(sxy, sxx), (x, y)| {
        (sxy + (x - mx) * (y - my), sxx + (x - mx).powi(2))
    });
    sxy / sxx
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_interval_is_students_t() {
        // Mean 2, sample standard deviation 1, 3 samples: 4.303 / sqrt(3).
        let i = MeanInterval::of(&[1.0, 2.0, 3.0]);
        assert!((i.mean - 2.0).abs() < 1e-12);
        assert!((i.half_width - 4.303 / 3f64.sqrt()).abs() < 1e-9);
        // Past the table, within 0.2% of the exact quantiles.
        for (dof, exact) in [(31, 2.0395), (40, 2.0211), (120, 1.9799)] {
            assert!((t_975(dof) / exact - 1.0).abs() < 2e-3, "{dof}");
        }
    }

    #[test]
    fn slope_of_a_power_law_is_its_exponent() {
        let points: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0].map(|x| (x, 0.5 / x)).to_vec();
        assert!((log_log_slope(&points) + 1.0).abs() < 1e-12);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
