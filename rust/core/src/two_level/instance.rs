use glam::{DAffine3, DMat4, DVec3, Vec3};

use crate::geometry::{Aabb, Ray};
use crate::scene::RenderSpace;

/// An object placing a mesh tree, in 56 bytes: the affine map from render space into the mesh's
/// space (rows of f32, made in f64 from the exact composition), the tree and the object.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Instance {
    /// Rows `[m0 m1 m2 translation]` of mesh-from-render.
    pub mesh_from_render: [[f32; 4]; 3],
    /// Index of the mesh tree.
    pub mesh: u32,
    /// Index of the object in the frame's objects (what hits carry).
    pub object: u32,
}

const _: () = assert!(std::mem::size_of::<Instance>() == 56);

impl Instance {
    /// `None` when `render_from_mesh` is not invertible (an object scaled to nothing, which
    /// no ray can hit; a flat scene drops its triangles as zero-area).
    pub fn new(render_from_mesh: &DAffine3, mesh: u32, object: u32) -> Option<Self> {
        let det = render_from_mesh.matrix3.determinant();
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inverse = render_from_mesh.inverse();
        let m = inverse.matrix3;
        let t = inverse.translation;
        let row = |r: usize| {
            [
                m.x_axis[r] as f32,
                m.y_axis[r] as f32,
                m.z_axis[r] as f32,
                t[r] as f32,
            ]
        };
        let rows = [row(0), row(1), row(2)];
        rows.iter()
            .flatten()
            .all(|v| v.is_finite())
            .then_some(Instance {
                mesh_from_render: rows,
                mesh,
                object,
            })
    }

    /// The ray in mesh space with the same parameter: origin mapped as a point, direction as
    /// a vector (not renormalised), `t_min` and `t_max` unchanged. One f32 formula, used by
    /// the traversal and the brute-force reference alike.
    #[inline(always)]
    pub fn ray_to_mesh(&self, ray: &Ray) -> Ray {
        let [r0, r1, r2] = &self.mesh_from_render;
        let (o, d) = (ray.origin, ray.direction);
        let point = |r: &[f32; 4]| r[0] * o.x + r[1] * o.y + r[2] * o.z + r[3];
        let vector = |r: &[f32; 4]| r[0] * d.x + r[1] * d.y + r[2] * d.z;
        Ray {
            origin: Vec3::new(point(r0), point(r1), point(r2)),
            direction: Vec3::new(vector(r0), vector(r1), vector(r2)),
            t_min: ray.t_min,
            t_max: ray.t_max,
        }
    }
}

/// Render space from an object's mesh space: render space after world after object after the
/// mesh space's inverse, composed in f64.
pub fn render_from_mesh(
    render: &RenderSpace,
    world_from_object: &DMat4,
    mesh: &RenderSpace,
) -> DAffine3 {
    DAffine3::from_scale(DVec3::splat(render.scale))
        * DAffine3::from_translation(-render.origin)
        * DAffine3::from_mat4(*world_from_object)
        * DAffine3::from_translation(mesh.origin)
        * DAffine3::from_scale(DVec3::splat(1.0 / mesh.scale))
}

/// The render-space box of a mesh-space box under `render_from_mesh`: its eight corners in f64,
/// widened by 2^-20 of its size and magnitude and rounded outward, so it holds every point the
/// f32 ray transform can reach inside the mesh box (the top level must never cull an instance
/// the brute-force reference hits).
pub fn instance_box(render_from_mesh: &DAffine3, bounds: &Aabb) -> Aabb {
    if bounds.is_empty() {
        return Aabb::EMPTY;
    }
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    for corner in 0..8 {
        let pick = |bit: usize, lo: f32, hi: f32| if corner & bit == 0 { lo } else { hi } as f64;
        let c = DVec3::new(
            pick(1, bounds.min.x, bounds.max.x),
            pick(2, bounds.min.y, bounds.max.y),
            pick(4, bounds.min.z, bounds.max.z),
        );
        let p = render_from_mesh.transform_point3(c);
        min = min.min(p);
        max = max.max(p);
    }
    let pad = ((max - min).max_element() + min.abs().max(max.abs()).max_element()) * 2f64.powi(-20);
    let down = |v: f64| (v - pad) as f32;
    let up = |v: f64| (v + pad) as f32;
    Aabb::new(
        Vec3::new(down(min.x), down(min.y), down(min.z)).map(f32::next_down),
        Vec3::new(up(max.x), up(max.y), up(max.z)).map(f32::next_up),
    )
}
