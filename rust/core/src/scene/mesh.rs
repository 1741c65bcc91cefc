use glam::Vec3;
use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::Xxh3;

use super::material::{validate_mesh_alpha, UvMap};
use crate::{Error, Result};

/// A triangle mesh in object space, as Blender's evaluated mesh gives it after triangulation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Shading normals at each triangle's three corners (Blender's corner normals, custom ones
    /// included), parallel to `triangles`; empty for a flat-shaded mesh. Only the `shading`
    /// facing convention reads them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub normals: Vec<[Vec3; 3]>,
    /// Each triangle's material slot (Blender's `material_index`), parallel to `triangles`;
    /// empty when the mesh's objects give none of its slots an alpha material (all slot 0).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub material_slots: Vec<u32>,
    /// The UV maps its alpha materials read, each per triangle corner; empty without alpha.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub uv_maps: Vec<UvMap>,
}

impl Mesh {
    pub fn new(name: impl Into<String>, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        Mesh {
            name: name.into(),
            positions,
            triangles,
            normals: Vec::new(),
            material_slots: Vec::new(),
            uv_maps: Vec::new(),
        }
    }

    /// The mesh with corner normals (one triple per triangle).
    pub fn with_normals(mut self, normals: Vec<[Vec3; 3]>) -> Self {
        self.normals = normals;
        self
    }

    /// The mesh with per-triangle material slots and the UV maps its alpha materials read.
    pub fn with_alpha(mut self, material_slots: Vec<u32>, uv_maps: Vec<UvMap>) -> Self {
        self.material_slots = material_slots;
        self.uv_maps = uv_maps;
        self
    }

    /// The material slot of triangle `t` (0 without slots).
    #[inline]
    pub fn material_slot(&self, t: usize) -> u32 {
        self.material_slots.get(t).copied().unwrap_or(0)
    }

    /// The UV map named `name`, if the mesh has it.
    pub fn uv_map(&self, name: &str) -> Option<&UvMap> {
        self.uv_maps.iter().find(|m| m.name == name)
    }

    /// Rejects non-finite positions and out-of-range indices, naming the mesh and the first bad index.
    pub fn validate(&self) -> Result<()> {
        for (index, p) in self.positions.iter().enumerate() {
            for value in p.to_array() {
                if !value.is_finite() {
                    return Err(Error::NonFinite {
                        owner: format!("mesh '{}'", self.name),
                        what: "vertex position",
                        index,
                        value: value as f64,
                    });
                }
            }
        }
        if !self.normals.is_empty() && self.normals.len() != self.triangles.len() {
            return Err(Error::invalid(
                format!("mesh '{}'", self.name),
                format!(
                    "{} corner-normal triples for {} triangles (give one per triangle or none)",
                    self.normals.len(),
                    self.triangles.len()
                ),
            ));
        }
        for (index, corners) in self.normals.iter().enumerate() {
            if let Some(value) = corners
                .iter()
                .flat_map(|n| n.to_array())
                .find(|v| !v.is_finite())
            {
                return Err(Error::NonFinite {
                    owner: format!("mesh '{}'", self.name),
                    what: "corner normal",
                    index,
                    value: value as f64,
                });
            }
        }
        validate_mesh_alpha(
            &self.name,
            self.triangles.len(),
            &self.material_slots,
            &self.uv_maps,
        )?;
        let vertex_count = self.positions.len();
        for (triangle, tri) in self.triangles.iter().enumerate() {
            if let Some(&vertex) = tri.iter().find(|&&v| v as usize >= vertex_count) {
                return Err(Error::IndexOutOfRange {
                    mesh: self.name.clone(),
                    triangle,
                    vertex,
                    vertex_count,
                });
            }
        }
        Ok(())
    }

