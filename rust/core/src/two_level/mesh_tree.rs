use glam::{DVec3, Vec3};

use super::refit::wear_cost;
use crate::build::{build_binned_sah, BuildSettings};
use crate::bvh::Bvh;
use crate::geometry::Aabb;
use crate::scene::{is_degenerate, Mesh, RenderSpace, TriangleSet};

/// One mesh's triangles in mesh space (its object space re-centred and scaled by a power of two
/// into about [-1, 1], as [`RenderSpace`] does for a flat frame, so every mesh traces at the
/// precision a flat scene does wherever and at whatever scale its objects place it) and the
/// binary tree over them. Kept across frames while the mesh is the same `Arc`.
#[derive(Clone, Debug)]
pub struct MeshTree {
    pub space: RenderSpace,
    /// Mesh-space triangles by the ids the tree's hits carry; zero-area ones are left out.
    pub triangles: Vec<[Vec3; 3]>,
    /// The mesh's triangle index (`TriangleRef::primitive`) of each id.
    pub primitives: Vec<u32>,
    /// The object of each id, for a tree over several objects' triangles ([`MeshTree::of_set`]);
    /// empty for one mesh's tree (the instance names the object).
    pub objects: Vec<u32>,
    pub bvh: Bvh,
    /// Bounds of `triangles` (mesh space).
    pub bounds: Aabb,
    /// Zero-area triangles left out.
    pub degenerate: usize,
    /// The tree's cost as refits wear it ([`MeshTree::sah_growth`]) when it was last built.
    pub built_cost: f32,
}

impl MeshTree {
    /// Fits the mesh space, keeps the triangles of non-zero area and builds a SAH tree.
    pub fn build(mesh: &Mesh, settings: &BuildSettings) -> Self {
        let placed = MeshSpaceTriangles::of(mesh);
        let bvh = build_binned_sah(&placed.triangles, settings);
        MeshTree {
            built_cost: wear_cost(&bvh, &placed.space, settings),
            space: placed.space,
            triangles: placed.triangles,
            primitives: placed.primitives,
            objects: Vec::new(),
            bvh,
            bounds: placed.bounds,
            degenerate: placed.degenerate,
        }
    }

    /// A tree over render-space triangles of several objects (a flat set): its space is render
    /// space itself, so an instance of it maps rays exactly and its answers are the flat
    /// tree's over the same triangles.
    pub fn of_set(set: TriangleSet, settings: &BuildSettings) -> Self {
        let bvh = build_binned_sah(&set.vertices, settings);
        MeshTree {
            built_cost: wear_cost(&bvh, &RenderSpace::IDENTITY, settings),
            space: RenderSpace::IDENTITY,
            bounds: set.bounds(),
            primitives: set.refs.iter().map(|r| r.primitive).collect(),
            objects: set.refs.iter().map(|r| r.object).collect(),
            triangles: set.vertices,
            bvh,
            degenerate: set.degenerate,
        }
    }

    /// Bytes held: the triangles, their primitive indices and the tree.
    pub fn bytes(&self) -> usize {
        self.triangles.len() * std::mem::size_of::<[Vec3; 3]>()
            + (self.primitives.len() + self.objects.len()) * 4
            + self.bvh.bytes()
    }
}

/// A mesh's triangles in its fitted mesh space, the zero-area ones left out: what a tree is
/// built or refit over.
pub(super) struct MeshSpaceTriangles {
    pub(super) space: RenderSpace,
    pub(super) triangles: Vec<[Vec3; 3]>,
    pub(super) primitives: Vec<u32>,
    pub(super) bounds: Aabb,
    pub(super) degenerate: usize,
}

impl MeshSpaceTriangles {
    pub(super) fn of(mesh: &Mesh) -> Self {
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for p in &mesh.positions {
            min = min.min(p.as_dvec3());
            max = max.max(p.as_dvec3());
        }
        let space = RenderSpace::fit(min, max);
        let positions: Vec<Vec3> = mesh
            .positions
            .iter()
            .map(|p| space.point(p.as_dvec3()).as_vec3())
            .collect();
        let mut triangles = Vec::with_capacity(mesh.triangles.len());
        let mut primitives = Vec::with_capacity(mesh.triangles.len());
        let mut bounds = Aabb::EMPTY;
        let mut degenerate = 0;
        for (primitive, tri) in mesh.triangles.iter().enumerate() {
            let v = tri.map(|i| positions[i as usize]);
            if is_degenerate(tri.map(|i| mesh.positions[i as usize]))
                || (v[1] - v[0]).cross(v[2] - v[0]) == Vec3::ZERO
            {
                degenerate += 1;
                continue;
            }
            bounds.grow(&Aabb::of_triangle(&v));
            triangles.push(v);
            primitives.push(primitive as u32);
        }
        MeshSpaceTriangles {
            space,
            triangles,
            primitives,
            bounds,
            degenerate,
        }
    }
}
