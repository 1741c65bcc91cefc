//! The scene arguments `render` and `record` share: which scene, which frames, what size.

use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, ImageSize, Scene};
use anyhow::Result;
use clap::Args;

use crate::frames::parse_frames;
use crate::scene_source::open_scene;

#[derive(Args, Debug)]
pub struct SceneArgs {
    /// A built-in scene (bedroom, colonnade, city, forest, hairball, indoors, instanced-forest,
    /// character-room, leaf-cards; "-rot45" for the rotated variant), an OBJ/glTF file, or a
    /// recording (.antrec).
    #[arg(long)]
    pub scene: String,
    /// Frames, "A-B" or "N" (default: the scene's whole range).
    #[arg(long)]
    pub frames: Option<String>,
    /// Image size WxH (default: the scene's resolution).
    #[arg(long, value_name = "WxH", value_parser = ImageSize::parse_image)]
    pub size: Option<ImageSize>,
    /// Triangle budget of a built-in scene: world triangles, or unique triangles with
    /// --instances.
    #[arg(long, default_value_t = 100_000)]
    pub triangles: usize,
    /// Exactly N instances sharing a few meshes (instanced-forest only, at most 10,000,000);
    /// --triangles then budgets the unique triangles, not the world's.
    #[arg(long, value_name = "N")]
    pub instances: Option<usize>,
}

/// An opened scene with the frames and image size asked for.
pub struct OpenScene {
    pub animation: Box<dyn Animation>,
    pub frames: RangeInclusive<i32>,
    pub size: Option<ImageSize>,
}

impl SceneArgs {
    pub fn open(&self) -> Result<OpenScene> {
        let frames = self.frames.as_deref().map(parse_frames).transpose()?;
        let frame_count = frames.as_ref().map_or(24, |r| *r.end());
        let animation = open_scene(
            &self.scene,
            self.triangles,
            self.instances,
            frame_count.max(1),
        )?;
        let frames = frames.unwrap_or_else(|| animation.frame_range());
        Ok(OpenScene {
            animation,
            frames,
            size: self.size,
        })
    }
}

impl OpenScene {
    /// The frames asked for, in order, each at the size asked for. The last is the animation's
    /// [`Animation::into_frame`], so a built-in scene's objects are not held by the scene and
    /// by the frame at once while it renders.
    pub fn into_frames(self) -> SceneFrames {
        SceneFrames {
            animation: Some(self.animation),
            frames: self.frames,
            size: self.size,
        }
    }
}

/// The frames of an [`OpenScene`], one at a time ([`OpenScene::into_frames`]).
pub struct SceneFrames {
    /// Dropped when the last frame is taken from it.
    animation: Option<Box<dyn Animation>>,
    frames: RangeInclusive<i32>,
    size: Option<ImageSize>,
}

impl Iterator for SceneFrames {
    type Item = Scene;

    fn next(&mut self) -> Option<Scene> {
        let frame = self.frames.next()?;
        let scene = if self.frames.is_empty() {
            self.animation.take()?.into_frame(frame)
        } else {
            self.animation.as_ref()?.frame(frame)
        };
        Some(at_size(scene, self.size))
    }
}

/// `scene` at `size` (100%) if given.
fn at_size(mut scene: Scene, size: Option<ImageSize>) -> Scene {
    if let Some(size) = size {
        scene.resolution.x = size.width;
        scene.resolution.y = size.height;
        scene.resolution.percentage = 100;
    }
    scene
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use antumbra_scenes::{builtin, SceneParams};

    use super::*;

    /// A built-in scene that notes each frame asked of it, and whether it was taken.
    struct Noting {
        inner: Box<dyn Animation>,
        asked: Arc<Mutex<Vec<(i32, bool)>>>,
    }

    impl Animation for Noting {
        fn name(&self) -> &str {
            self.inner.name()
        }
        fn frame_range(&self) -> RangeInclusive<i32> {
            self.inner.frame_range()
        }
        fn frame(&self, frame: i32) -> Scene {
            self.asked.lock().unwrap().push((frame, false));
            self.inner.frame(frame)
        }
        fn into_frame(self: Box<Self>, frame: i32) -> Scene {
            self.asked.lock().unwrap().push((frame, true));
            self.inner.into_frame(frame)
        }
    }

    fn frames_of(frames: RangeInclusive<i32>) -> (Vec<Scene>, Vec<(i32, bool)>) {
        let params = SceneParams {
            triangles: 1_000,
            frames: 4,
            ..SceneParams::default()
        };
        let asked = Arc::new(Mutex::new(Vec::new()));
        let open = OpenScene {
            animation: Box::new(Noting {
                inner: builtin("hairball", &params).unwrap(),
                asked: asked.clone(),
            }),
            frames,
            size: Some(ImageSize::parse_image("100x50").unwrap()),
        };
        let scenes = open.into_frames().collect();
        let asked = asked.lock().unwrap().clone();
        (scenes, asked)
    }

    #[test]
    fn each_frame_is_asked_once_and_the_last_is_taken() {
        let (scenes, asked) = frames_of(2..=4);
        assert_eq!(asked, [(2, false), (3, false), (4, true)]);
        let numbers: Vec<i32> = scenes.iter().map(|s| s.frame).collect();
        assert_eq!(numbers, [2, 3, 4]);
        for s in &scenes {
            let r = s.resolution;
            assert_eq!((r.x, r.y, r.percentage), (100, 50, 100));
        }
        assert_eq!(frames_of(3..=3).1, [(3, true)]);
    }
}
