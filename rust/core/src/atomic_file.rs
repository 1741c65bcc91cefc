//! Atomic file replacement: write a uniquely named temporary file next to the target, flush it
//! to disk, rename it over the target, then flush the folder. A crash or an error leaves either
//! the old file or the new one under the final name, never a truncated one (readers such as
//! Blender may pick files up at any time), and two writers of one target never share a temporary.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

use crate::{Error, Result};

/// Marks our temporary files, so a folder listing shows what they are (the spool removes
/// leftovers by it).
pub const TEMP_SUFFIX: &str = ".antumbra-tmp";

/// A file being written under a temporary name beside `path`; [`AtomicFile::commit`] puts it in
/// place. Dropped without a commit, the temporary file is removed and `path` is untouched.
pub struct AtomicFile {
    path: PathBuf,
    dir: PathBuf,
    w: BufWriter<NamedTempFile>,
}

impl AtomicFile {
    /// Starts writing `path`; its folder must exist.
    pub fn create(path: &Path) -> Result<Self> {
        let name = path.file_name().ok_or_else(|| {
            Error::invalid(path.display().to_string(), "output path has no file name")
        })?;
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let mut prefix = std::ffi::OsString::from(".");
        prefix.push(name);
        prefix.push(".");
        // Same folder, so the rename cannot cross file systems and is atomic.
        let temp = tempfile::Builder::new()
            .prefix(&prefix)
            .suffix(TEMP_SUFFIX)
            .tempfile_in(&dir)
            .map_err(|e| Error::io(path, e))?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            dir,
            w: BufWriter::new(temp),
        })
    }

    /// Flushes the data to disk, renames the file over the target and flushes the folder.
    pub fn commit(self) -> Result<()> {
        let path = self.path;
        let temp = self
            .w
            .into_inner()
            .map_err(|e| Error::io(&path, e.error()))?;
        // Data must be on disk before the rename makes it visible, or a crash could expose an
        // empty file under the final name.
        temp.as_file().sync_all().map_err(|e| Error::io(&path, e))?;
        temp.persist(&path).map_err(|e| Error::io(&path, e.error))?;
        sync_dir(&self.dir);
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.w.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.w.flush()
    }
}

impl Seek for AtomicFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.w.seek(pos)
    }
}

/// Writes `path` atomically; `fill` writes the whole content into the given writer.
/// On any error the temporary file is removed and an existing `path` is left untouched.
pub(crate) fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut AtomicFile) -> Result<()>,
{
    let mut file = AtomicFile::create(path)?;
    fill(&mut file)?;
    file.commit()
}

/// Persists a rename in `dir`; best effort, as not every platform can open a folder.
pub fn sync_dir(dir: &Path) {
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
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    write_atomic(path, |w| w.write_all(bytes).map_err(|e| Error::io(path, e)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::file_names;
    use std::fs;
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

    /// Two writers of one target each have their own temporary file; the last commit wins.
    #[test]
    fn output_atomic_writers_of_one_target_do_not_clash() {
        let dir = TempDir::new().unwrap();
        let target = dir.path().join("stats.csv");
        let mut a = AtomicFile::create(&target).unwrap();
        let mut b = AtomicFile::create(&target).unwrap();
        a.write_all(b"from a").unwrap();
        b.write_all(b"from b").unwrap();
        a.commit().unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"from a");
        b.commit().unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"from b");
        assert_eq!(file_names(dir.path()), vec!["stats.csv".to_string()]);
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
