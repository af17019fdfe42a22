//! Frame sequences: `A-B[xSTEP]` ranges (`cirrus render --frames`, `cirrus
//! farm submit --frames`) and the output name of each frame, where a run of
//! `#` becomes the zero-padded frame number (`shot.####.exr`, as husk and
//! Nuke write sequences), as do husk's `$F4` and `<F4>` (`$F`, `<F>`: unpadded).

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

/// Whether `pattern` holds a frame token (see [`frame_output`]).
pub fn has_frame_number(pattern: &Path) -> bool {
    let text = pattern.to_string_lossy();
    text.char_indices()
        .any(|(at, _)| frame_token(&text[at..]).is_some())
}

/// The frame token at the start of `text`, as (its length in bytes, the
/// number's width): a run of `#` (its length), `$F` or `$F<n>`, `<F>` or
/// `<F<n>>` (width n, 1..=9; husk's and Houdini's forms).
fn frame_token(text: &str) -> Option<(usize, usize)> {
    let hashes = text.bytes().take_while(|&b| b == b'#').count();
    if hashes > 0 {
        return Some((hashes, hashes));
    }
    let digit = |at: usize| {
        text.as_bytes()
            .get(at)
            .filter(|b| (b'1'..=b'9').contains(b))
            .map(|b| usize::from(b - b'0'))
    };
    if text.starts_with("$F") {
        return Some(digit(2).map_or((2, 1), |width| (3, width)));
    }
    if text.starts_with("<F>") {
        return Some((3, 1));
    }
    let width = digit(2).filter(|_| text.starts_with("<F"))?;
    (text.as_bytes().get(3) == Some(&b'>')).then_some((4, width))
}

/// The output path of `frame`: every frame token (a run of `#`, `$F4`,
/// `<F4>`, ...) replaced by the number zero-padded to the token's width
/// (`None`, or no token: the pattern itself).
pub fn frame_output(pattern: &Path, frame: Option<i64>) -> PathBuf {
    let text = pattern.to_string_lossy();
    let Some(frame) = frame else {
        return pattern.to_path_buf();
    };
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    while at < text.len() {
        match frame_token(&text[at..]) {
            Some((length, width)) => {
                out += &format!("{frame:0width$}");
                at += length;
            }
            None => {
                let c = text[at..]
                    .chars()
                    .next()
                    .expect("at < len, on a char boundary");
                out.push(c);
                at += c.len_utf8();
            }
        }
    }
    PathBuf::from(out)
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
        let husk = |p: &str| frame_output(Path::new(p), Some(7));
        assert_eq!(husk("s.$F4.exr"), Path::new("s.0007.exr"));
        assert_eq!(husk("s.$F.exr"), Path::new("s.7.exr"));
        assert_eq!(husk("s.<F3>.exr"), Path::new("s.007.exr"));
        assert_eq!(husk("s_<F>_$F2.exr"), Path::new("s_7_07.exr"));
        assert_eq!(husk("s.<Fx>.exr"), Path::new("s.<Fx>.exr"));
        assert!(has_frame_number(Path::new("a.$F4.exr")));
        assert!(!has_frame_number(Path::new("a.<F.exr")));
    }
}
