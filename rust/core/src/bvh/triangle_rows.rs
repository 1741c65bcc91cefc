//! The triangles of a tree as SIMD rows: blocks of four consecutive triangle slots, each block
//! the nine coordinates (vertex x axis) as rows of four lanes, so a leaf's triangles are a few
//! neighbouring cache lines that the leaf test (`trace::wide::leaf`) loads a row at a time.

use glam::Vec3;

/// Four triangle slots: `rows[3 * v + axis][lane]`.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
pub(crate) struct Block {
    pub(crate) rows: [[f32; 4]; 9],
}

/// The triangles of a tree in blocks of four slots (slot `s` is lane `s % 4` of block `s / 4`),
/// followed by two zero blocks so that an eight-lane window starting at any block stays inside.
#[derive(Clone, Debug, Default)]
pub struct TriangleRows {
    pub(crate) blocks: Vec<Block>,
}

impl TriangleRows {
    pub fn new(triangles: &[[Vec3; 3]]) -> Self {
        let mut blocks = vec![Block::default(); triangles.len().div_ceil(4) + 2];
        for (slot, t) in triangles.iter().enumerate() {
            let block = &mut blocks[slot / 4];
            for (v, vertex) in t.iter().enumerate() {
                for axis in 0..3 {
                    block.rows[3 * v + axis][slot % 4] = vertex[axis];
                }
            }
        }
        TriangleRows { blocks }
    }

    pub fn bytes(&self) -> usize {
        self.blocks.len() * std::mem::size_of::<Block>()
    }
}
