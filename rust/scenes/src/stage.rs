//! What every built-in scene shares: the static part (meshes made once, shared by `Arc` with every
//! frame), frame timing, and helpers for cameras and lights in Blender's conventions.

use std::sync::Arc;

use antumbra_core::scene::{Camera, Light, LightKind, Mesh, Object, Resolution, Scene};
use glam::{DMat4, DVec3};

/// Frames per second that turns frame numbers into seconds of motion.
pub(crate) const FPS: f64 = 24.0;

pub(crate) fn default_resolution() -> Resolution {
    Resolution::new(640, 360)
}

/// Meshes built once and the objects that place them in every frame. Meshes that only move
/// rigidly live here too; their objects are added per frame with [`add_object`].
#[derive(Clone, Default)]
pub(crate) struct Stage {
    meshes: Vec<Arc<Mesh>>,
    objects: Vec<Object>,
}

impl Stage {
    pub fn new() -> Self {
        Stage::default()
    }

    /// Adds a mesh without placing it; returns its index in every frame's `meshes`.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(Arc::new(mesh));
        self.meshes.len() - 1
    }

    /// Adds a mesh and an object of the same name that places it at `xf` in every frame.
    pub fn add_static(&mut self, mesh: Mesh, xf: DMat4) -> usize {
        let name = mesh.name.clone();
        let index = self.add_mesh(mesh);
        self.objects.push(Object::new(name, index, xf));
        index
    }

    /// [`Stage::add_static`] with the object's material slots mapped to alpha materials.
    pub fn add_static_with(&mut self, mesh: Mesh, xf: DMat4, materials: Vec<Option<u32>>) {
        self.add_static(mesh, xf);
        if let Some(o) = self.objects.last_mut() {
            o.materials = materials;
        }
    }

    /// Places the stage's mesh `mesh` at `xf` in every frame (an instance when several objects
    /// share a mesh).
    pub fn place(&mut self, name: String, mesh: usize, xf: DMat4) {
        self.objects.push(Object::new(name, mesh, xf));
    }

    /// Room for `additional` more placed objects.
    pub fn reserve_objects(&mut self, additional: usize) {
        self.objects.reserve(additional);
    }

    /// A frame holding the static part (the same `Arc`s every time); callers add what moves.
    pub fn scene(&self, frame: i32, camera: Camera, lights: Vec<Light>) -> Scene {
        self.clone().into_scene(frame, camera, lights)
    }

    /// [`Stage::scene`] for the last frame asked for
    /// ([`Animation::into_frame`](antumbra_core::scene::Animation::into_frame)): the objects
    /// move into the frame instead of being copied, so a million instances are held once.
    pub fn into_scene(self, frame: i32, camera: Camera, lights: Vec<Light>) -> Scene {
        Scene {
            frame,
            meshes: self.meshes,
            objects: self.objects,
            camera,
            lights,
            resolution: default_resolution(),
            alpha: Default::default(),
        }
    }
}

/// Places an existing mesh of `scene` (a rigidly moving part).
pub(crate) fn add_object(scene: &mut Scene, name: String, mesh: usize, xf: DMat4) {
    scene.objects.push(Object::new(name, mesh, xf));
}

/// Adds a mesh made for this frame only (a deforming part: a new `Arc` every frame).
pub(crate) fn add_deforming(scene: &mut Scene, mesh: Mesh, xf: DMat4) {
    let name = mesh.name.clone();
    scene.meshes.push(Arc::new(mesh));
    let index = scene.meshes.len() - 1;
    add_object(scene, name, index, xf);
}

/// Frame timing: frames `1..=frames`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Clock {
    pub frames: i32,
}

impl Clock {
    pub fn range(&self) -> std::ops::RangeInclusive<i32> {
        1..=self.frames
    }

    /// Progress along a camera path: 0 at the first frame, 1 at the last (clamped outside).
    pub fn progress(&self, frame: i32) -> f64 {
        if self.frames <= 1 {
            0.0
        } else {
            ((frame - 1) as f64 / (self.frames - 1) as f64).clamp(0.0, 1.0)
        }
    }

