use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// A triangle mesh in object space, as Blender's evaluated mesh gives it after triangulation.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn new(name: impl Into<String>, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        Mesh {
            name: name.into(),
            positions,
            triangles,
        }
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

    /// A content hash (FNV-1a over the vertex and triangle counts and the little-endian bytes of
    /// positions and indices; the name is not hashed) so that unchanged meshes can be recognised
    /// across frames without comparing them element by element.
    pub fn content_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h ^= b as u64;
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        };
        eat(&(self.positions.len() as u64).to_le_bytes());
        for p in &self.positions {
            for c in p.to_array() {
                eat(&c.to_bits().to_le_bytes());
            }
        }
        eat(&(self.triangles.len() as u64).to_le_bytes());
        for t in &self.triangles {
            for i in t {
                eat(&i.to_le_bytes());
            }
        }
        h
    }
}
