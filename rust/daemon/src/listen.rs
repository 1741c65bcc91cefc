//! Where the daemon listens: a Unix domain socket (0600 in a 0700 folder), optionally a loopback
//! TCP port guarded by a token. The connection type both give, [`Conn`], is the client's too.

use std::fs;
use std::io;
use std::net::{SocketAddr, TcpListener, ToSocketAddrs};
use std::os::unix::fs::{DirBuilderExt, FileTypeExt, MetadataExt, PermissionsExt};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};

use crate::error::DaemonError;
pub use antumbra_protocol::client::Conn;

/// `$XDG_RUNTIME_DIR/antumbra/daemon.sock`, or `/tmp/antumbra-$UID/daemon.sock` when
/// `XDG_RUNTIME_DIR` is unset or empty.
pub fn default_socket_path() -> PathBuf {
    match std::env::var_os("XDG_RUNTIME_DIR").filter(|v| !v.is_empty()) {
        Some(dir) => PathBuf::from(dir).join("antumbra").join("daemon.sock"),
        None => {
            // SAFETY: getuid has no preconditions and cannot fail.
            let uid = unsafe { libc::getuid() };
            PathBuf::from(format!("/tmp/antumbra-{uid}")).join("daemon.sock")
        }
    }
}

/// Creates the socket's folder with mode 0700 if it does not exist. An existing folder must be
/// ours; if it is, its mode is narrowed to 0700 when it is the default `antumbra` folder.
fn prepare_socket_dir(socket: &Path) -> Result<(), DaemonError> {
    let Some(dir) = socket.parent().filter(|d| !d.as_os_str().is_empty()) else {
        return Ok(());
    };
    if !dir.exists() {
        fs::DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(dir)
            .map_err(|e| DaemonError::path(dir, format!("cannot create the socket folder: {e}")))?;
        return Ok(());
    }
    // Not followed: a link planted at the folder would take our chmod and our socket elsewhere.
    let meta = fs::symlink_metadata(dir).map_err(|e| DaemonError::path(dir, e.to_string()))?;
    if meta.file_type().is_symlink() {
        return Err(DaemonError::path(
            dir,
            "the socket folder is a symbolic link; remove it, or give --socket a path in a \
             folder of your own",
        ));
    }
    if !meta.is_dir() {
        return Err(DaemonError::path(
            dir,
            "the socket's parent is not a folder",
        ));
    }
    let is_default_dir = dir
        .file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n == "antumbra" || n.starts_with("antumbra-"));
    // Others who may write the folder could replace the socket and read a client's Hello; the
    // sticky bit (as on /tmp) stops them. The default folder is ours and narrowed to 0700 below.
    const STICKY: u32 = 0o1000;
    if !is_default_dir && meta.mode() & 0o022 != 0 && meta.mode() & STICKY == 0 {
        return Err(DaemonError::path(
            dir,
            format!(
                "the socket folder is writable by other users (mode {:o}) and not sticky; \
                 chmod go-w it, or give --socket a path in a folder of your own",
                meta.mode() & 0o7777
            ),
        ));
    }
    // SAFETY: getuid has no preconditions and cannot fail.
    let uid = unsafe { libc::getuid() };
    // Whoever owns the folder can replace the socket: it must be us, or root (as /tmp).
    if !is_default_dir && meta.uid() != uid && meta.uid() != 0 {
        return Err(DaemonError::path(
            dir,
            format!(
                "the socket folder belongs to uid {}, not to this user (uid {uid}); give \
                 --socket a path in a folder of your own",
                meta.uid()
            ),
        ));
    }
    if is_default_dir {
        if meta.uid() != uid {
            return Err(DaemonError::path(
                dir,
                format!(
                    "the socket folder belongs to uid {}, not to this user (uid {uid})",
                    meta.uid()
                ),
            ));
        }
        if meta.mode() & 0o077 != 0 {
            fs::set_permissions(dir, fs::Permissions::from_mode(0o700))
                .map_err(|e| DaemonError::path(dir, format!("cannot chmod 0700: {e}")))?;
        }
    }
    Ok(())
}

