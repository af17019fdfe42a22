//! The text forms of a job's flag values that no library type parses
//! itself (`FrameRange`, `Shutter` and `AovSet` do): sizes, seconds,
//! thresholds, on/off, and the parts of a frame. Each returns the message
//! the command line shows for text it refuses.

use std::ops::Range;
use std::time::Duration;

use glam::UVec2;

/// Parses `WIDTHxHEIGHT`, each side in 1..=65536 pixels.
pub fn parse_resolution(s: &str) -> Result<UVec2, String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("{s:?}: expected WIDTHxHEIGHT, e.g. 1280x720"))?;
    let side = |v: &str| {
        v.parse::<u32>()
            .ok()
            .filter(|&n| (1..=65536).contains(&n))
            .ok_or_else(|| format!("{s:?}: {v:?} is not a size in 1..=65536"))
    };
    Ok(UVec2::new(side(w)?, side(h)?))
}

/// Parses a positive, finite number of seconds (`--time`, `--checkpoint-every`,
/// `--preview-every`).
pub fn parse_seconds(s: &str) -> Result<Duration, String> {
    s.parse::<f64>()
        .ok()
        .filter(|t| *t > 0.0)
        .and_then(|t| Duration::try_from_secs_f64(t).ok())
        .ok_or_else(|| format!("{s:?}: must be a positive number of seconds"))
}

/// Parses `--noise-threshold`: a positive, finite relative error.
pub fn parse_noise_threshold(s: &str) -> Result<f32, String> {
    s.parse::<f32>()
        .ok()
        .filter(|t| t.is_finite() && *t > 0.0)
        .ok_or_else(|| format!("{s:?}: must be a positive number, e.g. 0.05"))
}

/// Parses `on` or `off`.
pub fn parse_on_off(value: &str) -> Result<bool, String> {
    match value {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("'{value}' is neither on nor off")),
    }
}

/// Parses `--tile I/N` with 0 <= I < N.
pub fn parse_tile(s: &str) -> Result<(u32, u32), String> {
    let parsed = s
        .split_once('/')
        .and_then(|(i, n)| Some((i.parse::<u32>().ok()?, n.parse::<u32>().ok()?)));
    match parsed {
        Some((i, n)) if i < n => Ok((i, n)),
        _ => Err(format!("{s:?}: expected I/N with 0 <= I < N, e.g. 0/4")),
    }
}

/// Parses `--crop X0,Y0,X1,Y1` (pixels) with X0 < X1 and Y0 < Y1.
pub fn parse_crop(s: &str) -> Result<[u32; 4], String> {
    let values: Vec<u32> = s.split(',').filter_map(|v| v.trim().parse().ok()).collect();
    match values[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        _ => Err(format!(
            "{s:?}: expected X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1, e.g. 0,0,640,360"
        )),
    }
}

/// Parses `--sample-range START..END` with START < END.
pub fn parse_sample_range(s: &str) -> Result<Range<u32>, String> {
    let parsed = s
        .split_once("..")
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)));
    match parsed {
        Some((a, b)) if a < b => Ok(a..b),
        _ => Err(format!(
            "{s:?}: expected START..END with START < END, e.g. 0..32"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_parse_and_bad_ones_are_refused() {
        assert_eq!(parse_resolution("64x36"), Ok(UVec2::new(64, 36)));
        assert!(parse_resolution("0x36").is_err() && parse_resolution("64").is_err());
        assert_eq!(parse_seconds("1.5"), Ok(Duration::from_millis(1500)));
        assert!(parse_seconds("0").is_err() && parse_seconds("nan").is_err());
        assert!(parse_noise_threshold("inf").is_err());
        assert_eq!(parse_on_off("off"), Ok(false));
        assert_eq!(parse_tile("2/4"), Ok((2, 4)));
        assert!(parse_tile("4/4").is_err());
        assert_eq!(parse_crop("0,0,8,4"), Ok([0, 0, 8, 4]));
        assert!(parse_crop("8,0,8,4").is_err());
        assert_eq!(parse_sample_range("0..32"), Ok(0..32));
        assert!(parse_sample_range("32..32").is_err());
    }
}
