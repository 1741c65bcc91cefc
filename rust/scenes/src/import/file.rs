//! Opening what an import reads: regular files only, sized before they are read, and glTF URIs
//! kept inside the file's folder.

use std::fs::File;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

use antumbra_core::Error;

use super::limits::{check, ImportLimits, Totals};

/// Opens `path` for reading if it is (or links to) a regular file that fits what is left of
/// the byte budget; `Err` of an I/O error when it cannot be read, of a message otherwise.
/// A device, FIFO or socket is refused before it is opened: opening a FIFO waits for a writer,
/// and `/dev/zero` never ends.
pub(super) fn open_regular(
    path: &Path,
    totals: &mut Totals,
    limits: &ImportLimits,
) -> Result<(File, u64), Error> {
    let invalid = |message: String| Error::invalid(path.display().to_string(), message);
    // `metadata` follows links, so a link is judged by what it points to.
    let metadata = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    regular(&metadata).map_err(invalid)?;
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    // Again on the open file: the path may have been replaced in between.
    let metadata = file.metadata().map_err(|e| Error::io(path, e))?;
    regular(&metadata).map_err(invalid)?;
    let size = metadata.len();
    totals
        .add_bytes("file size", size, limits)
        .map_err(invalid)?;
    Ok((file, size))
}

fn regular(metadata: &std::fs::Metadata) -> Result<(), String> {
    if metadata.is_file() {
        Ok(())
    } else if metadata.is_dir() {
        Err("is a folder, not a regular file".into())
    } else {
        Err("not a regular file (a device, FIFO or socket, or a link to one)".into())
    }
}

/// The whole of a file opened by [`open_regular`] of `size` bytes, refusing one that grew past
/// the byte budget while it was read.
pub(super) fn read_all(
    file: File,
    size: u64,
    what: &str,
    limits: &ImportLimits,
) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(limits.max_file_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| format!("{what}: cannot read: {e}"))?;
    check(
        &format!("{what}: size"),
        bytes.len() as u64,
        limits.max_file_bytes,
        "max_file_bytes",
    )?;
    Ok(bytes)
}

/// The file a glTF's relative URI names inside `folder`, as a viewer resolves it: no scheme,
/// no absolute path, no `..`, and (links resolved) still inside `folder`. `what` names the
/// buffer in errors; the URI itself is not echoed, it may have been made to show bytes.
pub(super) fn resolve_in_folder(folder: &Path, uri: &str, what: &str) -> Result<PathBuf, String> {
    let refuse = |why: &str| {
        Err(format!(
            "{what}: the URI {why}; only data: URIs and paths inside the file's folder are read"
        ))
    };
    if has_scheme(uri) {
        return refuse("has a scheme");
    }
    let Some(decoded) = percent_decode(uri) else {
        return refuse("is not valid percent-encoded UTF-8");
    };
    if decoded.is_empty() || decoded.contains(['\\', '\0']) {
        return refuse("is empty or holds a backslash or NUL");
    }
    let relative = Path::new(&decoded);
    for component in relative.components() {
        match component {
            Component::Normal(_) | Component::CurDir => {}
            Component::ParentDir => return refuse("climbs out with '..'"),
            Component::RootDir | Component::Prefix(_) => return refuse("is an absolute path"),
        }
    }
    let joined = folder.join(relative);
    let inside = std::fs::canonicalize(folder)
        .map_err(|e| format!("{what}: the file's folder cannot be resolved: {e}"))?;
    let resolved =
        std::fs::canonicalize(&joined).map_err(|e| format!("{what}: {}: {e}", joined.display()))?;
    if !resolved.starts_with(&inside) {
        return refuse("leads out of the folder through a link");
    }
    Ok(resolved)
}

/// `scheme:` at the start (RFC 3986: a letter, then letters, digits, `+`, `-` or `.`); a
/// Windows drive (`C:`) counts as one too.
fn has_scheme(uri: &str) -> bool {
    match uri.split_once(':') {
        Some((scheme, _)) => {
            let mut chars = scheme.chars();
            chars.next().is_some_and(|c| c.is_ascii_alphabetic())
                && chars.all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
        }
        None => false,
    }
}

/// `%XX` escapes decoded; `None` for a bad escape or bytes that are not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3)?;
            // Checked first: `from_str_radix` would take a sign ("%+f").
            if !hex.iter().all(u8::is_ascii_hexdigit) {
                return None;
            }
            out.push(u8::from_str_radix(std::str::from_utf8(hex).ok()?, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_are_decoded_and_schemes_spotted() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("%2E%2E/x").as_deref(), Some("../x"));
        assert_eq!(percent_decode("bad%2"), None);
        assert_eq!(percent_decode("bad%zz"), None);
        assert_eq!(percent_decode("%ff"), None);
        assert_eq!(percent_decode("%+f"), None);
        assert!(has_scheme("file:///etc/passwd"));
        assert!(has_scheme("C:/x.bin"));
        assert!(has_scheme("https://example.com/x.bin"));
        assert!(!has_scheme("x.bin"));
        assert!(!has_scheme("dir/x:y.bin"));
        assert!(!has_scheme(":x"));
    }
}
