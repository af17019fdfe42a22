//! How instances are named in the manifest ([`NameRun`]s of
//! [`NamePattern`]s), for Cryptomatte (docs/conventions.md, "Cryptomatte
//! names").

use serde::Deserialize;

/// How a run of consecutive instances is named: a few per instancer or
/// instanceable prim, never one string per PointInstancer instance.
#[derive(Clone, Debug, Deserialize)]
pub struct NameRun {
    /// Instances in the run (the runs' counts add up to `Instances::count`).
    pub count: u64,
    /// The name of each instance's prototype root (`/World/teapot_3`,
    /// `/World/scatter[12]`).
    pub root: NamePattern,
    /// The nearest `component` or `assembly` model above the prototype
    /// root; `null` when there is none.
    pub asset: Option<NamePattern>,
}

/// A prim path that may hold the instance's `source_index`: `head`, then
/// `[source_index]` when `indexed`, then `tail` (`/World/scatter` `[12]`
/// `/Prototypes/tree/leaves`).
#[derive(Clone, Debug, Deserialize)]
pub struct NamePattern {
    /// The path up to the PointInstancer (or all of it).
    pub head: String,
    /// Whether `[source_index]` follows `head`.
    pub indexed: bool,
    /// The path below the PointInstancer's prototype root, if any.
    pub tail: String,
    /// For copies of a PointInstancer nested in another's prototype, the
    /// inner instancer's index and the path after it (absent: none).
    #[serde(default)]
    pub inner: Option<InnerIndex>,
}

/// The inner PointInstancer index of a run's copies: the run's copy `k`
/// (counted from the run's first) has `indices[k % indices.len()]` (the
/// outer instancer's copies are outer-major), written as `[index]` then
/// `tail` after the pattern's own `tail`.
#[derive(Clone, Debug, Deserialize)]
pub struct InnerIndex {
    /// The inner instancer's `ids` (else positions) of one outer copy's
    /// copies, in order.
    pub indices: Vec<u32>,
    /// The path below the inner instancer's prototype root, if any.
    pub tail: String,
}

impl NamePattern {
    /// Spells the name for the copy `position` of a run (see
    /// [`InnerIndex`]), of `source_index`, as pieces of UTF-8 given to
    /// `out` in order (no allocation).
    pub fn spell(&self, source_index: u32, position: u64, out: &mut dyn FnMut(&[u8])) {
        out(self.head.as_bytes());
        if self.indexed {
            spell_index(source_index, out);
        }
        out(self.tail.as_bytes());
        if let Some(inner) = self.inner.as_ref().filter(|i| !i.indices.is_empty()) {
            let k = position % inner.indices.len() as u64;
            spell_index(inner.indices[k as usize], out);
            out(inner.tail.as_bytes());
        }
    }
}

/// Spells `[index]` into `out` (no allocation).
fn spell_index(index: u32, out: &mut dyn FnMut(&[u8])) {
    let mut digits = [0u8; 10];
    let mut start = digits.len();
    let mut n = index;
    loop {
        start -= 1;
        digits[start] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    out(b"[");
    out(&digits[start..]);
    out(b"]");
}
