//! glTF and GLB from bytes: the document's JSON parsed by the `gltf` crate's model, everything
//! else (indices between its arrays, buffers, accessors, the node tree) checked here where used.

mod accessor;
mod buffers;
mod glb;

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

use antumbra_core::scene::{Mesh, Object};
use glam::{DMat4, DQuat, DVec3, Vec3};
use gltf::json::mesh::{Mode, Semantic};
use gltf::json::validation::Checked;
use gltf::json::Root;

use self::accessor::{Accessors, Use};
use super::limits::{check, ImportLimits, Totals};
use super::{y_up_to_z_up, Imported};

/// Node hierarchies deeper than this are treated as malformed (a cycle) rather than followed.
const MAX_NODE_DEPTH: usize = 256;

/// The meshes and objects of a glTF (JSON) or GLB file held in `bytes`; external buffers are
/// read from `folder` (the file's own) and only from there.
pub(super) fn read_gltf(
    bytes: &[u8],
    folder: Option<&Path>,
    limits: &ImportLimits,
) -> Result<Imported, String> {
    let mut totals = Totals::default();
    totals.add_bytes("file size", bytes.len() as u64, limits)?;
    let (json, bin) = if bytes.starts_with(b"glTF") {
        glb::split(bytes)?
    } else {
        (bytes, None)
    };
    let root = parse(json)?;
    let buffers = buffers::load(&root, bin, folder, &mut totals, limits)?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|b| &b[..]).collect();
    let accessors = Accessors {
        root: &root,
        buffers: &buffers,
    };
    // The default scene, else the first.
    let scene = root
        .scene
        .map(|s| s.value())
        .or((!root.scenes.is_empty()).then_some(0));
    let roots: Vec<usize> = match scene {
        Some(s) => {
            let scene = root
                .scenes
                .get(s)
                .ok_or_else(|| format!("scene {s} does not exist"))?;
            scene.nodes.iter().map(|n| n.value()).collect()
        }
        // No scene: every node that is nobody's child is a root.
        None => {
            let children: HashSet<usize> = root
                .nodes
                .iter()
                .flat_map(|n| n.children.iter().flatten().map(|c| c.value()))
                .collect();
            (0..root.nodes.len())
                .filter(|n| !children.contains(n))
                .collect()
        }
    };
    let mut out = Imported::default();
    let mut mesh_of: HashMap<usize, Option<usize>> = HashMap::new();
    // Nodes are counted as they are put on the stack, so that the stack stays within the
    // limit too; a node reached through several parents counts each time (a tree of shared
    // nodes can place exponentially many).
    let mut placed = 0u64;
    let mut place = |n: usize| {
        placed += n as u64;
        check("nodes placed", placed, limits.max_objects, "max_objects")
    };
    place(roots.len())?;
    let mut stack: Vec<(usize, DMat4, usize)> =
        roots.into_iter().map(|n| (n, y_up_to_z_up(), 0)).collect();
    while let Some((index, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "node hierarchy deeper than {MAX_NODE_DEPTH} levels (a cycle?)"
            ));
        }
        let node = root
            .nodes
            .get(index)
            .ok_or_else(|| format!("node {index} does not exist"))?;
        let world = parent * local_transform(node);
        if let Some(mesh) = node.mesh.map(|m| m.value()) {
            let built = match mesh_of.get(&mesh) {
                Some(&built) => built,
                None => {
                    let built = read_mesh(&accessors, mesh, &mut totals, limits)?.map(|m| {
                        out.meshes.push(Arc::new(m));
                        out.meshes.len() - 1
                    });
                    if built.is_some() {
                        totals.add_mesh("meshes", limits)?;
                    }
                    mesh_of.insert(mesh, built);
                    built
                }
            };
            if let Some(built) = built {
                totals.add_object("objects", limits)?;
                let name = node.name.clone().unwrap_or_else(|| format!("node.{index}"));
                out.objects.push(Object::new(name, built, world));
            }
        }
        let children = node.children.as_deref().unwrap_or_default();
        place(children.len())?;
        stack.extend(children.iter().map(|c| (c.value(), world, depth + 1)));
    }
    Ok(out)
}

/// A node's matrix, or its translation, rotation and scale (in that order of application
/// from the left, as glTF defines).
fn local_transform(node: &gltf::json::Node) -> DMat4 {
    let f = |v: f32| v as f64;
    match node.matrix {
        Some(m) => DMat4::from_cols_array(&m.map(f)),
        None => {
            let t = node.translation.unwrap_or([0.0; 3]).map(f);
            let r = node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0).map(f);
            let s = node.scale.unwrap_or([1.0; 3]).map(f);
            DMat4::from_scale_rotation_translation(
                DVec3::from_array(s),
                DQuat::from_array(r),
                DVec3::from_array(t),
            )
        }
    }
}

