//! Job ids: the folder names in `jobs/`, what a client may choose, and how a name that is not
//! UTF-8 is shown (its results, `ERROR` included, go under that readable name).

use std::ffi::{OsStr, OsString};
use std::os::unix::ffi::OsStrExt;

use super::ERROR_FILE;

/// The longest job id, in bytes: `results/<id>.ERROR` (a refused job's end) must be a file name
/// the file system takes (255 bytes).
pub const MAX_JOB_ID_BYTES: usize = 255 - 1 - ERROR_FILE.len();

/// A job folder's name as read from `jobs/`.
pub(crate) struct JobName {
    /// The folder's name as the file system has it.
    pub os: OsString,
    /// The name for people, logs and the results folder: the name itself when it is UTF-8,
    /// else its UTF-8 parts with every other byte as `\xNN` (the same bytes give the same id).
    pub id: String,
}

impl JobName {
    pub fn new(os: OsString) -> JobName {
        let id = readable(&os);
        JobName { os, id }
    }

    /// Whether the folder's name is UTF-8 (the only kind the spool renders).
    pub fn is_utf8(&self) -> bool {
        self.os.to_str().is_some()
    }
}

/// `name` with each byte that is not part of UTF-8 text written `\xNN`.
fn readable(name: &OsStr) -> String {
    let mut text = String::new();
    for chunk in name.as_bytes().utf8_chunks() {
        text.push_str(chunk.valid());
        for b in chunk.invalid() {
            text.push_str(&format!("\\x{b:02X}"));
        }
    }
    text
}

/// Checks a job id a client chooses: a plain folder name that is not hidden, short enough
/// for every file the spool names after it.
pub fn check_job_id(id: &str) -> Result<(), String> {
    if id.is_empty() || id.starts_with('.') || id.contains(['/', '\\', '\0']) {
        return Err(format!(
            "job id '{id}': must be a plain folder name (no '/', '\\', or leading '.')"
        ));
    }
    if id.len() > MAX_JOB_ID_BYTES {
        return Err(format!(
            "job id '{id}': {} bytes long, at most {MAX_JOB_ID_BYTES} (results/<id>.{ERROR_FILE} \
             must fit in a file name)",
            id.len()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::ffi::OsStringExt;

    #[test]
    fn spool_name_not_utf8_is_escaped_stably() {
        let name = JobName::new(OsString::from_vec(b"shot-\xff\xfe-a\xc3\xa9".to_vec()));
        assert_eq!(name.id, "shot-\\xFF\\xFE-a\u{e9}");
        assert!(!name.is_utf8());
        let plain = JobName::new(OsString::from("shot-01"));
        assert_eq!(plain.id, "shot-01");
        assert!(plain.is_utf8());
    }

    #[test]
    fn spool_job_id_length_is_bounded() {
        assert_eq!(MAX_JOB_ID_BYTES, 249);
        assert!(check_job_id(&"a".repeat(249)).is_ok());
        let e = check_job_id(&"a".repeat(250)).unwrap_err();
        assert!(e.contains("250 bytes long, at most 249"), "{e}");
        assert!(check_job_id(".hidden").is_err());
        assert!(check_job_id("a/b").is_err());
    }
}
