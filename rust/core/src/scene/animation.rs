use std::ops::RangeInclusive;

use super::Scene;

/// An animated scene: a source of per-frame snapshots. Meshes that do not change between frames
/// are the same `Arc`, so consumers can tell static geometry from moving geometry cheaply.
pub trait Animation: Send + Sync {
    fn name(&self) -> &str;
    fn frame_range(&self) -> RangeInclusive<i32>;
    fn frame(&self, frame: i32) -> Scene;

    /// Frame `frame` from an animation no longer needed afterwards (the last frame a caller
    /// asks for): one that holds a large static part moves it into the frame rather than
    /// copying it, so it is not held twice.
    fn into_frame(self: Box<Self>, frame: i32) -> Scene {
        self.frame(frame)
    }
}

/// A scene that does not move: every frame is the same snapshot.
pub struct StaticAnimation {
    pub name: String,
    pub scene: Scene,
}

impl Animation for StaticAnimation {
    fn name(&self) -> &str {
        &self.name
    }
    fn frame_range(&self) -> RangeInclusive<i32> {
        self.scene.frame..=self.scene.frame
    }
    fn frame(&self, frame: i32) -> Scene {
        let mut scene = self.scene.clone();
        scene.frame = frame;
        scene
    }
}
