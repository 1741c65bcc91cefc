//! Refit of a deforming mesh's tree: the mesh arrives with new positions over the same triangle
//! list, and its tree keeps its topology and takes the new boxes ([`crate::bvh::Bvh::refit`])
//! while its SAH cost stays within [`REFIT_LIMIT`] of the cost it had when last built.

use super::mesh_tree::{sah_cost, MeshSpaceTriangles};
use super::MeshTree;
use crate::build::BuildSettings;
use crate::scene::Mesh;

/// How far a refit tree's SAH cost (relative to its root's area) may grow over its last build's
/// before the mesh is rebuilt; measured in docs/two-level.md, "Refit".
pub const REFIT_LIMIT: f32 = 1.3;

impl MeshTree {
    /// This tree over `mesh`, which must be `built_over` (the mesh the tree was built or last
    /// refit over) with new positions: the same topology with every box recomputed. `None`
    /// when the triangle list or the vertex count differ, or when another set of triangles is
    /// degenerate (left out) in `mesh`: those take a build.
    pub fn refit(&self, built_over: &Mesh, mesh: &Mesh) -> Option<MeshTree> {
        if mesh.positions.len() != built_over.positions.len()
            || mesh.triangles != built_over.triangles
            || !self.objects.is_empty()
        {
            return None;
        }
        let placed = MeshSpaceTriangles::of(mesh);
        if placed.primitives != self.primitives {
            return None;
        }
        let mut bvh = self.bvh.clone();
        bvh.refit(&placed.triangles);
        Some(MeshTree {
            space: placed.space,
            triangles: placed.triangles,
            primitives: placed.primitives,
            objects: Vec::new(),
            bvh,
            bounds: placed.bounds,
            degenerate: placed.degenerate,
            built_cost: self.built_cost,
        })
    }

    /// The tree's SAH cost over its cost when last built (1 for a tree just built).
    pub fn sah_growth(&self, settings: &BuildSettings) -> f32 {
        if self.built_cost > 0.0 {
            sah_cost(&self.bvh, settings) / self.built_cost
        } else {
            1.0
        }
    }

    /// Whether refits have worn the tree past [`REFIT_LIMIT`]: it is rebuilt.
    pub fn is_worn(&self, settings: &BuildSettings) -> bool {
        self.sah_growth(settings) > REFIT_LIMIT
    }
}