    /// A content hash (64-bit XXH3 over the vertex count, the positions, the triangle count and
    /// the indices, all little-endian; the name is not hashed) so that unchanged meshes can be
    /// recognised across frames without comparing them element by element. The protocol's mesh
    /// hash (`docs/protocol.md`). XXH3, not BLAKE3: the hash only recognises a client's own
    /// meshes, so speed matters and collision resistance against an attacker does not. Corner
    /// normals, when there are any, follow (their count, then nine floats per triangle), so a
    /// mesh without them keeps the hash it always had; so do material slots (their count, then
    /// one u32 each) and UV maps (their count, then per map its name's length and UTF-8 bytes
    /// and six floats per triangle).
    pub fn content_hash(&self) -> u64 {
        let mut h = Xxh3::new();
        h.update(&(self.positions.len() as u64).to_le_bytes());
        hash_in_chunks(&mut h, &self.positions, |p| {
            p.to_array().map(f32::to_le_bytes)
        });
        h.update(&(self.triangles.len() as u64).to_le_bytes());
        hash_in_chunks(&mut h, &self.triangles, |t| t.map(u32::to_le_bytes));
        if !self.normals.is_empty() {
            h.update(&(self.normals.len() as u64).to_le_bytes());
            let corners = self.normals.as_flattened();
            hash_in_chunks(&mut h, corners, |n| n.to_array().map(f32::to_le_bytes));
        }
        if !self.material_slots.is_empty() {
            h.update(&(self.material_slots.len() as u64).to_le_bytes());
            for chunk in self.material_slots.chunks(1024) {
                let bytes: Vec<u8> = chunk.iter().flat_map(|s| s.to_le_bytes()).collect();
                h.update(&bytes);
            }
        }
        if !self.uv_maps.is_empty() {
            h.update(&(self.uv_maps.len() as u64).to_le_bytes());
            for map in &self.uv_maps {
                h.update(&(map.name.len() as u64).to_le_bytes());
                h.update(map.name.as_bytes());
                for chunk in map.corners.chunks(512) {
                    let bytes: Vec<u8> = chunk
                        .iter()
                        .flat_map(|c| c.as_flattened().iter().flat_map(|v| v.to_le_bytes()))
                        .collect();
                    h.update(&bytes);
                }
            }
        }
        h.digest()
    }
}

/// Feeds items as little-endian bytes through a stack buffer: XXH3 is fastest on long inputs,
/// and the bytes need no per-platform cast.
fn hash_in_chunks<T>(h: &mut Xxh3, items: &[T], bytes: impl Fn(&T) -> [[u8; 4]; 3]) {
    const ITEMS: usize = 512;
    let mut buf = [0u8; ITEMS * 12];
    for chunk in items.chunks(ITEMS) {
        for (out, item) in buf.chunks_exact_mut(12).zip(chunk) {
            out.copy_from_slice(bytes(item).as_flattened());
        }
        h.update(&buf[..chunk.len() * 12]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chunked hash equals XXH3 over the bytes the protocol sends, in one piece, and
    /// docs/protocol.md's example value.
    #[test]
    fn content_hash_is_xxh3_of_the_wire_bytes() {
        let positions: Vec<Vec3> = (0..1500)
            .map(|i| Vec3::new(i as f32, -0.5, 1e-3 * i as f32))
            .collect();
        let triangles: Vec<[u32; 3]> = (0..1400).map(|i| [i, i + 1, i + 2]).collect();
        let mesh = Mesh::new("m", positions.clone(), triangles.clone());
        let mut bytes = (positions.len() as u64).to_le_bytes().to_vec();
        bytes.extend(
            positions
                .iter()
                .flat_map(|p| p.to_array())
                .flat_map(f32::to_le_bytes),
        );
        bytes.extend((triangles.len() as u64).to_le_bytes());
        bytes.extend(triangles.iter().flatten().flat_map(|i| i.to_le_bytes()));
        assert_eq!(mesh.content_hash(), xxhash_rust::xxh3::xxh3_64(&bytes));

        let tri = Mesh::new("tri", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
        assert_eq!(tri.content_hash(), 0x6ffd_2beb_bb67_e42d);
        assert_eq!(
            tri.content_hash(),
            Mesh {
                name: "other".into(),
                ..tri.clone()
            }
            .content_hash()
        );
    }
}