/// The document's JSON, parsed (not validated: the `gltf` crate's validation indexes arrays
/// unchecked; every index and value used is checked where it is used). Errors give where and
/// what kind, not the text found. Required extensions are refused: none is read.
fn parse(json: &[u8]) -> Result<Root, String> {
    let root = Root::from_slice(json).map_err(|e| {
        let kind = if e.is_eof() {
            "ends early"
        } else if e.is_syntax() {
            "is not JSON"
        } else {
            "does not match the glTF schema"
        };
        format!(
            "not a valid glTF file: the JSON {kind} (line {}, column {})",
            e.line(),
            e.column()
        )
    })?;
    if !root.extensions_required.is_empty() {
        return Err(format!(
            "requires {} extension(s) (extensionsRequired); none is read",
            root.extensions_required.len()
        ));
    }
    Ok(root)
}

/// All triangles of glTF mesh `index`'s primitives (triangle lists, strips and fans) in one
/// mesh; `None` when it has none. Counts are checked against the limits before each read.
fn read_mesh(
    accessors: &Accessors,
    index: usize,
    totals: &mut Totals,
    limits: &ImportLimits,
) -> Result<Option<Mesh>, String> {
    let json = accessors
        .root
        .meshes
        .get(index)
        .ok_or_else(|| format!("mesh {index} does not exist"))?;
    let name = json.name.clone().unwrap_or_else(|| format!("mesh.{index}"));
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    // Vertex normals (`NORMAL`), kept only if every primitive has them.
    let mut normals: Option<Vec<Vec3>> = Some(Vec::new());
    for (p, primitive) in json.primitives.iter().enumerate() {
        let what = format!("mesh {index} primitive {p}");
        let mode = match primitive.mode {
            Checked::Valid(m) => m,
            Checked::Invalid => return Err(format!("{what}: mode is not valid")),
        };
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            continue;
        }
        let attribute = |s| {
            primitive
                .attributes
                .get(&Checked::Valid(s))
                .map(|i| i.value())
        };
        let Some(position) = attribute(Semantic::Positions) else {
            continue;
        };
        let vertices = accessors.count(position)?;
        let corners = match primitive.indices {
            Some(i) => accessors.count(i.value())?,
            None => vertices,
        };
        let new = match mode {
            Mode::Triangles => corners / 3,
            _ => corners.saturating_sub(2),
        };
        check(
            &format!("{what}: triangles of the mesh"),
            triangles.len() as u64 + new,
            limits.max_triangles_per_mesh,
            "max_triangles_per_mesh",
        )?;
        check(
            &format!("{what}: vertices of the mesh"),
            positions.len() as u64 + vertices,
            u32::MAX as u64,
            "u32 vertex indices",
        )?;
        totals.add_mesh_part(&what, new, vertices, limits)?;

        let base = positions.len() as u32;
        let read = accessors.read::<3>(position, Use::Position)?;
        positions.extend(
            read.into_iter()
                .map(|p| Vec3::from_array(p.map(f32::from_bits))),
        );
        let count = positions.len() as u32 - base;
        normals = match (normals, attribute(Semantic::Normals)) {
            (Some(mut n), Some(normal)) => {
                // Compared before reading: the count alone sizes a sparse accessor.
                let normals = accessors.count(normal)?;
                if normals != count as u64 {
                    return Err(format!(
                        "{what}: NORMAL has {normals} elements, POSITION {count}"
                    ));
                }
                let read = accessors.read::<3>(normal, Use::Normal)?;
                n.extend(
                    read.into_iter()
                        .map(|v| Vec3::from_array(v.map(f32::from_bits))),
                );
                Some(n)
            }
            _ => None,
        };
        let indices: Vec<u32> = match primitive.indices {
            Some(i) => {
                let read = accessors.read::<1>(i.value(), Use::Indices)?;
                read.into_iter().map(|[i]| i).collect()
            }
            None => (0..count).collect(),
        };
        // Checked per primitive: an index past this primitive's vertices would silently pick
        // another primitive's vertex once they share one array. The value is not echoed.
        if let Some(k) = indices.iter().position(|&i| i >= count) {
            return Err(format!(
                "{what}: index #{k} is out of range for a primitive of {count} vertices"
            ));
        }
        let at = |k: usize| base + indices[k];
        match mode {
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
            _ => triangles.extend((2..indices.len()).map(|k| [at(0), at(k - 1), at(k)])),
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
