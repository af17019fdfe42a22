//! Files appear whole or not at all: everything Cirrus writes goes to a
//! temporary file in the target's folder, is flushed to disk, and is then
//! renamed over the target (an atomic replace on POSIX file systems). A crash
//! or a full disk leaves the previous file, or none, under the final name;
//! never a truncated one.

use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};

/// Writes `path` through `write`, which is given the temporary path to
/// create. On success the temporary file is synced and renamed to `path`; on
/// any failure it is removed and `path` is untouched.
pub fn replace_file(path: &Path, write: impl FnOnce(&Path) -> io::Result<()>) -> io::Result<()> {
    let temp = temp_path(path);
    let written = write(&temp)
        .and_then(|()| File::open(&temp)?.sync_all())
        .and_then(|()| std::fs::rename(&temp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&temp);
    }
    written
}

/// Writes `bytes` to `path` atomically (see [`replace_file`]).
pub fn write_file(path: &Path, bytes: &[u8]) -> io::Result<()> {
    replace_file(path, |temp| std::fs::write(temp, bytes))
}

/// `dir/.name.PID.tmp.ext`: the same folder (so the rename is atomic), hidden,
/// unique per process, and with the target's extension (OpenImageIO picks its
/// writer from it).
pub(super) fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "tmp".into());
    path.with_file_name(format!(".{name}.{}.tmp.{ext}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temp_file_stays_beside_the_target_with_its_extension() {
        let t = temp_path(Path::new("/a/b/out.exr"));
        assert_eq!(t.parent(), Some(Path::new("/a/b")));
        assert_eq!(t.extension().unwrap(), "exr");
        assert!(t
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with(".out."));
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_leaves_no_temp() {
        let dir = std::env::temp_dir().join(format!("cirrus_atomic_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("file.txt");
        write_file(&path, b"old").unwrap();
        let failed = replace_file(&path, |temp| {
            std::fs::write(temp, b"half")?;
            Err(io::Error::other("disk full"))
        });
        assert!(failed.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert!(!temp_path(&path).exists());
        write_file(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
