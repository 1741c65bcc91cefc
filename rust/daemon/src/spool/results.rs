//! A job's results folder, written without ever following a symbolic link: the folder must be
//! a real folder of the daemon's user, each name in it is checked with `symlink_metadata`, and
//! files are created fresh and renamed into place (a rename replaces a link, not its target).

use std::fs::{self, DirBuilder, File};
use std::os::unix::fs::{DirBuilderExt, MetadataExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use antumbra_core::atomic_file::{write_bytes_atomic, TEMP_SUFFIX};
use antumbra_core::output::{frame_stem, write_frame_files, Outputs};
use antumbra_core::render::FrameResult;

use super::prepare::TEMP_PREFIX;
use super::{Manifest, ManifestFrame, DONE_FILE, ERROR_FILE, MANIFEST_FILE};

/// Why a result could not be written or checked.
pub(crate) enum WriteError {
    /// The write failed (permissions, a full disk...): worth retrying.
    Io(String),
    /// A name is not what the daemon writes there (a symbolic link, another user's folder):
    /// never retried, never written through.
    Unsafe(String),
    /// The data cannot be written anywhere (e.g. a file name the file system refuses): the
    /// job fails.
    Invalid(String),
}

impl WriteError {
    pub fn into_message(self) -> String {
        match self {
            WriteError::Io(m) | WriteError::Unsafe(m) | WriteError::Invalid(m) => m,
        }
    }

    fn map_message(self, f: impl FnOnce(String) -> String) -> WriteError {
        match self {
            WriteError::Io(m) => WriteError::Io(f(m)),
            WriteError::Unsafe(m) => WriteError::Unsafe(f(m)),
            WriteError::Invalid(m) => WriteError::Invalid(f(m)),
        }
    }
}

/// A failed write at `path`: retried, unless no retry can cure it.
pub(crate) fn io_error(path: &Path, e: std::io::Error) -> WriteError {
    let message = format!("cannot write {}: {e}", path.display());
    match e.raw_os_error() {
        Some(code) if HOPELESS_OS_ERRORS.contains(&code) => WriteError::Invalid(message),
        _ => WriteError::Io(message),
    }
}

/// Errors of the system that no retry can cure: the name itself is refused (too long, or not a
/// name the file system takes). Waiting on them would stall the spool for ever.
const HOPELESS_OS_ERRORS: [i32; 3] = [libc::ENAMETOOLONG, libc::EILSEQ, libc::EINVAL];

/// The system error code in a message, as `io::Error` spells it: `... (os error 36)`.
fn os_error(message: &str) -> Option<i32> {
    let start = message.rfind("(os error ")? + "(os error ".len();
    let end = start + message[start..].find(')')?;
    message[start..end].parse().ok()
}

/// A failed atomic write of a small file: retried unless the name can never be written.
fn write_failure(e: antumbra_core::Error) -> WriteError {
    let message = format!("cannot write {e}");
    match os_error(&message) {
        Some(code) if HOPELESS_OS_ERRORS.contains(&code) => WriteError::Invalid(message),
        _ => WriteError::Io(message),
    }
}

/// Refuses a symbolic link at `path`, naming it.
pub(crate) fn refuse_link(path: &Path) -> WriteError {
    WriteError::Unsafe(link_message(path))
}

pub(crate) fn link_message(path: &Path) -> String {
    format!(
        "{} is a symbolic link: the spool never follows a link in its folders; remove it",
        path.display()
    )
}

/// `results/<job>/`, checked: a real folder (not a link), owned by the daemon's user and not
/// writable by others. Every write re-checks that the name is still that folder.
pub(crate) struct JobResults {
    dir: PathBuf,
    id: (u64, u64),
}

impl JobResults {
    /// Creates `results/<job>/` (mode 0755) if it does not exist, and checks it.
    pub fn open(dir: &Path) -> Result<JobResults, WriteError> {
        match DirBuilder::new().mode(0o755).create(dir) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(io_error(dir, e)),
        }
        let meta = check_folder(dir)?;
        Ok(JobResults {
            dir: dir.to_path_buf(),
            id: (meta.dev(), meta.ino()),
        })
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// The folder is still the one checked (not replaced by a link since).
    fn verify(&self) -> Result<(), WriteError> {
        let meta = check_folder(&self.dir)?;
        if (meta.dev(), meta.ino()) != self.id {
            return Err(WriteError::Unsafe(format!(
                "{} was replaced while the job ran",
                self.dir.display()
            )));
        }
        Ok(())
    }

    /// Whether `frame` is finished: its folder exists as a real folder. A link or a file under
    /// the frame's name is refused, never counted.
    pub fn frame_done(&self, frame: i32) -> Result<bool, WriteError> {
        let path = self.dir.join(frame_stem(frame));
        match path.symlink_metadata() {
            Ok(m) if m.file_type().is_dir() => Ok(true),
            Ok(m) if m.file_type().is_symlink() => Err(refuse_link(&path)),
            Ok(_) => Err(WriteError::Unsafe(format!(
                "{} is not a folder: the spool writes each frame as a folder; remove it",
                path.display()
            ))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
            Err(e) => Err(WriteError::Io(format!(
                "cannot read {}: {e}",
                path.display()
            ))),
        }
    }

    /// Writes a frame's files into a fresh temporary folder, then renames it into place.
    pub fn write_frame(&self, result: &FrameResult, outputs: &Outputs) -> Result<(), WriteError> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        self.verify()?;
        let stem = frame_stem(result.frame);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let temp = self
            .dir
            .join(format!("{TEMP_PREFIX}{stem}-{}-{n}", std::process::id()));
        let fin = self.dir.join(&stem);
        let write = || -> Result<(), WriteError> {
            // create_dir fails on any existing name, a link included: the folder is ours.
            DirBuilder::new()
                .mode(0o755)
                .create(&temp)
                .map_err(|e| io_error(&temp, e))?;
            write_frame_files(&temp, result, outputs).map_err(|e| self.classify(e))?;
            sync_dir(&temp);
            // Renaming a folder onto a link fails (ENOTDIR) rather than following it.
            fs::rename(&temp, &fin).map_err(|e| io_error(&fin, e))?;
            sync_dir(&self.dir);
            Ok(())
        };
        let r = write();
        if r.is_err() {
            let _ = fs::remove_dir_all(&temp);
        }
        // Errors name the frame's folder, not the temporary: its name changes at every try, and
        // a message that never repeats would be logged as a new failure each time.
        let (temp_name, fin_name) = (temp.display().to_string(), fin.display().to_string());
        r.map_err(|e| e.map_message(|m| m.replace(&temp_name, &fin_name)))
    }

    /// Rebuilds `manifest.json` from the frame folders that exist (real folders only).
    pub fn write_manifest(&self, job: &str, frames: &[i32], done: bool) -> Result<(), WriteError> {
        self.verify()?;
        let mut listed = Vec::new();
        for &f in frames {
            if !self.frame_done(f)? {
                continue;
            }
            let dir = frame_stem(f);
            let path = self.dir.join(&dir);
            let entries = fs::read_dir(&path)
                .map_err(|e| WriteError::Io(format!("cannot read {}: {e}", path.display())))?;
            let mut files: Vec<String> = entries
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            files.sort();
            listed.push(ManifestFrame {
                frame: f,
                dir,
                files,
            });
        }
        let manifest = Manifest {
            job: job.to_string(),
            frames_total: frames.len(),
            done: done && listed.len() == frames.len(),
            frames: listed,
        };
        let text =
            serde_json::to_string_pretty(&manifest).map_err(|e| WriteError::Io(e.to_string()))?;
        self.write_file(MANIFEST_FILE, text.as_bytes())
    }

    pub fn write_done(&self, job: &str, frames: usize) -> Result<(), WriteError> {
        let done = serde_json::json!({ "job": job, "frames": frames });
        self.write_file(DONE_FILE, done.to_string().as_bytes())
    }

    pub fn write_error(&self, message: &str) -> Result<(), WriteError> {
        self.write_file(ERROR_FILE, format!("{message}\n").as_bytes())
    }

    /// A failed frame write is retried only if the folder itself refuses writes (read-only,
    /// gone) or the disk is full; otherwise the frame is at fault (e.g. a name too long) and a
    /// retry would wait for ever.
    fn classify(&self, e: antumbra_core::Error) -> WriteError {
        let message = e.to_string();
        let full =
            os_error(&message).is_some_and(|code| [libc::ENOSPC, libc::EDQUOT].contains(&code));
        if matches!(e, antumbra_core::Error::Io { .. }) && (full || !self.can_write()) {
            WriteError::Io(format!("cannot write {message}"))
        } else {
            WriteError::Invalid(format!("cannot write the frame: {message}"))
        }
    }

    /// Whether a small file can be created and synced in the folder now.
    fn can_write(&self) -> bool {
        static N: AtomicU64 = AtomicU64::new(0);
        let name = format!(
            ".probe-{}-{}{TEMP_SUFFIX}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        );
        let path = self.dir.join(name);
        let ok = fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .and_then(|mut f| {
                std::io::Write::write_all(&mut f, b"probe")?;
                f.sync_all()
            })
            .is_ok();
        let _ = fs::remove_file(&path);
        ok
    }

    /// Writes a small file atomically: a fresh temporary (O_EXCL) renamed over the name, so a
    /// link under the name is replaced, never followed.
    fn write_file(&self, name: &str, bytes: &[u8]) -> Result<(), WriteError> {
        self.verify()?;
        let path = self.dir.join(name);
        write_bytes_atomic(&path, bytes).map_err(write_failure)
    }
}

/// Checks that `dir` is a real folder of the daemon's user that others cannot write into.
fn check_folder(dir: &Path) -> Result<fs::Metadata, WriteError> {
    let meta = dir
        .symlink_metadata()
        .map_err(|e| WriteError::Io(format!("cannot read {}: {e}", dir.display())))?;
    if meta.file_type().is_symlink() {
        return Err(refuse_link(dir));
    }
    if !meta.is_dir() {
        return Err(WriteError::Unsafe(format!(
            "{} is not a folder; remove it",
            dir.display()
        )));
    }
    // SAFETY: geteuid has no preconditions.
    let me = unsafe { libc::geteuid() };
    if meta.uid() != me {
        return Err(WriteError::Unsafe(format!(
            "{} is owned by user {}, not by the daemon's user {me}; remove it or give it to \
             the daemon's user",
            dir.display(),
            meta.uid()
        )));
    }
    if meta.mode() & 0o002 != 0 {
        return Err(WriteError::Unsafe(format!(
            "{} is writable by other users; chmod o-w it",
            dir.display()
        )));
    }
    Ok(meta)
}

/// Writes `results/<job>.ERROR` for a job whose results folder is unsafe (a fresh temporary
/// renamed into `results/`, so nothing is written into the unsafe folder or through a link).
pub(crate) fn write_refusal(
    results_root: &Path,
    job: &str,
    message: &str,
) -> Result<(), WriteError> {
    let path = refusal_path(results_root, job);
    write_bytes_atomic(&path, format!("{message}\n").as_bytes()).map_err(write_failure)
}

pub(crate) fn refusal_path(results_root: &Path, job: &str) -> PathBuf {
    results_root.join(format!("{job}.{ERROR_FILE}"))
}

/// Whether a regular file (not a link) is at `path`.
pub(crate) fn is_file(path: &Path) -> bool {
    path.symlink_metadata().is_ok_and(|m| m.is_file())
}

pub(crate) fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spool_os_error_is_read_from_the_message() {
        assert_eq!(
            os_error("x: File name too long (os error 36)"),
            Some(libc::ENAMETOOLONG)
        );
        assert_eq!(os_error("x (os error 2): y (os error 13)"), Some(13));
        assert_eq!(os_error("no code here"), None);
    }

    #[test]
    fn spool_name_too_long_is_not_retried() {
        let path = Path::new("results/x");
        let e = std::io::Error::from_raw_os_error(libc::ENAMETOOLONG);
        assert!(matches!(io_error(path, e), WriteError::Invalid(_)));
        let e = std::io::Error::from_raw_os_error(libc::EROFS);
        assert!(matches!(io_error(path, e), WriteError::Io(_)));
        let e = antumbra_core::Error::io("r/x.ERROR", std::io::Error::from_raw_os_error(36));
        assert!(matches!(write_failure(e), WriteError::Invalid(_)));
        let e = antumbra_core::Error::io("r/x.ERROR", std::io::Error::from_raw_os_error(13));
        assert!(matches!(write_failure(e), WriteError::Io(_)));
    }
}