/// The bound Unix socket and the identity of its file, so that only our own socket file is
/// removed at exit.
pub struct BoundUnix {
    pub listener: UnixListener,
    pub path: PathBuf,
    dev_ino: (u64, u64),
}

impl BoundUnix {
    /// Removes the socket file if it is still the one this daemon created.
    pub fn remove_file(&self) {
        if let Ok(meta) = fs::symlink_metadata(&self.path) {
            if (meta.dev(), meta.ino()) == self.dev_ino {
                let _ = fs::remove_file(&self.path);
            }
        }
    }
}

/// Binds the Unix socket at `path`:
/// - a stale socket file (nothing answers on it) is removed first;
/// - a socket on which a daemon answers is an error ([`DaemonError::AlreadyRunning`]);
/// - any other file at `path` is an error ([`DaemonError::NotASocket`]).
///
/// The socket file is made mode 0600 right after `bind`, and its folder is created 0700.
pub fn bind_unix(path: &Path) -> Result<BoundUnix, DaemonError> {
    prepare_socket_dir(path)?;
    match fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_socket() => match UnixStream::connect(path) {
            Ok(_) => {
                return Err(DaemonError::AlreadyRunning {
                    path: path.to_path_buf(),
                })
            }
            Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {
                tracing::info!(path = %path.display(), "removing stale socket file");
                fs::remove_file(path).map_err(|e| {
                    DaemonError::path(path, format!("cannot remove the stale socket: {e}"))
                })?;
            }
            Err(e) => {
                return Err(DaemonError::path(
                    path,
                    format!("a socket exists and cannot be probed ({e}); refusing to replace it"),
                ))
            }
        },
        Ok(_) => {
            return Err(DaemonError::NotASocket {
                path: path.to_path_buf(),
            })
        }
        Err(e) if e.kind() == io::ErrorKind::NotFound => {}
        Err(e) => return Err(DaemonError::path(path, e.to_string())),
    }
    let listener = UnixListener::bind(path)
        .map_err(|e| DaemonError::path(path, format!("cannot bind: {e}")))?;
    fs::set_permissions(path, fs::Permissions::from_mode(0o600)).map_err(|e| {
        let _ = fs::remove_file(path);
        DaemonError::path(path, format!("cannot chmod 0600: {e}"))
    })?;
    let meta = fs::symlink_metadata(path).map_err(|e| DaemonError::path(path, e.to_string()))?;
    listener
        .set_nonblocking(true)
        .map_err(|e| DaemonError::io("socket", e))?;
    Ok(BoundUnix {
        listener,
        path: path.to_path_buf(),
        dev_ino: (meta.dev(), meta.ino()),
    })
}

/// Parses a TCP listen address: `IP:PORT` or `localhost:PORT`. Every address it resolves to
/// must be loopback.
pub fn parse_tcp_addr(text: &str) -> Result<SocketAddr, DaemonError> {
    let addrs: Vec<SocketAddr> = match text.parse::<SocketAddr>() {
        Ok(a) => vec![a],
        Err(_) => {
            let (host, _) = text.rsplit_once(':').ok_or_else(|| {
                DaemonError::Config(format!(
                    "--tcp: '{text}' is not an address like 127.0.0.1:7878"
                ))
            })?;
            if host != "localhost" {
                return Err(DaemonError::NotLoopback { addr: text.into() });
            }
            text.to_socket_addrs()
                .map_err(|e| DaemonError::Config(format!("--tcp: '{text}': {e}")))?
                .collect()
        }
    };
    match addrs.iter().find(|a| !a.ip().is_loopback()) {
        Some(_) => Err(DaemonError::NotLoopback { addr: text.into() }),
        None => addrs
            .first()
            .copied()
            .ok_or_else(|| DaemonError::Config(format!("--tcp: '{text}' resolves to nothing"))),
    }
}

