//! Atomic file replacement: write a uniquely named temporary file next to the target, flush it
//! to disk, rename it over the target, then flush the folder. A crash or an error leaves either
//! the old file or the new one under the final name, never a truncated one (readers such as
//! Blender may pick files up at any time), and two writers of one target never share a temporary.
//! The file gets the mode the user's umask gives any new file (0644 under umask 022), so results
//! on a farm's shared storage are readable as the user expects.

use std::ffi::{OsStr, OsString};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

use crate::{Error, Result};

/// Marks our temporary files, so a folder listing shows what they are (the spool removes
/// leftovers by it).
pub const TEMP_SUFFIX: &str = ".antumbra-tmp";

/// The mode a new file is created with before the umask applies, as `open(2)` callers such as
/// `touch` use: the kernel narrows it by the umask, which is process-wide and racy to read.
/// (tempfile's default, 0600, would make every result private whatever the umask.)
#[cfg(unix)]
pub const NEW_FILE_MODE: u32 = 0o666;

/// Target names longer than this (bytes) appear shortened in the temporary's name, with a hash
/// of the whole name: `.` + name + `.` + 6 random characters + [`TEMP_SUFFIX`] must stay within
/// the 255 bytes a file name may have, or a long target could never be written.
const MAX_NAME_IN_TEMP: usize = 200;
/// How much of a long name the temporary's name keeps, so a listing still shows whose it is.
const KEPT_OF_LONG_NAME: usize = 64;

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
        let prefix = temp_prefix(name);
        // Same folder, so the rename cannot cross file systems and is atomic. Errors name the
        // target, not the temporary: its random name would make every failure look new.
        let temp = tempfile::Builder::new()
            .prefix(&prefix)
            .suffix(TEMP_SUFFIX)
            .make_in(&dir, open_new)
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

/// `.NAME.`, or for a long name its first [`KEPT_OF_LONG_NAME`] bytes (whole characters) and a
/// hash of all of it, so the temporary's name fits whatever the target's length.
fn temp_prefix(name: &OsStr) -> OsString {
    let mut prefix = OsString::from(".");
    if name.len() <= MAX_NAME_IN_TEMP {
        prefix.push(name);
    } else {
        let lossy = name.to_string_lossy();
        let mut end = KEPT_OF_LONG_NAME.min(lossy.len());
        while !lossy.is_char_boundary(end) {
            end -= 1;
        }
        let hash = xxhash_rust::xxh3::xxh3_64(name.as_encoded_bytes());
        prefix.push(format!("{}~{hash:016x}", &lossy[..end]));
    }
    prefix.push(".");
    prefix
}

/// Creates a fresh file (never an existing name) with the umask's mode for new files.
fn open_new(path: &Path) -> std::io::Result<File> {
    let mut options = OpenOptions::new();
    options.read(true).write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, NEW_FILE_MODE);
    options.open(path)
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

    /// The umask in force, from `/proc/self/status` (reading it with `umask(2)` would change it
    /// for every thread for a moment).
    #[cfg(target_os = "linux")]
    fn current_umask() -> u32 {
        let status = fs::read_to_string("/proc/self/status").unwrap();
        let line = status.lines().find(|l| l.starts_with("Umask:")).unwrap();
        u32::from_str_radix(line["Umask:".len()..].trim(), 8).unwrap()
    }

    /// A written file has the mode any new file of the user gets (0644 under umask 022), not
    /// the temporary's private 0600.
    #[cfg(target_os = "linux")]
    #[test]
    fn output_atomic_file_gets_the_umask_mode() {
        use std::os::unix::fs::PermissionsExt;
        let dir = TempDir::new().unwrap();
        let target = dir.path().join("frame_0001.exr");
        write_bytes_atomic(&target, b"pixels").unwrap();
        let mode = fs::metadata(&target).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, NEW_FILE_MODE & !current_umask(), "mode {mode:o}");
    }

    /// A name of 250 bytes (the longest a file may have is 255) is written: its temporary's
    /// name is shortened, and an error would name the target, not the temporary.
    #[test]
    fn output_atomic_long_name_is_written() {
        let dir = TempDir::new().unwrap();
        let name = format!("{}.ERROR", "j".repeat(243));
        assert_eq!(name.len(), 249);
        let target = dir.path().join(&name);
        write_bytes_atomic(&target, b"why").unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"why");
        assert_eq!(file_names(dir.path()), vec![name.clone()]);
        let prefix = temp_prefix(OsStr::new(&name));
        assert!(prefix.len() < 100, "{prefix:?}");
        assert!(prefix.to_string_lossy().starts_with(".jjjj"), "{prefix:?}");
        // Two long names with the same beginning get different temporaries.
        let other = format!("{}.DONE", "j".repeat(243));
        assert_ne!(prefix, temp_prefix(OsStr::new(&other)));
    }

    #[test]
    fn output_atomic_error_names_the_target_not_the_temporary() {
        let dir = TempDir::new().unwrap();
        let target = dir.path().join("no_such_folder").join("stats.csv");
        let err = write_atomic(&target, |_| Ok(())).unwrap_err().to_string();
        assert!(err.contains("stats.csv"), "{err}");
        assert!(!err.contains(TEMP_SUFFIX), "{err}");
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
