//! IES photometric profiles (ANSI/IES LM-63, the 1995, 2002 and 2019
//! editions): a reader of the text format and the tabulated candela
//! distribution it holds, looked up bilinearly.
//!
//! Only type C photometry (photometric type 1, every architectural and
//! theatrical luminaire) is read: vertical angles from 0 (nadir, the light's
//! axis) to 180 degrees, horizontal angles 0 (the light's +X) towards 90
//! (+Y), with LM-63's symmetries (one horizontal angle: rotationally
//! symmetric; 0-90: quadrants; 0-180 and 90-270: bilateral). Tilt data
//! (`TILT=INCLUDE`) is skipped; the ballast and lamp factors are ignored, as
//! Cycles and the OpenUSD reference (hdEmbree's `PxrIESFile`) ignore them.

use std::f32::consts::PI;
use std::path::Path;

/// Largest table (vertical x horizontal angles) read: LM-63 files hold at
/// most a few tens of thousands of values; more is a corrupt count.
const MAX_VALUES: usize = 1 << 20;

/// Why an IES file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum IesError {
    /// The file cannot be read.
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    /// The text is not an LM-63 profile this reader takes.
    #[error("not a usable LM-63 profile: {0}")]
    Malformed(String),
}

/// A type C candela distribution: candela (cd, the file's values times its
/// candela multiplier) on a grid of vertical x horizontal angles.
#[derive(Clone, Debug)]
pub struct IesProfile {
    /// Vertical angles, radians, strictly increasing within [0, pi].
    vertical: Vec<f32>,
    /// Horizontal angles, radians, strictly increasing within [0, 2 pi].
    horizontal: Vec<f32>,
    /// Candela, horizontal-major: `candela[h * vertical.len() + v]`.
    candela: Vec<f32>,
    /// Values that were NaN, infinite, negative or above [`MAX_CANDELA`],
    /// read as 0.
    bad_values: usize,
}

/// The largest candela value read (cd): far above any lamp, and low enough
/// that sums over a profile's grid (its mean intensity, its power in the
/// light BVH) stay finite in f32. Larger values are read as 0 and counted.
const MAX_CANDELA: f32 = 1e20;

