//! Where a scene comes from: a built-in generator by name, an OBJ/glTF file by path, or a
//! session recording (`.antrec`, written by `antumbra serve --record`) replayed frame by frame.

use std::path::Path;

use antumbra_core::scene::Animation;
use antumbra_protocol::RecordedAnimation;
use antumbra_scenes::{builtin, load_file, SceneParams};
use anyhow::Result;

pub fn open_scene(name_or_path: &str, triangles: usize, frames: i32) -> Result<Box<dyn Animation>> {
    let path = Path::new(name_or_path);
    let looks_like_file = path.extension().is_some() || name_or_path.contains('/');
    let is_recording = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("antrec"));
    let params = SceneParams {
        triangles,
        frames,
        ..SceneParams::default()
    };
    Ok(if is_recording {
        // The recording's own frames; --frames picks among them.
        Box::new(RecordedAnimation::open(path)?)
    } else if looks_like_file {
        load_file(path, frames)?
    } else {
        builtin(name_or_path, &params)?
    })
}
