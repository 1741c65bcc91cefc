//! The scenes and frames bench measures: `--frames` if given, else every frame of a recording
//! and the first frame of a built-in scene or a file.

use std::ops::RangeInclusive;

use antumbra_core::scene::Animation;
use anyhow::{bail, Result};

use crate::frames::parse_frames;
use crate::scene_source::{open_scene, SceneKind};

/// An opened scene and the frames to measure.
pub(super) struct BenchScene {
    pub animation: Box<dyn Animation>,
    pub kind: SceneKind,
    pub frames: Vec<i32>,
    /// Whether `--frames` chose them.
    pub asked: bool,
}

impl BenchScene {
    /// Opens `name`; a built-in scene is `length` frames long unless `--frames A-B` makes it B.
    pub fn open(
        name: &str,
        triangles: usize,
        frames: Option<&str>,
        length: i32,
    ) -> Result<BenchScene> {
        let asked = frames.map(parse_frames).transpose()?;
        let length = asked.as_ref().map_or(length, |r| *r.end()).max(1);
        let animation = open_scene(name, triangles, None, length)?;
        let kind = SceneKind::of(name);
        let range = animation.frame_range();
        let frames: RangeInclusive<i32> = match (&asked, kind) {
            (Some(a), SceneKind::Recording)
                if a.start() < range.start() || a.end() > range.end() =>
            {
                bail!(
                    "{name}: --frames {}-{} asks for frames it does not hold (it recorded frames {}-{})",
                    a.start(),
                    a.end(),
                    range.start(),
                    range.end()
                )
            }
            (Some(a), _) => a.clone(),
            (None, SceneKind::Recording) => range,
            (None, _) => *range.start()..=*range.start(),
        };
        Ok(BenchScene {
            animation,
            kind,
            frames: frames.collect(),
            asked: asked.is_some(),
        })
    }
}

/// The scenes asked for, or every built-in scene.
pub(super) fn scene_names(asked: &[String]) -> Vec<String> {
    if asked.is_empty() {
        antumbra_scenes::BUILTIN_SCENES
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        asked.to_vec()
    }
}
