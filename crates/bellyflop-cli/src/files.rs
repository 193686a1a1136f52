//! Output files written whole or not at all: into a hidden temporary file
//! beside the final name, then renamed over it.

use std::path::{Path, PathBuf};

use crate::error::OutputError;

/// Write `contents` to `path` whole or not at all (see [`commit`]).
pub fn write_file(path: &Path, contents: impl AsRef<[u8]>) -> Result<(), OutputError> {
    commit(path, |tmp| {
        std::fs::write(tmp, contents.as_ref()).map_err(|e| OutputError::io(path, e))
    })
}

/// Have `write` write the file `path` into a hidden temporary file beside it
/// (`.NAME.partial.EXT`, the extension kept for writers that go by it), then
/// rename that over `path`: a failed write (a full disk, a file-size limit)
/// leaves no half-written file under the final name, and the temporary file
/// is removed. A `path` that exists and is not a regular file (a device
/// such as /dev/full, a FIFO) is written in place.
pub fn commit(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    let special = std::fs::metadata(path).is_ok_and(|m| !m.is_file());
    if special {
        return write(path);
    }
    let tmp = temp_path(path);
    let result = write(&tmp)
        .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| OutputError::io(path, e)));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The temporary name of [`commit`]: `.NAME.partial.EXT` beside `path`.
fn temp_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!(".{stem}.partial.{}", ext.to_string_lossy()),
        None => format!(".{stem}.partial"),
    };
    path.with_file_name(name)
}
