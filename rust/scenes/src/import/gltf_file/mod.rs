//! glTF and GLB from bytes: the document parsed and validated by the `gltf` crate, the buffers
//! and accessors checked and read here, the node tree walked with counts bounded.

mod accessor;
mod buffers;
mod glb;

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

use antumbra_core::scene::{Mesh, Object};
use glam::{DMat4, Vec3};
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
    let document = parse(json)?;
    let root = document.as_json();
    let buffers = buffers::load(root, bin, folder, &mut totals, limits)?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|b| &b[..]).collect();
    let accessors = Accessors {
        root,
        buffers: &buffers,
    };
    let roots: Vec<gltf::Node> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        // No scene: every node that is nobody's child is a root.
        None => {
            let children: HashSet<usize> = document
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
    let mut mesh_of: HashMap<usize, Option<usize>> = HashMap::new();
    let mut visits = 0u64;
    let mut stack: Vec<(gltf::Node, DMat4, usize)> =
        roots.into_iter().map(|n| (n, y_up_to_z_up(), 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "node hierarchy deeper than {MAX_NODE_DEPTH} levels (a cycle?)"
            ));
        }
        // A node reached through several parents counts each time: a tree of shared nodes
        // can place exponentially many.
        visits += 1;
        check("nodes placed", visits, limits.max_objects, "max_objects")?;
        let local = node.transform().matrix().map(|c| c.map(|v| v as f64));
        let world = parent * DMat4::from_cols_array_2d(&local);
        if let Some(mesh) = node.mesh() {
            let index = match mesh_of.get(&mesh.index()) {
                Some(&index) => index,
                None => {
                    let built = read_mesh(&accessors, mesh.index(), &mut totals, limits)?;
                    let index = built.map(|m| {
                        out.meshes.push(Arc::new(m));
                        out.meshes.len() - 1
                    });
                    if index.is_some() {
                        totals.add_mesh("meshes", limits)?;
                    }
                    mesh_of.insert(mesh.index(), index);
                    index
                }
            };
            if let Some(index) = index {
                totals.add_object("objects", limits)?;
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

/// The document, parsed and validated. Errors give where and what kind, not the text found.
fn parse(json: &[u8]) -> Result<gltf::Document, String> {
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
    gltf::Document::from_json(root).map_err(|e| match e {
        gltf::Error::Validation(errors) => {
            let shown: Vec<String> = errors
                .iter()
                .take(3)
                .map(|(path, error)| format!("{path}: {error}"))
                .collect();
            format!(
                "not a valid glTF file: {}{}",
                shown.join("; "),
                if errors.len() > 3 { "; ..." } else { "" }
            )
        }
        _ => "not a valid glTF file".into(),
    })
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
                let read = accessors.read::<3>(normal, Use::Normal)?;
                if read.len() != count as usize {
                    return Err(format!(
                        "{what}: NORMAL has {} elements, POSITION {count}",
                        read.len()
                    ));
                }
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