    /// Seconds since the first frame, for motion that keeps its speed whatever the length.
    pub fn seconds(&self, frame: i32) -> f64 {
        (frame - 1) as f64 / FPS
    }
}

pub(crate) fn lerp3(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    a + (b - a) * t
}

/// Smooth start and stop for camera moves.
pub(crate) fn ease(t: f64) -> f64 {
    t * t * (3.0 - 2.0 * t)
}

pub(crate) fn camera(eye: DVec3, target: DVec3, lens_mm: f64, clip: (f64, f64)) -> Camera {
    let mut cam = Camera::look_at(eye, target, DVec3::Z).with_lens(lens_mm);
    cam.clip_start = clip.0;
    cam.clip_end = clip.1;
    cam
}

/// A frame at `position` whose local -Z points along `direction` (how Blender's lights emit).
pub(crate) fn aimed(position: DVec3, direction: DVec3) -> DMat4 {
    let dir = direction.normalize();
    let up = if dir.cross(DVec3::Z).length_squared() < 1e-12 {
        DVec3::Y
    } else {
        DVec3::Z
    };
    DMat4::look_at_rh(position, position + dir, up).inverse()
}

/// The direction sunlight travels for a sun at `elevation` above the horizon and `azimuth`
/// (radians, counter-clockwise from +X).
pub(crate) fn sun_direction(elevation: f64, azimuth: f64) -> DVec3 {
    -DVec3::new(
        elevation.cos() * azimuth.cos(),
        elevation.cos() * azimuth.sin(),
        elevation.sin(),
    )
}

/// A sun shining along `direction` with an angular diameter of `angle` radians. Its position
/// does not matter to a sun; it is put above the origin to look sensible in Blender.
pub(crate) fn sun(name: &str, direction: DVec3, angle: f64) -> Light {
    let position = -direction.normalize() * 50.0;
    Light::new(name, aimed(position, direction), LightKind::Sun { angle })
}

pub(crate) fn point(name: &str, position: DVec3, radius: f64) -> Light {
    let xf = DMat4::from_translation(position);
    Light::new(name, xf, LightKind::Point { radius })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aimed_points_local_minus_z_along_the_direction() {
        for dir in [DVec3::new(1.0, 2.0, -3.0), DVec3::NEG_Z, DVec3::Z] {
            let m = aimed(DVec3::new(1.0, 2.0, 3.0), dir);
            let minus_z = -m.z_axis.truncate();
            assert!((minus_z - dir.normalize()).length() < 1e-12, "{dir}");
        }
    }

    #[test]
    fn the_last_frame_takes_the_objects_others_copy_them() {
        let mut stage = Stage::new();
        let mesh = stage.add_mesh(Mesh::new("tree", Vec::new(), Vec::new()));
        for i in 0..100 {
            let xf = DMat4::from_translation(DVec3::new(i as f64, 0.0, 0.0));
            stage.place(format!("tree.{i:03}"), mesh, xf);
        }
        let cam = camera(DVec3::ONE, DVec3::ZERO, 50.0, (0.1, 100.0));
        let held = stage.objects.as_ptr();
        let copied = stage.scene(3, cam.clone(), Vec::new());
        assert_ne!(copied.objects.as_ptr(), held);
        let taken = stage.into_scene(3, cam, Vec::new());
        assert_eq!(taken.objects.as_ptr(), held, "the objects were copied");
        assert_eq!(taken.objects, copied.objects);
        assert!(Arc::ptr_eq(&taken.meshes[mesh], &copied.meshes[mesh]));
    }

    #[test]
    fn progress_spans_the_frames() {
        let c = Clock { frames: 5 };
        assert_eq!(c.progress(1), 0.0);
        assert_eq!(c.progress(5), 1.0);
        assert_eq!(Clock { frames: 1 }.progress(1), 0.0);
    }
}
