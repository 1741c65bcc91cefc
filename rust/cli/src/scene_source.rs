//! Where a scene comes from: a built-in generator by name, or an OBJ/glTF file by path.

use std::path::Path;

use antumbra_core::scene::Animation;
use antumbra_scenes::{builtin, load_file, SceneParams};
use anyhow::Result;

pub fn open_scene(name_or_path: &str, triangles: usize, frames: i32) -> Result<Box<dyn Animation>> {
    let path = Path::new(name_or_path);
    let looks_like_file = path.extension().is_some() || name_or_path.contains('/');
    let params = SceneParams {
        triangles,
        frames,
        ..SceneParams::default()
    };
    Ok(if looks_like_file {
        load_file(path, frames)?
    } else {
        builtin(name_or_path, &params)?
    })
}
