//! Refit of a deforming mesh's tree: the mesh arrives with new positions over the same triangle
//! list, and its tree keeps its topology and takes the new boxes ([`crate::bvh::Bvh::refit`])
//! while its SAH cost stays within [`REFIT_LIMIT`] of the cost it had when last built.

use super::mesh_tree::MeshSpaceTriangles;
use super::MeshTree;
use crate::build::BuildSettings;
use crate::bvh::Bvh;
use crate::scene::{Mesh, RenderSpace};

/// How far refits may wear a tree ([`MeshTree::sah_growth`]) before the mesh is rebuilt: past
/// it a build's tree traces about a fifth less work; measured in docs/two-level.md, "Refit".
pub const REFIT_LIMIT: f32 = 1.2;

/// The cost refits are judged by: the SAH cost relative to the root's area, times the square
/// root of that area in object space. Relative cost alone falls as a swinging arm grows the
/// root box; times the area it counts rays that never meet the mesh; between the two it follows
/// the cost of a build over the same frame (measured, docs/two-level.md).
pub(super) fn wear_cost(bvh: &Bvh, space: &RenderSpace, settings: &BuildSettings) -> f32 {
    let Some(root) = bvh.nodes.first() else {
        return 0.0;
    };
    let relative = bvh.sah_cost(settings.traversal_cost, settings.intersection_cost);
    relative * (root.bounds().half_area().sqrt() / space.scale as f32)
}

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

    /// The tree's cost over its cost when last built (1 for a tree just built, about its SAH
    /// cost over a build's over the same positions after refits).
    pub fn sah_growth(&self, settings: &BuildSettings) -> f32 {
        if self.built_cost > 0.0 {
            wear_cost(&self.bvh, &self.space, settings) / self.built_cost
        } else {
            1.0
        }
    }

    /// Whether refits have worn the tree past [`REFIT_LIMIT`]: it is rebuilt.
    pub fn is_worn(&self, settings: &BuildSettings) -> bool {
        self.sah_growth(settings) > REFIT_LIMIT
    }
}
