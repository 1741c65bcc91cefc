//! OBJ and glTF/GLB files as static scenes: every frame holds the same meshes (same `Arc`s), an
//! automatic camera framing the geometry and a default sun.
//!
//! Both formats are Y-up; like Blender's importers, objects are turned so that the file's +Y is
//! world +Z (and the file's +Z, glTF's front, is world -Y).

use std::collections::HashMap;
use std::f64::consts::FRAC_PI_2;
use std::ops::RangeInclusive;
use std::path::Path;
use std::sync::Arc;

use antumbra_core::scene::{Animation, Mesh, Object, Scene};
use antumbra_core::{Error, Result};
use glam::{DMat4, DVec3, Vec3};

use crate::stage::{camera, default_resolution, sun, sun_direction};

/// Meshes and the objects placing them, as read from a file.
#[derive(Default)]
struct Imported {
    meshes: Vec<Arc<Mesh>>,
    objects: Vec<Object>,
}

/// Loads an OBJ (`.obj`) or glTF (`.gltf`, `.glb`) file as an animation of `frames` identical
/// frames numbered from 1.
pub fn load_file(path: &Path, frames: i32) -> Result<Box<dyn Animation>> {
    if frames < 1 {
        return Err(Error::invalid(
            "frames",
            format!("must be at least 1, got {frames}"),
        ));
    }
    std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    let invalid = |message: String| Error::invalid(path.display().to_string(), message);
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let imported = match extension.as_deref() {
        Some("obj") => read_obj(path).map_err(invalid)?,
        Some("gltf") | Some("glb") => read_gltf(path).map_err(invalid)?,
        _ => {
            return Err(invalid(
                "unsupported scene file format (expected .obj, .gltf or .glb)".into(),
            ))
        }
    };
    let triangles: usize = imported
        .objects
        .iter()
        .map(|o| imported.meshes[o.mesh].triangles.len())
        .sum();
    if triangles == 0 {
        return Err(invalid("contains no triangles".into()));
    }
    let scene = framed_scene(imported).map_err(|e| invalid(e.to_string()))?;
    let name = path
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

fn read_obj(path: &Path) -> std::result::Result<Imported, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials are irrelevant to shadows; a missing .mtl only fails the material part.
    let (models, _materials) =
        tobj::load_obj(path, &options).map_err(|e| format!("not a valid OBJ file: {e}"))?;
    let mut out = Imported::default();
    for model in models {
        let positions: Vec<Vec3> = model
            .mesh
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        let triangles: Vec<[u32; 3]> = model
            .mesh
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        if triangles.is_empty() {
            continue;
        }
        out.meshes.push(Arc::new(Mesh::new(
            model.name.clone(),
            positions,
            triangles,
        )));
        let mesh = out.meshes.len() - 1;
        out.objects
            .push(Object::new(model.name, mesh, y_up_to_z_up()));
    }
    Ok(out)
}

/// Node hierarchies deeper than this are treated as malformed (a cycle) rather than followed.
const MAX_NODE_DEPTH: usize = 256;

fn read_gltf(path: &Path) -> std::result::Result<Imported, String> {
    let gltf::Gltf { document, blob } =
        gltf::Gltf::open(path).map_err(|e| format!("not a valid glTF file: {e}"))?;
    let buffers = gltf::import_buffers(&document, path.parent(), blob)
        .map_err(|e| format!("cannot load glTF buffers: {e}"))?;
    let roots: Vec<gltf::Node> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        // No scene: every node that is nobody's child is a root.
        None => {
            let children: std::collections::HashSet<usize> = document
                .nodes()
                .flat_map(|n| n.children().map(|c| c.index()))
                .collect();
            document
                .nodes()
                .filter(|n| !children.contains(&n.index()))
                .collect()
        }
    };
    let mut out = Imported::default();
    let mut mesh_of: HashMap<usize, std::result::Result<Option<usize>, String>> = HashMap::new();
    let mut stack: Vec<(gltf::Node, DMat4, usize)> =
        roots.into_iter().map(|n| (n, y_up_to_z_up(), 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "node hierarchy deeper than {MAX_NODE_DEPTH} levels (a cycle?)"
            ));
        }
        let local = node.transform().matrix().map(|c| c.map(|v| v as f64));
        let world = parent * DMat4::from_cols_array_2d(&local);
        if let Some(mesh) = node.mesh() {
            let index = mesh_of.entry(mesh.index()).or_insert_with(|| {
                gltf_mesh(&mesh, &buffers).map(|m| {
                    m.map(|m| {
                        out.meshes.push(Arc::new(m));
                        out.meshes.len() - 1
                    })
                })
            });
            if let Some(index) = index.clone()? {
                let name = node
                    .name()
                    .map(str::to_owned)
                    .unwrap_or_else(|| format!("node.{}", node.index()));
                out.objects.push(Object::new(name, index, world));
            }
        }
        stack.extend(node.children().map(|c| (c, world, depth + 1)));
    }
    Ok(out)
}

/// All triangles of a glTF mesh's primitives (triangle lists, strips and fans) in one mesh;
/// `None` when it has none.
fn gltf_mesh(
    mesh: &gltf::Mesh,
    buffers: &[gltf::buffer::Data],
) -> std::result::Result<Option<Mesh>, String> {
    use gltf::mesh::Mode;
    let name = mesh
        .name()
        .map(str::to_owned)
        .unwrap_or_else(|| format!("mesh.{}", mesh.index()));
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    // Vertex normals (`NORMAL`), kept only if every primitive has them.
    let mut normals: Option<Vec<Vec3>> = Some(Vec::new());
    for primitive in mesh.primitives() {
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let Some(read) = reader.read_positions() else {
            continue;
        };
        let base = positions.len() as u32;
        positions.extend(read.map(Vec3::from_array));
        let count = positions.len() as u32 - base;
        normals = normals
            .zip(reader.read_normals())
            .and_then(|(mut n, read)| {
                n.extend(read.map(Vec3::from_array));
                (n.len() == positions.len()).then_some(n)
            });
        let indices: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..count).collect(),
        };
        // Checked per primitive: an index past this primitive's vertices would silently pick
        // another primitive's vertex once they share one array.
        if let Some(bad) = indices.iter().find(|&&i| i >= count) {
            return Err(format!(
                "mesh '{name}': index {bad} is out of range for a primitive of {count} vertices"
            ));
        }
        let at = |k: usize| base.saturating_add(indices[k]);
        match primitive.mode() {
            Mode::Triangles => triangles
                .extend((0..indices.len() / 3).map(|t| [at(3 * t), at(3 * t + 1), at(3 * t + 2)])),
            Mode::TriangleStrip => triangles.extend((2..indices.len()).map(|k| {
                // Every other triangle of a strip is flipped to keep one winding.
                if k % 2 == 0 {
                    [at(k - 2), at(k - 1), at(k)]
                } else {
                    [at(k - 1), at(k - 2), at(k)]
                }
            })),
            Mode::TriangleFan => {
                triangles.extend((2..indices.len()).map(|k| [at(0), at(k - 1), at(k)]))
            }
            Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => {}
        }
    }
    let corners = match normals {
        Some(n) => triangles.iter().map(|t| t.map(|i| n[i as usize])).collect(),
        None => Vec::new(),
    };
    Ok(
        (!triangles.is_empty())
            .then(|| Mesh::new(name, positions, triangles).with_normals(corners)),
    )
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
}
