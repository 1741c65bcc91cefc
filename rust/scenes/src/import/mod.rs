//! OBJ and glTF/GLB files as static scenes: every frame holds the same meshes (same `Arc`s), an
//! automatic camera framing the geometry and a default sun.
//!
//! Both formats are Y-up; like Blender's importers, objects are turned so that the file's +Y is
//! world +Z (and the file's +Z, glTF's front, is world -Y).
//!
//! Nothing a file holds can crash an import: only regular files are read, sizes and counts are
//! checked against [`ImportLimits`] before anything is allocated for them, glTF accessors are
//! checked before they are read, and glTF buffers come only from the file's own folder.

mod file;
mod gltf_file;
mod limits;
mod obj;

use std::f64::consts::FRAC_PI_2;
use std::io::{BufReader, Read};
use std::ops::RangeInclusive;
use std::path::Path;
use std::sync::Arc;

use antumbra_core::scene::{Animation, Mesh, Object, Scene};
use antumbra_core::{Error, Result};
use glam::{DMat4, DVec3};

use crate::stage::{camera, default_resolution, sun, sun_direction};

pub use limits::ImportLimits;

/// Meshes and the objects placing them, as read from a file.
#[derive(Default)]
struct Imported {
    meshes: Vec<Arc<Mesh>>,
    objects: Vec<Object>,
}

/// The formats read, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Obj,
    /// `.gltf` or `.glb`: which one is told by the bytes.
    Gltf,
}

impl Format {
    /// The format a path's extension names, or `None`.
    fn of(path: &Path) -> Option<Format> {
        let extension = path.extension()?.to_str()?.to_ascii_lowercase();
        match extension.as_str() {
            "obj" => Some(Format::Obj),
            "gltf" | "glb" => Some(Format::Gltf),
            _ => None,
        }
    }
}

/// Loads an OBJ (`.obj`) or glTF (`.gltf`, `.glb`) file as an animation of `frames` identical
/// frames numbered from 1, within the default [`ImportLimits`].
pub fn load_file(path: &Path, frames: i32) -> Result<Box<dyn Animation>> {
    load_file_with(path, frames, &ImportLimits::default())
}

/// As [`load_file`], within `limits`.
pub fn load_file_with(
    path: &Path,
    frames: i32,
    limits: &ImportLimits,
) -> Result<Box<dyn Animation>> {
    check_frames(frames)?;
    let name = path.display().to_string();
    let Some(format) = Format::of(path) else {
        std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        return Err(Error::invalid(
            name,
            "unsupported scene file format (expected .obj, .gltf or .glb)",
        ));
    };
    let mut totals = limits::Totals::default();
    let (file, size) = file::open_regular(path, &mut totals, limits)?;
    let invalid = |message: String| Error::invalid(&name, message);
    let imported = match format {
        Format::Obj => obj::read_obj(BufReader::new(file), limits).map_err(invalid)?,
        Format::Gltf => {
            let bytes = file::read_all(file, size, "file", limits).map_err(invalid)?;
            // Relative buffer URIs resolve in the file's folder ("" for a bare file name).
            let folder = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            gltf_file::read_gltf(&bytes, Some(folder), limits).map_err(invalid)?
        }
    };
    finish(&name, imported, frames)
}

/// An OBJ read from `reader` (a file, or bytes in memory) as a static animation; `name` (a
/// file name) names it and its errors.
pub fn load_obj(
    name: &str,
    reader: impl Read,
    frames: i32,
    limits: &ImportLimits,
) -> Result<Box<dyn Animation>> {
    check_frames(frames)?;
    let imported =
        obj::read_obj(BufReader::new(reader), limits).map_err(|e| Error::invalid(name, e))?;
    finish(name, imported, frames)
}

/// A glTF or GLB file held in `bytes` as a static animation; `name` (a file name) names it and
/// its errors. Buffers in other files are read from `folder` only, and only with one.
pub fn load_gltf(
    name: &str,
    bytes: &[u8],
    folder: Option<&Path>,
    frames: i32,
    limits: &ImportLimits,
) -> Result<Box<dyn Animation>> {
    check_frames(frames)?;
    let imported =
        gltf_file::read_gltf(bytes, folder, limits).map_err(|e| Error::invalid(name, e))?;
    finish(name, imported, frames)
}

fn check_frames(frames: i32) -> Result<()> {
    if frames < 1 {
        return Err(Error::invalid(
            "frames",
            format!("must be at least 1, got {frames}"),
        ));
    }
    Ok(())
}

/// The imported meshes as a framed static scene, refused when it has no triangle.
fn finish(name: &str, imported: Imported, frames: i32) -> Result<Box<dyn Animation>> {
    let invalid = |message: String| Error::invalid(name, message);
    let triangles: usize = imported
        .objects
        .iter()
        .map(|o| imported.meshes[o.mesh].triangles.len())
        .sum();
    if triangles == 0 {
        return Err(invalid("contains no triangles".into()));
    }
    let scene = framed_scene(imported).map_err(|e| invalid(e.to_string()))?;
    let name = Path::new(name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    Ok(Box::new(StaticFile {
        name,
        frames,
        scene,
    }))
}

/// Y-up file coordinates to Blender's Z-up world.
fn y_up_to_z_up() -> DMat4 {
    DMat4::from_rotation_x(FRAC_PI_2)
}
/// The imported geometry with a camera that frames its bounding sphere from the front right,
/// a little above (as Blender's default view), and a default sun. Validates the result.
fn framed_scene(imported: Imported) -> Result<Scene> {
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    for object in &imported.objects {
        let mesh = &imported.meshes[object.mesh];
        for p in &mesh.positions {
            let w = object.world_from_object.transform_point3(p.as_dvec3());
            min = min.min(w);
            max = max.max(w);
        }
    }
    let mut scene = Scene {
        frame: 1,
        meshes: imported.meshes,
        objects: imported.objects,
        camera: camera(DVec3::NEG_Y, DVec3::ZERO, 50.0, (0.1, 100.0)),
        lights: vec![sun("Sun", sun_direction(0.9, -0.9), 0.0093)],
        resolution: default_resolution(),
        alpha: Default::default(),
    };
    // Non-finite positions are reported by validation, not framed.
    scene.validate()?;
    let centre = (min + max) * 0.5;
    let radius = ((max - min).length() * 0.5).max(1e-6);
    // The vertical half-angle of a 50 mm lens on a 36 mm sensor at 16:9 is the tighter one.
    let (w, h) = scene.resolution.pixels();
    let half_tan = 18.0 / 50.0 * (h.min(w) as f64 / h.max(w) as f64);
    let distance = 1.05 * radius * (1.0 + half_tan * half_tan).sqrt() / half_tan;
    let eye = centre + DVec3::new(0.6, -1.0, 0.55).normalize() * distance;
    scene.camera = camera(
        eye,
        centre,
        50.0,
        ((distance - radius) * 0.5, (distance + radius) * 2.0),
    );
    scene.validate()?;
    Ok(scene)
}

/// A file scene: the same snapshot in every frame.
struct StaticFile {
    name: String,
    frames: i32,
    scene: Scene,
}

impl Animation for StaticFile {
    fn name(&self) -> &str {
        &self.name
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        1..=self.frames
    }

    fn frame(&self, frame: i32) -> Scene {
        let mut scene = self.scene.clone();
        scene.frame = frame;
        scene
    }

    /// The snapshot itself, not a copy of its objects.
    fn into_frame(self: Box<Self>, frame: i32) -> Scene {
        Scene {
            frame,
            ..self.scene
        }
    }
}
