//! Where a scene comes from: a built-in generator by name, an OBJ/glTF file by path, or a
//! session recording (`.antrec`, written by `antumbra serve --record`) replayed frame by frame.

use std::path::Path;

use antumbra_core::scene::Animation;
use antumbra_protocol::RecordedAnimation;
use antumbra_scenes::{builtin, load_file, SceneParams};
use anyhow::{bail, Result};

/// What a scene argument names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneKind {
    Builtin,
    /// An OBJ/glTF file: one static scene.
    File,
    /// A session recording: its own frames, each with its camera.
    Recording,
}

impl SceneKind {
    /// A name with an extension or a slash is a path; `.antrec` is a recording.
    pub fn of(name_or_path: &str) -> SceneKind {
        let path = Path::new(name_or_path);
        match path.extension() {
            Some(e) if e.eq_ignore_ascii_case("antrec") => SceneKind::Recording,
            Some(_) => SceneKind::File,
            None if name_or_path.contains('/') => SceneKind::File,
            None => SceneKind::Builtin,
        }
    }
}

/// Opens a scene; `triangles`, `instances` and `frames` size a built-in one (see
/// [`SceneParams`]), and `instances` is refused for files and recordings.
pub fn open_scene(
    name_or_path: &str,
    triangles: usize,
    instances: Option<usize>,
    frames: i32,
) -> Result<Box<dyn Animation>> {
    let path = Path::new(name_or_path);
    let params = SceneParams {
        triangles,
        frames,
        instances,
        ..SceneParams::default()
    };
    let kind = SceneKind::of(name_or_path);
    if instances.is_some() && kind != SceneKind::Builtin {
        bail!("--instances applies to built-in scenes only, not to '{name_or_path}'");
    }
    Ok(match kind {
        // The recording's own frames; --frames picks among them.
        SceneKind::Recording => Box::new(RecordedAnimation::open(path)?),
        SceneKind::File => load_file(path, frames)?,
        SceneKind::Builtin => builtin(name_or_path, &params)?,
    })
}
