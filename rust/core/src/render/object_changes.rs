//! [`ObjectChanges`]: which of a frame's objects have changed (mesh, matrix or flags) in some
//! frame so far. Two levels give a dynamic object's mesh a tree of its own and keep the static
//! rest in one group tree.

use std::sync::Arc;

use rayon::prelude::*;
use xxhash_rust::xxh3::xxh3_64;

use crate::scene::{Object, Scene};

/// Per object (by its index in the frame's objects): its state hashed, and whether it has
/// changed. A frame with another object count starts over: every object static.
#[derive(Clone, Default)]
pub struct ObjectChanges {
    signatures: Arc<Vec<u64>>,
    dynamic: Arc<Vec<bool>>,
}

impl ObjectChanges {
    /// Advances to `scene`: an object is dynamic once its state differs from the last frame's.
    /// Returns whether any object changed since the last frame (or the objects did).
    pub fn advance(&mut self, scene: &Scene) -> bool {
        let signatures: Vec<u64> = (scene.objects.par_iter())
            .map(|o| signature(scene, o))
            .collect();
        let dynamic: Vec<bool> = if self.signatures.len() == signatures.len() {
            (signatures.iter())
                .zip(self.signatures.iter().zip(self.dynamic.iter()))
                .map(|(s, (was, dynamic))| *dynamic || s != was)
                .collect()
        } else {
            vec![false; signatures.len()]
        };
        let moved = *self.signatures != signatures;
        self.signatures = Arc::new(signatures);
        self.dynamic = Arc::new(dynamic);
        moved
    }

    /// Triangles of the objects that render (seen or casting shadows) and have not changed so
    /// far, and of those that have.
    pub fn static_and_dynamic_triangles(&self, scene: &Scene) -> (u64, u64) {
        let mut split = (0, 0);
        let rendered = scene.objects.iter().enumerate();
        for (i, o) in rendered.filter(|(_, o)| o.visible_to_camera || o.casts_shadow) {
            let triangles = scene
                .meshes
                .get(o.mesh)
                .map_or(0, |m| m.triangles.len() as u64);
            if self.is_dynamic(i) {
                split.1 += triangles;
            } else {
                split.0 += triangles;
            }
        }
        split
    }

    /// Whether object `i` has changed in some frame so far.
    pub fn is_dynamic(&self, i: usize) -> bool {
        self.dynamic.get(i).copied().unwrap_or(false)
    }

    /// Object `i`'s state, hashed (0 for an object the last frame did not have).
    pub fn signature(&self, i: usize) -> u64 {
        self.signatures.get(i).copied().unwrap_or(0)
    }
}

/// An object's mesh (by identity), matrix and flags, hashed: what makes it change.
fn signature(scene: &Scene, o: &Object) -> u64 {
    xxh3_64(&object_state(scene, o))
}

/// An object's mesh (by identity), matrix and flags as bytes: what makes it change, for the
/// per-object signatures and the frame's geometry key alike.
pub(super) fn object_state(scene: &Scene, o: &Object) -> [u8; 8 + 16 * 8 + 2] {
    let mut bytes = [0u8; 8 + 16 * 8 + 2];
    let mesh = Arc::as_ptr(&scene.meshes[o.mesh]) as usize as u64;
    bytes[..8].copy_from_slice(&mesh.to_le_bytes());
    for (i, v) in o.world_from_object.to_cols_array().iter().enumerate() {
        bytes[8 + 8 * i..16 + 8 * i].copy_from_slice(&v.to_bits().to_le_bytes());
    }
    bytes[136] = o.visible_to_camera as u8;
    bytes[137] = o.casts_shadow as u8;
    bytes
}
