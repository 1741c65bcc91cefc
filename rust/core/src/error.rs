//! One error type for everything a user can get wrong; every message names the object, frame or
//! field at fault so it can be shown as is in Blender or on the command line.

use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    /// Non-finite (NaN or infinite) number in the input.
    #[error("{what} of {owner} has a non-finite value ({value}) at index {index}")]
    NonFinite {
        owner: String,
        what: &'static str,
        index: usize,
        value: f64,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("mesh '{mesh}': triangle {triangle} refers to vertex {vertex}, but the mesh has {vertex_count} vertices")]
    IndexOutOfRange {
        mesh: String,
        triangle: usize,
        vertex: u32,
        vertex_count: usize,
    },
    /// An object refers to a mesh that does not exist.
    #[error("object '{object}' refers to mesh {mesh}, but the scene has {mesh_count} meshes")]
    UnknownMesh {
        object: String,
        mesh: usize,
        mesh_count: usize,
    },
    /// A setting or scene field outside its valid range.
    #[error("{field}: {message}")]
    Invalid { field: String, message: String },
    /// Files that could not be read or written.
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    /// The render was stopped through its [`crate::cancel::CancelToken`].
    #[error("the render was cancelled")]
    Cancelled,
}

impl Error {
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }

    pub fn io(path: impl AsRef<std::path::Path>, err: impl std::fmt::Display) -> Self {
        Error::Io {
            path: path.as_ref().display().to_string(),
            message: err.to_string(),
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;
