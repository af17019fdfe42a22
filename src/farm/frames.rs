//! Frame sequences: `A-B[xSTEP]` ranges (`cirrus render --frames`, `cirrus
//! farm submit --frames`) and the output name of each frame, where a run of
//! `#` becomes the zero-padded frame number (`shot.####.exr`, as husk and
//! Nuke write sequences).

use std::path::{Path, PathBuf};
use std::str::FromStr;

/// Frames (USD time codes) `first`, `first + step`, ... up to `last`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    first: i64,
    last: i64,
    step: i64,
}

impl FrameRange {
    /// The frames in order.
    pub fn frames(&self) -> impl Iterator<Item = i64> {
        (self.first..=self.last).step_by(self.step as usize)
    }
}

impl FromStr for FrameRange {
    type Err = String;

    /// `A-B` (inclusive), `A-BxSTEP`, or a single frame `A`, with A <= B and
    /// STEP >= 1.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || {
            format!(
                "{s:?}: expected frames A-B[xSTEP] with A <= B and STEP >= 1, e.g. 1-24 or 1-24x2"
            )
        };
        let (range, step) = s.trim().split_once('x').unwrap_or((s.trim(), "1"));
        let (a, b) = match range.split_once('-').filter(|(a, _)| !a.is_empty()) {
            Some(ends) => ends,
            None => (range, range),
        };
        match (a.trim().parse(), b.trim().parse(), step.trim().parse()) {
            (Ok(first), Ok(last), Ok(step)) if first <= last && step >= 1 => {
                Ok(Self { first, last, step })
            }
            _ => Err(bad()),
        }
    }
}

/// Whether `pattern` holds a run of `#` for the frame number.
pub fn has_frame_number(pattern: &Path) -> bool {
    pattern.to_string_lossy().contains('#')
}

/// The output path of `frame`: the first run of `#` replaced by the
/// zero-padded number (`None`, or no `#`: the pattern itself).
pub fn frame_output(pattern: &Path, frame: Option<i64>) -> PathBuf {
    let text = pattern.to_string_lossy();
    let (Some(frame), Some(start)) = (frame, text.find('#')) else {
        return pattern.to_path_buf();
    };
    let width = text[start..].chars().take_while(|&c| c == '#').count();
    let number = format!("{frame:0width$}");
    PathBuf::from(format!(
        "{}{number}{}",
        &text[..start],
        &text[start + width..]
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse_with_steps_and_refuse_empty_or_reversed_ones() {
        let frames = |s: &str| {
            s.parse::<FrameRange>()
                .map(|r| r.frames().collect::<Vec<_>>())
        };
        assert_eq!(frames("1-4"), Ok(vec![1, 2, 3, 4]));
        assert_eq!(frames("1-7x3"), Ok(vec![1, 4, 7]));
        assert_eq!(frames("5"), Ok(vec![5]));
        for bad in ["9-2", "x", "", "1-4x0", "1-4x-1", "1-"] {
            assert!(frames(bad).is_err(), "{bad:?} parsed");
        }
    }

    #[test]
    fn frame_patterns_fill() {
        let p = Path::new("/o/shot.####.exr");
        assert_eq!(frame_output(p, Some(7)), Path::new("/o/shot.0007.exr"));
        assert_eq!(frame_output(p, None), p);
        assert!(has_frame_number(p) && !has_frame_number(Path::new("/o/a.exr")));
        assert_eq!(
            frame_output(Path::new("/o/a.exr"), Some(3)),
            Path::new("/o/a.exr")
        );
    }
}