impl IesProfile {
    /// Reads and parses the file at `path`.
    pub fn read(path: &Path) -> Result<Self, IesError> {
        let bytes = std::fs::read(path).map_err(|source| IesError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::parse(&String::from_utf8_lossy(&bytes))
    }

    /// Parses LM-63 text: keyword lines up to `TILT=`, then the numbers
    /// (separated by white space or commas, across lines in any way).
    pub fn parse(text: &str) -> Result<Self, IesError> {
        let bad = |what: &str| IesError::Malformed(what.to_owned());
        let mut lines = text.lines();
        let tilt = lines
            .by_ref()
            .map(str::trim)
            .find_map(|l| l.strip_prefix("TILT="))
            .ok_or_else(|| bad("no TILT= line"))?
            .trim();
        let rest: Vec<&str> = lines.collect();
        let mut numbers = rest
            .iter()
            .flat_map(|l| l.split(|c: char| c.is_whitespace() || c == ','))
            .filter(|t| !t.is_empty());
        let mut next = |what: &str| -> Result<f32, IesError> {
            let token = numbers
                .next()
                .ok_or_else(|| bad(&format!("the file ends before {what}")))?;
            token
                .parse::<f32>()
                .map_err(|_| bad(&format!("{what}: {token:?} is not a number")))
        };
        match tilt {
            "NONE" => {}
            "INCLUDE" => {
                next("the lamp-to-luminaire geometry")?;
                let pairs = count(next("the tilt angle count")?, "tilt angle count")?;
                for _ in 0..2 * pairs {
                    next("the tilt table")?;
                }
            }
            file => return Err(bad(&format!("TILT={file}: tilt files are not read"))),
        }
        let _lamps = next("the lamp count")?;
        let _lumens = next("the lumens per lamp")?;
        let multiplier = next("the candela multiplier")?;
        let nv = count(next("the vertical angle count")?, "vertical angle count")?;
        let nh = count(
            next("the horizontal angle count")?,
            "horizontal angle count",
        )?;
        let photometric_type = next("the photometric type")?;
        for what in ["units type", "width", "length", "height", "ballast factor"] {
            next(what)?;
        }
        next("the ballast-lamp factor")?;
        next("the input watts")?;
        if photometric_type != 1.0 {
            return Err(bad(&format!(
                "photometric type {photometric_type} (only type C, 1, is read)"
            )));
        }
        if !(multiplier.is_finite() && multiplier >= 0.0) {
            return Err(bad(&format!("candela multiplier {multiplier}")));
        }
        if nv.checked_mul(nh).is_none_or(|n| n > MAX_VALUES) {
            return Err(bad(&format!("{nv} x {nh} candela values")));
        }
        let vertical = angles(&mut next, nv, "vertical", 180.0)?;
        let horizontal = angles(&mut next, nh, "horizontal", 360.0)?;
        let (first, last) = (horizontal[0], horizontal[nh - 1]);
        let symmetric = nh == 1 || first == 0.0 || (near(first, PI / 2.0) && near(last, 1.5 * PI));
        if !symmetric {
            return Err(bad(
                "horizontal angles start neither at 0 nor at 90 (to 270) degrees",
            ));
        }
        let mut bad_values = 0;
        let mut candela = Vec::with_capacity(nv * nh);
        for _ in 0..nv * nh {
            let value = next("the candela values")? * multiplier;
            if (0.0..=MAX_CANDELA).contains(&value) {
                candela.push(value);
            } else {
                bad_values += 1;
                candela.push(0.0);
            }
        }
        Ok(Self {
            vertical,
            horizontal,
            candela,
            bad_values,
        })
    }

    /// Values that were NaN, infinite or negative and were read as 0.
    pub fn bad_values(&self) -> usize {
        self.bad_values
    }

    /// Candela towards vertical angle `theta` (radians from the light's
    /// axis) and horizontal angle `phi` (radians from +X towards +Y):
    /// bilinear in the table, 0 outside its vertical range.
    pub fn candela(&self, theta: f32, phi: f32) -> f32 {
        let (v0, w) = match bracket(&self.vertical, theta) {
            Some(b) => b,
            None => return 0.0,
        };
        let nv = self.vertical.len();
        let column = |h: usize| {
            let c = &self.candela[h * nv..(h + 1) * nv];
            if w == 0.0 {
                c[v0]
            } else {
                c[v0] * (1.0 - w) + c[v0 + 1] * w
            }
        };
        if self.horizontal.len() == 1 {
            return column(0);
        }
        let phi = self.fold(phi.rem_euclid(2.0 * PI)).max(self.horizontal[0]);
        let last = self.horizontal.len() - 1;
        match bracket(&self.horizontal, phi) {
            Some((h0, 0.0)) => column(h0),
            Some((h0, s)) => column(h0) * (1.0 - s) + column(h0 + 1) * s,
            // Beyond the last angle of a full circle not closed at 360:
            // between the last column and the first, 360 degrees on.
            None => {
                let span = 2.0 * PI - self.horizontal[last];
                let s = if span > 0.0 {
                    ((phi - self.horizontal[last]) / span).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                column(last) * (1.0 - s) + column(0) * s
            }
        }
    }

    /// `phi` in [0, 2 pi) mapped into the range the table covers, by its
    /// LM-63 symmetry.
    fn fold(&self, phi: f32) -> f32 {
        let (first, last) = (
            self.horizontal[0],
            self.horizontal[self.horizontal.len() - 1],
        );
        let mirror_at_pi = |p: f32| if p > PI { 2.0 * PI - p } else { p };
        if first == 0.0 && near(last, PI / 2.0) {
            let p = mirror_at_pi(phi);
            if p > PI / 2.0 {
                PI - p
            } else {
                p
            }
        } else if first == 0.0 && near(last, PI) {
            mirror_at_pi(phi)
        } else if near(first, PI / 2.0) {
            // 90-270: mirror across the 90-270 degree plane.
            if phi < PI / 2.0 {
                PI - phi
            } else if phi > 1.5 * PI {
                3.0 * PI - phi
            } else {
                phi
            }
        } else {
            phi
        }
    }

    /// The mean intensity over the sphere (over the lower hemisphere when
    /// the vertical angles span at most 90 degrees plus 0.1 radian), cd: the
    /// integral of the candela over the solid angle of every patch, bilinear
    /// at its centre, as the OpenUSD reference (`PxrIESFile`) computes the
    /// "profile power" `shaping:ies:normalize` divides by.
    pub fn mean_intensity(&self) -> f32 {
        const PHI_STEPS: usize = 360;
        let d_phi = 2.0 * PI / PHI_STEPS as f32;
        let mut power = 0.0f64;
        for pair in self.vertical.windows(2) {
            let (dv, mid) = (pair[1] - pair[0], 0.5 * (pair[0] + pair[1]));
            let ring: f32 = (0..PHI_STEPS)
                .map(|k| self.candela(mid, (k as f32 + 0.5) * d_phi))
                .sum();
            power += f64::from(ring * d_phi * dv * mid.sin());
        }
        let span = self.vertical[self.vertical.len() - 1] - self.vertical[0];
        let sphere = span > PI / 2.0 + 0.1;
        (power / f64::from(PI * if sphere { 4.0 } else { 2.0 })) as f32
    }

    /// The largest vertical angle (radians) towards which the profile may
    /// emit: the angle after the last one holding a positive value; `None`
    /// when every value is 0.
    pub fn max_theta(&self) -> Option<f32> {
        let nv = self.vertical.len();
        let last = (0..nv)
            .rev()
            .find(|&v| self.candela.iter().skip(v).step_by(nv).any(|&c| c > 0.0))?;
        Some(self.vertical[(last + 1).min(nv - 1)])
    }
}

/// Whether two angles (radians) are the same up to the rounding of a
/// conversion from degrees.
fn near(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-5
}

/// A table count: a whole number from 1 up.
fn count(value: f32, what: &str) -> Result<usize, IesError> {
    if value >= 1.0 && value.fract() == 0.0 && value <= MAX_VALUES as f32 {
        Ok(value as usize)
    } else {
        Err(IesError::Malformed(format!("{what} {value}")))
    }
}

/// `n` angles in degrees, strictly increasing within [0, `max_deg`], as
/// radians.
fn angles(
    next: &mut impl FnMut(&str) -> Result<f32, IesError>,
    n: usize,
    what: &str,
    max_deg: f32,
) -> Result<Vec<f32>, IesError> {
    let mut out: Vec<f32> = Vec::with_capacity(n);
    let mut previous = f32::NEG_INFINITY;
    for _ in 0..n {
        let deg = next(&format!("the {what} angles"))?;
        if !(deg > previous && (0.0..=max_deg).contains(&deg)) {
            return Err(IesError::Malformed(format!(
                "{what} angles are not increasing within [0, {max_deg}] ({deg} after {previous})"
            )));
        }
        previous = deg;
        out.push(deg.to_radians());
    }
    Ok(out)
}

/// The interval of sorted `grid` holding `x` and the weight of its upper
/// end (0 on a grid point); `None` outside the grid.
fn bracket(grid: &[f32], x: f32) -> Option<(usize, f32)> {
    if !(x >= grid[0] && x <= grid[grid.len() - 1]) {
        return None;
    }
    let i = grid.partition_point(|&g| g <= x).saturating_sub(1);
    if i + 1 >= grid.len() {
        return Some((i, 0.0));
    }
    Some((i, (x - grid[i]) / (grid[i + 1] - grid[i])))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rotationally symmetric profile: 100 cd at 0 degrees, 50 at 45, 0
    /// at 90 (a downlight), with a keyword header.
    const DOWNLIGHT: &str = "IESNA:LM-63-2002\n[TEST] downlight\n[MANUFAC] cirrus\nTILT=NONE\n\
        1 1000 1.0 3 1 1 2 0 0 0\n1.0 1.0 10\n0 45 90\n0\n100 50 0\n";

    #[test]
    fn a_symmetric_profile_interpolates_its_table() {
        let p = IesProfile::parse(DOWNLIGHT).unwrap();
        for phi in [0.0, 1.0, 4.0] {
            assert_eq!(p.candela(0.0, phi), 100.0);
            assert!((p.candela(PI / 4.0, phi) - 50.0).abs() < 1e-4);
            assert!((p.candela(PI / 8.0, phi) - 75.0).abs() < 1e-3);
            assert_eq!(p.candela(PI / 2.0 + 0.01, phi), 0.0);
        }
        assert_eq!(p.max_theta(), Some(PI / 2.0));
    }

    /// A uniform 7 cd over the sphere (every 5 degrees) has mean 7; over the
    /// lower hemisphere only, the mean is taken over that hemisphere.
    #[test]
    fn the_mean_intensity_of_a_uniform_profile_is_its_value() {
        let table = |max_deg: usize| {
            let v: Vec<String> = (0..=max_deg).step_by(5).map(|d| d.to_string()).collect();
            let c = vec!["7"; v.len()].join(" ");
            let n = v.len();
            format!(
                "TILT=NONE\n1 1 1 {n} 1 1 2 0 0 0 1 1 1\n{}\n0\n{c}\n",
                v.join(" ")
            )
        };
        for max_deg in [180, 90] {
            let mean = IesProfile::parse(&table(max_deg)).unwrap().mean_intensity();
            assert!((mean - 7.0).abs() < 7e-3, "{max_deg}: {mean}");
        }
    }

    #[test]
    fn quadrant_and_bilateral_symmetries_fold_the_circle() {
        // Two vertical angles, horizontal 0 and 90: 10 cd at 0, 30 at 90.
        let quadrant = "TILT=NONE\n1 1 1 2 2 1 2 0 0 0 1 1 1\n0 90\n0 90\n10 10\n30 30\n";
        let p = IesProfile::parse(quadrant).unwrap();
        let at = |phi_deg: f32| p.candela(0.3, phi_deg.to_radians());
        assert!((at(0.0) - 10.0).abs() < 1e-4 && (at(90.0) - 30.0).abs() < 1e-4);
        assert!((at(180.0) - 10.0).abs() < 1e-4 && (at(270.0) - 30.0).abs() < 1e-4);
        assert!((at(135.0) - 20.0).abs() < 1e-3 && (at(315.0) - 20.0).abs() < 1e-3);
        let bilateral = "TILT=NONE\n1 1 1 2 2 1 2 0 0 0 1 1 1\n0 90\n90 270\n10 10\n30 30\n";
        let p = IesProfile::parse(bilateral).unwrap();
        let at = |phi_deg: f32| p.candela(0.3, phi_deg.to_radians());
        assert!((at(0.0) - 20.0).abs() < 1e-3, "{}", at(0.0));
        assert!((at(90.0) - 10.0).abs() < 1e-4 && (at(270.0) - 30.0).abs() < 1e-4);
    }

    /// NaN and negative candela read as 0 and are counted; a multiplier
    /// scales the rest.
    #[test]
    fn bad_candela_values_read_as_zero_and_are_counted() {
        let text = "TILT=NONE\n1 1 2.0 3 1 1 2 0 0 0 1 1 1\n0 45 90\n0\n10 nan -3\n";
        let p = IesProfile::parse(text).unwrap();
        assert_eq!(p.bad_values(), 2);
        assert_eq!(p.candela(0.0, 0.0), 20.0);
        assert_eq!(p.candela(PI / 4.0, 0.0), 0.0);
        assert_eq!(p.max_theta(), Some(PI / 4.0));
    }

    /// Values above `MAX_CANDELA` read as 0 and are counted, so the mean
    /// intensity stays finite: the fuzzer's first find (fuzz/seeds/ies_reader/
    /// huge_candela.ies), where two values of 5.6e37 cd summed to infinity.
    #[test]
    fn huge_candela_values_read_as_zero_and_the_mean_stays_finite() {
        let text = include_str!("../../fuzz/seeds/ies_reader/huge_candela.ies");
        let p = IesProfile::parse(text).unwrap();
        assert_eq!(p.bad_values(), 2);
        let mean = p.mean_intensity();
        assert!(mean.is_finite() && mean > 0.0, "mean {mean}");
    }

    /// The fuzz target's properties (fuzz/fuzz_targets/ies_reader.rs), bounded
    /// and seeded: the committed seeds with random bytes overwritten, cut
    /// short or repeated parse or fail cleanly, and every profile accepted
    /// gives finite, non-negative candela, mean and a last angle in [0, pi].
    #[test]
    fn mutated_seeds_parse_or_fail_cleanly() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/ies_reader");
        let mut seeds: Vec<Vec<u8>> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| std::fs::read(e.unwrap().path()).unwrap())
            .collect();
        assert!(seeds.len() >= 3);
        seeds.sort();
        let mut rng = crate::sampling::Pcg32::new(17, 0);
        let mut below = |n: usize| (rng.next_f32() * n as f32) as usize % n.max(1);
        let (mut accepted, mut refused) = (0, 0);
        for round in 0..600 {
            let mut bytes = seeds[round % seeds.len()].clone();
            for _ in 0..1 + below(4) {
                if bytes.is_empty() {
                    break;
                }
                let at = below(bytes.len());
                match below(3) {
                    0 => bytes[at] = b"0123456789.-, \nen"[below(17)],
                    1 => bytes.truncate(at),
                    _ => {
                        let repeated: Vec<u8> = bytes[at..].iter().take(8).copied().collect();
                        bytes.splice(at..at, repeated);
                    }
                }
            }
            let Ok(p) = IesProfile::parse(&String::from_utf8_lossy(&bytes)) else {
                refused += 1;
                continue;
            };
            accepted += 1;
            for i in 0..=18 {
                for j in 0..=24 {
                    let c = p.candela(i as f32 * PI / 18.0, j as f32 * PI / 6.0 - PI);
                    assert!(c.is_finite() && c >= 0.0, "{c}");
                }
            }
            let mean = p.mean_intensity();
            assert!(mean.is_finite() && mean >= 0.0, "{mean}");
            assert!(p.max_theta().is_none_or(|t| (0.0..=PI).contains(&t)));
        }
        assert!(
            accepted > 50 && refused > 50,
            "{accepted} accepted, {refused} refused"
        );
    }

    #[test]
    fn malformed_files_are_errors() {
        for text in [
            "",
            "no tilt line\n1 2 3",
            "TILT=lamp.tlt\n",
            "TILT=NONE\n1 1 1 3 1 1 2 0 0 0 1 1 1\n0 45\n",
            "TILT=NONE\n1 1 1 3 1 2 2 0 0 0 1 1 1\n0 45 90\n0\n1 1 1\n",
            "TILT=NONE\n1 1 1 3 1 1 2 0 0 0 1 1 1\n0 90 45\n0\n1 1 1\n",
            "TILT=NONE\n1 1 1 1e9 1e9 1 2 0 0 0 1 1 1\n",
            "TILT=NONE\n1 1 1 2 1 1 2 0 0 0 1 1 1\n0 90\n0\n1 x\n",
            "TILT=NONE\n1 1 1 2 2 1 2 0 0 0 1 1 1\n0 90\n10 90\n1 1 1 1\n",
        ] {
            assert!(
                matches!(IesProfile::parse(text), Err(IesError::Malformed(_))),
                "{text:?}"
            );
        }
        assert!(matches!(
            IesProfile::read(Path::new("/nonexistent/x.ies")),
            Err(IesError::Io { .. })
        ));
    }
}
