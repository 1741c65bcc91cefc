//! Atomic file replacement: write a temporary file next to the target, flush it to disk, then
//! rename it over the target. A crash or an error leaves either the old file or the new one under
//! the final name, never a truncated one (readers such as Blender may pick files up at any time).

use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::{Error, Result};

/// Marks our temporary files, so a folder listing shows what they are.
const TEMP_SUFFIX: &str = ".antumbra-tmp";

/// Writes `path` atomically; `fill` writes the whole content into the given writer.
/// On any error the temporary file is removed and an existing `path` is left untouched.
pub(crate) fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let (dir, temp) = temp_path(path)?;
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(|e| Error::io(&temp, e))?;
    let result = fill_and_sync(file, fill, &temp).and_then(|()| {
        // Same folder, so the rename cannot cross file systems and is atomic.
        fs::rename(&temp, path).map_err(|e| Error::io(path, e))
    });
    if result.is_err() {
        let _ = fs::remove_file(&temp);
        return result;
    }
    sync_dir(&dir);
    Ok(())
}

fn fill_and_sync<F>(file: File, fill: F, temp: &Path) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let mut writer = BufWriter::new(file);
    fill(&mut writer)?;
    writer.flush().map_err(|e| Error::io(temp, e))?;
    let file = writer
        .into_inner()
        .map_err(|e| Error::io(temp, e.error()))?;
    // Data must be on disk before the rename makes it visible, or a crash could expose an
    // empty file under the final name.
    file.sync_all().map_err(|e| Error::io(temp, e))
}

/// The folder of `path` and a fresh temporary name in it (unique per process and call).
fn temp_path(path: &Path) -> Result<(PathBuf, PathBuf)> {
    let name = path.file_name().ok_or_else(|| {
        Error::invalid(path.display().to_string(), "output path has no file name")
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(".{}-{n}{TEMP_SUFFIX}", std::process::id()));
    let temp = dir.join(temp_name);
    Ok((dir, temp))
}

/// Persists the rename itself; best effort, as not every platform can open a folder.
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

/// Writes `bytes` to `path` atomically, creating the parent folder if needed.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    write_atomic(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::file_names;
    use tempfile::TempDir;

    #[test]
    fn output_atomic_replaces_and_cleans_up() {
        let dir = TempDir::new().unwrap();
        let target = dir.path().join("a.bin");
        write_atomic(&target, |w| {
            w.write_all(b"first").map_err(|e| Error::io("x", e))
        })
        .unwrap();
        write_atomic(&target, |w| {
            w.write_all(b"second").map_err(|e| Error::io("x", e))
        })
        .unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"second");
        assert_eq!(file_names(dir.path()), vec!["a.bin".to_string()]);
    }

    #[test]
    fn output_atomic_failure_keeps_old_file_and_no_temp() {
        let dir = TempDir::new().unwrap();
        let target = dir.path().join("a.bin");
        fs::write(&target, b"old").unwrap();
        let err = write_atomic(&target, |w| {
            w.write_all(b"half").unwrap();
            Err(Error::invalid("test", "fails midway"))
        })
        .unwrap_err();
        assert!(matches!(err, Error::Invalid { .. }));
        assert_eq!(fs::read(&target).unwrap(), b"old");
        assert_eq!(file_names(dir.path()), vec!["a.bin".to_string()]);
    }

    #[test]
    fn output_atomic_missing_folder_is_io_error() {
        let dir = TempDir::new().unwrap();
        let target = dir.path().join("no_such_folder").join("a.bin");
        let err = write_atomic(&target, |_| Ok(())).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err}");
        assert!(file_names(dir.path()).is_empty());
    }
}
