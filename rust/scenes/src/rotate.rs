//! The "rotated by 45 degrees" variants: the whole scene (objects, lights, camera) turned about
//! the world's vertical Z axis through the origin. Papers use this to show how much a BVH relies
//! on geometry being aligned with the axes its boxes are.

use std::f64::consts::FRAC_PI_4;
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, Scene};
use glam::DMat4;

/// Appended to a built-in scene's name for its rotated variant.
pub const ROTATED_SUFFIX: &str = "-rot45";

/// Pre-multiplies every world matrix by `world_rotation`. Meshes are untouched, so static meshes
/// stay the same `Arc`.
pub fn rotate_scene(scene: &mut Scene, world_rotation: DMat4) {
    for object in &mut scene.objects {
        object.world_from_object = world_rotation * object.world_from_object;
    }
    for light in &mut scene.lights {
        light.world_from_light = world_rotation * light.world_from_light;
    }
    scene.camera.world_from_camera = world_rotation * scene.camera.world_from_camera;
}

/// An animation turned by 45 degrees about world Z.
pub struct Rotated {
    inner: Box<dyn Animation>,
    name: String,
}

impl Rotated {
    pub fn new(inner: Box<dyn Animation>) -> Self {
        let name = format!("{}{ROTATED_SUFFIX}", inner.name());
        Rotated { inner, name }
    }

    pub fn rotation() -> DMat4 {
        DMat4::from_rotation_z(FRAC_PI_4)
    }
}

impl Animation for Rotated {
    fn name(&self) -> &str {
        &self.name
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.inner.frame_range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let mut scene = self.inner.frame(frame);
        rotate_scene(&mut scene, Rotated::rotation());
        scene
    }

    /// The inner animation's own last frame, so that its static part is not copied either.
    fn into_frame(self: Box<Self>, frame: i32) -> Scene {
        let mut scene = self.inner.into_frame(frame);
        rotate_scene(&mut scene, Rotated::rotation());
        scene
    }
}
