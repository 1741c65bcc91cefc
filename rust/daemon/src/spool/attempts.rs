//! `attempts.log`: one synced line per frame start, written before the frame renders, so a
//! frame that kills the daemon (out of memory, a crash) is known at the next start.

use std::collections::HashMap;
use std::fs::OpenOptions;
use std::io::{Read, Write};
use std::os::unix::fs::OpenOptionsExt;

use super::results::{io_error, refuse_link, sync_dir, JobResults, WriteError};

pub const ATTEMPTS_FILE: &str = "attempts.log";
/// The line `antumbra spool resume` appends.
const RESUME: &str = "resume";
/// More than any real log holds (a line per start); a larger file is read only this far.
const MAX_BYTES: u64 = 1 << 20;

/// The frames started and not cleanly stopped, by frame, as `attempts.log` records them.
pub(crate) struct Attempts {
    starts: HashMap<i32, u32>,
}

impl Attempts {
    /// Reads the job's `attempts.log` (none yet: no starts). Lines are `start F ...`,
    /// `stopped F` (a clean stop while the frame was under way, which takes one start back) and
    /// `resume ...` (`antumbra spool resume`: every start before it is forgiven); a torn last
    /// line of a killed daemon parses as nothing.
    pub fn load(results: &JobResults) -> Result<Attempts, WriteError> {
        let path = results.path(ATTEMPTS_FILE);
        let mut text = String::new();
        match OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
            .open(&path)
        {
            Ok(f) => {
                if !f.metadata().is_ok_and(|m| m.is_file()) {
                    return Err(not_regular(&path));
                }
                f.take(MAX_BYTES)
                    .read_to_string(&mut text)
                    .map_err(|e| WriteError::Io(format!("cannot read {}: {e}", path.display())))?;
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) if e.raw_os_error() == Some(libc::ELOOP) => return Err(refuse_link(&path)),
            Err(e) => {
                return Err(WriteError::Io(format!(
                    "cannot read {}: {e}",
                    path.display()
                )));
            }
        }
        let mut starts: HashMap<i32, u32> = HashMap::new();
        for line in text.lines() {
            if line.split_whitespace().next() == Some(RESUME) {
                starts.clear();
                continue;
            }
            let mut words = line.split_whitespace();
            let (Some(what), Some(Ok(frame))) = (words.next(), words.next().map(str::parse)) else {
                continue;
            };
            let n = starts.entry(frame).or_default();
            match what {
                "start" => *n += 1,
                "stopped" => *n = n.saturating_sub(1),
                _ => {}
            }
        }
        Ok(Attempts { starts })
    }

    /// Starts of `frame` that did not finish.
    pub fn starts(&self, frame: i32) -> u32 {
        self.starts.get(&frame).copied().unwrap_or(0)
    }

    /// Records that `frame` starts now, on disk (synced) before it renders.
    pub fn record_start(&mut self, results: &JobResults, frame: i32) -> Result<(), WriteError> {
        let line = format!(
            "start {frame} pid={} unix_s={}\n",
            std::process::id(),
            unix_s()
        );
        append(results, &line)?;
        *self.starts.entry(frame).or_default() += 1;
        Ok(())
    }

    /// Records that a person resumed the job: the starts so far no longer count against it.
    pub fn record_resume(results: &JobResults) -> Result<(), WriteError> {
        append(
            results,
            &format!("{RESUME} pid={} unix_s={}\n", std::process::id(), unix_s()),
        )
    }

    /// Records that the daemon stopped cleanly while `frame` was under way: not a failure.
    /// Best effort: at worst the frame keeps one start too many.
    pub fn record_stopped(&mut self, results: &JobResults, frame: i32) {
        if append(results, &format!("stopped {frame}\n")).is_ok() {
            let n = self.starts.entry(frame).or_default();
            *n = n.saturating_sub(1);
        }
    }
}

fn unix_s() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Appends a line to `attempts.log` and syncs it (and the folder, which may have got the file).
fn append(results: &JobResults, line: &str) -> Result<(), WriteError> {
    let path = results.path(ATTEMPTS_FILE);
    match path.symlink_metadata() {
        Ok(m) if m.file_type().is_symlink() => return Err(refuse_link(&path)),
        Ok(m) if !m.is_file() => return Err(not_regular(&path)),
        _ => {}
    }
    // O_NOFOLLOW: a link planted after the check above fails the open (ELOOP).
    let mut f = OpenOptions::new()
        .append(true)
        .create(true)
        .mode(0o644)
        .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
        .open(&path)
        .map_err(|e| match e.raw_os_error() {
            Some(libc::ELOOP) => refuse_link(&path),
            _ => io_error(&path, e),
        })?;
    if !f.metadata().is_ok_and(|m| m.is_file()) {
        return Err(not_regular(&path));
    }
    f.write_all(line.as_bytes())
        .and_then(|()| f.sync_data())
        .map_err(|e| io_error(&path, e))?;
    if let Some(dir) = path.parent() {
        sync_dir(dir);
    }
    Ok(())
}

fn not_regular(path: &std::path::Path) -> WriteError {
    WriteError::Unsafe(format!(
        "{} is not a regular file; remove it",
        path.display()
    ))
}
