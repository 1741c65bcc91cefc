//! [`ObjectChanges`]: which of a frame's objects have changed (mesh, matrix or flags) in some
//! frame so far, and which meshes are new. Two levels give a dynamic object's mesh a tree of
//! its own and keep the static rest in one group tree; `auto`'s structure weighs the triangles
//! whose trees two levels keep.

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
    /// The last frame's meshes by identity, sorted.
    meshes: Arc<Vec<usize>>,
}

/// What changed since the last frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameChange {
    /// Whether any object changed (or the objects did): a flat tree is then rebuilt.
    pub moved: bool,
    /// Triangles of the rendered objects (seen or casting shadows) whose mesh the last frame
    /// had too: static or rigidly moved, their trees are kept on two levels.
    pub kept_triangles: u64,
}

impl ObjectChanges {
    /// Advances to `scene`: an object is dynamic once its state differs from the last frame's.
    pub fn advance(&mut self, scene: &Scene) -> FrameChange {
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
        let mut meshes: Vec<usize> = scene.meshes.iter().map(mesh_id).collect();
        meshes.sort_unstable();
        let rendered = scene
            .objects
            .iter()
            .filter(|o| o.visible_to_camera || o.casts_shadow);
        let kept_triangles = rendered
            .filter_map(|o| scene.meshes.get(o.mesh))
            .filter(|m| self.meshes.binary_search(&mesh_id(m)).is_ok())
            .map(|m| m.triangles.len() as u64)
            .sum();
        self.signatures = Arc::new(signatures);
        self.dynamic = Arc::new(dynamic);
        self.meshes = Arc::new(meshes);
        FrameChange {
            moved,
            kept_triangles,
        }
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

/// A mesh's identity: a frame's unchanged mesh is the last frame's `Arc`.
fn mesh_id(mesh: &Arc<crate::scene::Mesh>) -> usize {
    Arc::as_ptr(mesh) as usize
}

/// An object's mesh (by identity), matrix and flags as bytes: what makes it change, for the
/// per-object signatures and the frame's geometry key alike.
pub(super) fn object_state(scene: &Scene, o: &Object) -> [u8; 8 + 16 * 8 + 2] {
    let mut bytes = [0u8; 8 + 16 * 8 + 2];
    let mesh = mesh_id(&scene.meshes[o.mesh]) as u64;
    bytes[..8].copy_from_slice(&mesh.to_le_bytes());
    for (i, v) in o.world_from_object.to_cols_array().iter().enumerate() {
        bytes[8 + 8 * i..16 + 8 * i].copy_from_slice(&v.to_bits().to_le_bytes());
    }
    bytes[136] = o.visible_to_camera as u8;
    bytes[137] = o.casts_shadow as u8;
    bytes
}