/// Binds a loopback TCP listener; any other address is refused.
pub fn bind_tcp(addr: SocketAddr) -> Result<TcpListener, DaemonError> {
    if !addr.ip().is_loopback() {
        return Err(DaemonError::NotLoopback {
            addr: addr.to_string(),
        });
    }
    let listener =
        TcpListener::bind(addr).map_err(|e| DaemonError::io(format!("binding {addr}"), e))?;
    listener
        .set_nonblocking(true)
        .map_err(|e| DaemonError::io("tcp socket", e))?;
    Ok(listener)
}

/// Reads a token file: its content with surrounding whitespace trimmed, which must not be empty.
/// Warns when the file is readable by other users.
pub fn read_token_file(path: &Path) -> Result<String, DaemonError> {
    let text = fs::read_to_string(path)
        .map_err(|e| DaemonError::path(path, format!("cannot read the token file: {e}")))?;
    let token = text.trim().to_string();
    if token.is_empty() {
        return Err(DaemonError::path(path, "the token file is empty"));
    }
    if let Ok(meta) = fs::metadata(path) {
        if meta.mode() & 0o077 != 0 {
            tracing::warn!(
                path = %path.display(),
                mode = format!("{:o}", meta.mode() & 0o777),
                "the token file is readable by other users; chmod 600 it"
            );
        }
    }
    Ok(token)
}

/// Compares two secrets in time that depends only on their lengths, not on where they differ.
pub fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    let mut diff = (a.len() ^ b.len()) as u64;
    // Walk the expected length whatever the given one, so the time does not tell a prefix.
    for (i, &y) in b.iter().enumerate() {
        let x = a.get(i).copied().unwrap_or(0);
        diff |= (x ^ y) as u64;
    }
    std::hint::black_box(diff) == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(p: &Path) -> u32 {
        fs::metadata(p).unwrap().mode() & 0o7777
    }

    #[test]
    fn a_symlinked_socket_folder_is_refused_and_its_target_untouched() {
        let tmp = tempfile::tempdir().unwrap();
        let target = tmp.path().join("elsewhere");
        fs::create_dir(&target).unwrap();
        fs::set_permissions(&target, fs::Permissions::from_mode(0o755)).unwrap();
        let link = tmp.path().join("antumbra");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        let err = bind_unix(&link.join("daemon.sock"))
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("symbolic link"), "{err}");
        assert_eq!(mode(&target), 0o755, "the link's target was changed");
        assert!(!target.join("daemon.sock").exists());
    }

    #[test]
    fn a_folder_others_can_write_is_refused_unless_sticky() {
        let tmp = tempfile::tempdir().unwrap();
        let open = tmp.path().join("open");
        fs::create_dir(&open).unwrap();
        fs::set_permissions(&open, fs::Permissions::from_mode(0o777)).unwrap();
        let err = bind_unix(&open.join("d.sock")).err().unwrap().to_string();
        assert!(err.contains("writable by other users"), "{err}");
        // With the sticky bit (as /tmp) no other user can replace our socket file.
        fs::set_permissions(&open, fs::Permissions::from_mode(0o1777)).unwrap();
        let bound = bind_unix(&open.join("d.sock")).unwrap();
        bound.remove_file();
    }

    #[test]
    fn constant_time_eq_compares() {
        assert!(constant_time_eq(b"secret", b"secret"));
        assert!(!constant_time_eq(b"secreT", b"secret"));
        assert!(!constant_time_eq(b"secre", b"secret"));
        assert!(!constant_time_eq(b"secrets", b"secret"));
        assert!(!constant_time_eq(b"", b"secret"));
        assert!(constant_time_eq(b"", b""));
    }

    #[test]
    fn tcp_addresses_must_be_loopback() {
        assert!(parse_tcp_addr("127.0.0.1:7878").is_ok());
        assert!(parse_tcp_addr("[::1]:7878").is_ok());
        assert!(parse_tcp_addr("localhost:7878").is_ok());
        for bad in [
            "0.0.0.0:7878",
            "192.168.1.2:7878",
            "[::]:7878",
            "example.com:7878",
        ] {
            assert!(
                matches!(parse_tcp_addr(bad), Err(DaemonError::NotLoopback { .. })),
                "{bad}"
            );
        }
        assert!(bind_tcp("0.0.0.0:0".parse().unwrap()).is_err());
    }
}
