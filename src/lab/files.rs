//! Files a study writes beside its printed tables: CSVs and text (Markdown,
//! SVG), each written atomically, so a study stopped half way never leaves
//! half a file.

use std::path::Path;

use super::Result;
use crate::file_error::FileError;

/// Writes `text` to `path` atomically.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<()> {
    crate::image::write_file(path, text.as_bytes())
        .map_err(|e| FileError::new("write", path, e).into())
}

/// Writes a CSV of `header` and one line per row to `path` and says so.
pub(crate) fn write_csv(path: &Path, header: &str, lines: &[String]) -> Result<()> {
    write_text(path, &format!("{header}\n{}\n", lines.join("\n")))?;
    println!("Wrote {}", path.display());
    Ok(())
}
