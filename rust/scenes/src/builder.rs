//! Accumulates positions and triangles of one mesh.

use antumbra_core::scene::Mesh;
use glam::DVec3;

#[derive(Default)]
pub(crate) struct MeshBuilder {
    pub positions: Vec<glam::Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl MeshBuilder {
    pub fn new() -> Self {
        MeshBuilder::default()
    }

    /// Adds a vertex (computed in f64, stored in f32 as Blender does) and returns its index.
    pub fn vertex(&mut self, p: DVec3) -> u32 {
        self.positions.push(p.as_vec3());
        (self.positions.len() - 1) as u32
    }

    pub fn next_index(&self) -> u32 {
        self.positions.len() as u32
    }

    pub fn triangle(&mut self, a: u32, b: u32, c: u32) {
        self.triangles.push([a, b, c]);
    }

    /// Two triangles of the quad `a b c d` given counter-clockwise seen from the front.
    pub fn quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.triangles.push([a, b, c]);
        self.triangles.push([a, c, d]);
    }

    pub fn build(self, name: impl Into<String>) -> Mesh {
        Mesh::new(name, self.positions, self.triangles)
    }
}
