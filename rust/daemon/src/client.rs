//! A small blocking client of the protocol, for tests and tools: connect, say Hello, send scenes
//! (uploading only the meshes the daemon lacks) and render them. Counts the bytes it sends.

use std::collections::HashSet;
use std::io::{self, BufReader, BufWriter, Write};
use std::net::{Shutdown, SocketAddr, TcpStream};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::time::Duration;

use antumbra_core::scene::Scene;
use antumbra_protocol::{
    encode_message, frame_update_from_scene, read_message, upload_from_mesh, ErrorCode, FrameError,
    FrameResultReply, Limits, NamedSettings, Passes, ProtocolError, RenderRequest, Reply, Request,
    PROTOCOL_VERSION,
};
use thiserror::Error;

use crate::listen::Conn;

#[derive(Debug, Error)]
pub enum ClientError {
    #[error(transparent)]
    Frame(#[from] FrameError),
    #[error(transparent)]
    Io(#[from] io::Error),
    #[error(transparent)]
    Protocol(#[from] ProtocolError),
    #[error("daemon replied {code:?}: {message}")]
    Daemon {
        code: ErrorCode,
        message: String,
        session_usable: bool,
        request_id: Option<u64>,
    },
    #[error("unexpected reply {0}")]
    Unexpected(String),
}

impl ClientError {
    fn from_reply(reply: Reply) -> Self {
        match reply {
            Reply::Error {
                code,
                message,
                session_usable,
                request_id,
            } => ClientError::Daemon {
                code,
                message,
                session_usable,
                request_id,
            },
            other => ClientError::Unexpected(format!("{other:?}").chars().take(200).collect()),
        }
    }

    /// The error code when the daemon answered with an error.
    pub fn code(&self) -> Option<ErrorCode> {
        match self {
            ClientError::Daemon { code, .. } => Some(*code),
            _ => None,
        }
    }
}

/// What sending a scene cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneSent {
    pub meshes_uploaded: usize,
    /// Bytes of `UploadMesh` frames sent.
    pub upload_bytes: u64,
    /// All bytes sent for the scene (questions, uploads, the frame update).
    pub bytes: u64,
}

/// A rendered frame and the progress stages seen before it.
#[derive(Clone, Debug)]
pub struct Rendered {
    pub result: FrameResultReply,
    pub stages: Vec<String>,
}

pub struct Client {
    reader: BufReader<Conn>,
    writer: BufWriter<Conn>,
    /// The daemon's limits (from `Welcome`; the defaults until then).
    pub limits: Limits,
    pub bytes_sent: u64,
}

impl Client {
    fn new(conn: Conn) -> io::Result<Self> {
        let w = conn.try_clone()?;
        Ok(Client {
            reader: BufReader::with_capacity(256 * 1024, conn),
            writer: BufWriter::with_capacity(256 * 1024, w),
            limits: Limits::default(),
            bytes_sent: 0,
        })
    }

    pub fn connect_unix(path: &Path) -> io::Result<Self> {
        Client::new(Conn::Unix(UnixStream::connect(path)?))
    }

    pub fn connect_tcp(addr: SocketAddr) -> io::Result<Self> {
        let s = TcpStream::connect(addr)?;
        s.set_nodelay(true)?;
        Client::new(Conn::Tcp(s))
    }

    /// Read and write timeouts (none by default).
    pub fn set_timeout(&self, t: Option<Duration>) -> io::Result<()> {
        self.reader.get_ref().set_read_timeout(t)?;
        self.writer.get_ref().set_write_timeout(t)
    }

    pub fn send(&mut self, request: &Request) -> Result<(), ClientError> {
        let bytes = encode_message(request)?;
        self.send_raw(&bytes)?;
        Ok(())
    }

    /// Sends bytes as they are (for malformed input in tests).
    pub fn send_raw(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.writer.write_all(bytes)?;
        self.writer.flush()?;
        self.bytes_sent += bytes.len() as u64;
        Ok(())
    }

    /// Closes the sending side (the daemon sees the end of the stream).
    pub fn shutdown_write(&mut self) -> io::Result<()> {
        self.writer.flush()?;
        self.writer.get_ref().shutdown(Shutdown::Write)
    }

    pub fn recv(&mut self) -> Result<Reply, ClientError> {
        Ok(read_message(&mut self.reader, &self.limits)?)
    }

    /// Sends a request and reads one reply.
    pub fn call(&mut self, request: &Request) -> Result<Reply, ClientError> {
        self.send(request)?;
        self.recv()
    }

    /// `Hello`; returns the daemon's limits (also kept in `self.limits`).
    pub fn hello(&mut self, client: &str, token: Option<&str>) -> Result<Limits, ClientError> {
        let reply = self.call(&Request::Hello {
            version: PROTOCOL_VERSION,
            client: client.into(),
            token: token.map(str::to_string),
        })?;
        match reply {
            Reply::Welcome { limits, .. } => {
                self.limits = limits.clone();
                Ok(limits)
            }
            other => Err(ClientError::from_reply(other)),
        }
    }

    /// Sends one frame's scene: asks which meshes are missing, uploads those, then sends the
    /// `FrameUpdate` (which must come back with nothing missing).
    pub fn send_scene(&mut self, scene: &Scene) -> Result<SceneSent, ClientError> {
        let start = self.bytes_sent;
        let update = frame_update_from_scene(scene)?;
        let mut seen = HashSet::new();
        let hashes: Vec<u64> = update
            .objects
            .iter()
            .map(|o| o.mesh_hash)
            .filter(|h| seen.insert(*h))
            .collect();
        let missing = match self.call(&Request::MissingMeshes {
            hashes: hashes.clone(),
        })? {
            Reply::Missing { hashes } => hashes,
            other => return Err(ClientError::from_reply(other)),
        };
        let mut sent = SceneSent::default();
        for h in missing {
            let Some(mesh) = scene.meshes.iter().find(|m| m.content_hash() == h) else {
                return Err(ClientError::Unexpected(format!(
                    "the daemon asked for mesh {h:#x}, which the scene does not have"
                )));
            };
            let before = self.bytes_sent;
            match self.call(&Request::UploadMesh(upload_from_mesh(mesh)))? {
                Reply::MeshStored { .. } => {}
                other => return Err(ClientError::from_reply(other)),
            }
            sent.meshes_uploaded += 1;
            sent.upload_bytes += self.bytes_sent - before;
        }
        match self.call(&Request::FrameUpdate(update))? {
            Reply::FrameAccepted { meshes_missing, .. } if meshes_missing.is_empty() => {}
            Reply::FrameAccepted { meshes_missing, .. } => {
                return Err(ClientError::Unexpected(format!(
                    "meshes still missing after upload: {meshes_missing:x?}"
                )))
            }
            other => return Err(ClientError::from_reply(other)),
        }
        sent.bytes = self.bytes_sent - start;
        Ok(sent)
    }

    /// Renders a frame sent before; reads `Progress` replies until the result.
    pub fn render(
        &mut self,
        frame: i32,
        settings: NamedSettings,
        passes: Passes,
        request_id: u64,
    ) -> Result<Rendered, ClientError> {
        self.send(&Request::Render(RenderRequest {
            frame,
            settings,
            passes,
            request_id,
        }))?;
        self.finish_render(request_id)
    }

    /// Reads the replies of render `request_id` up to its result or error.
    pub fn finish_render(&mut self, request_id: u64) -> Result<Rendered, ClientError> {
        let mut stages = Vec::new();
        loop {
            match self.recv()? {
                Reply::Progress {
                    request_id: r,
                    stage,
                    ..
                } if r == request_id => stages.push(stage),
                Reply::FrameResult(result) if result.request_id == request_id => {
                    return Ok(Rendered { result, stages })
                }
                other => return Err(ClientError::from_reply(other)),
            }
        }
    }

    /// `Close`, waiting for its `Ack`.
    pub fn close(mut self) -> Result<(), ClientError> {
        match self.call(&Request::Close)? {
            Reply::Ack => Ok(()),
            other => Err(ClientError::from_reply(other)),
        }
    }
}
