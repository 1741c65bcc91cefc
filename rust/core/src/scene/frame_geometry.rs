use glam::{DMat4, DVec3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::Scene;
use crate::geometry::Aabb;
use crate::Result;

/// The coordinate frame the tracer works in: world space re-centred on the scene and scaled by a
/// power of two (exact in floating point) so the scene spans roughly [-1, 1].
///
/// Why: f32 has 24 bits of mantissa. A scene modelled 1e6 units from the origin keeps only
/// 1/16-unit steps there, and the ray-origin offset of Wächter & Binder switches to a fixed
/// absolute epsilon near the origin, which is wrong for a millimetre-sized scene. Transforming in
/// f64 and re-centring first makes the answers independent of where and at what scale a scene
/// was modelled.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSpace {
    pub origin: DVec3,
    /// A power of two.
    pub scale: f64,
}

impl RenderSpace {
    pub const IDENTITY: RenderSpace = RenderSpace {
        origin: DVec3::ZERO,
        scale: 1.0,
    };

    /// Centre on `bounds` and scale the largest half-extent into [0.5, 1).
    pub fn fit(min: DVec3, max: DVec3) -> Self {
        if !(min.is_finite() && max.is_finite()) || min.cmpgt(max).any() {
            return RenderSpace::IDENTITY;
        }
        let origin = (min + max) * 0.5;
        let half = ((max - min) * 0.5).max_element();
        let scale = if half > 0.0 {
            2f64.powi(-(half.log2().floor() as i32) - 1)
        } else {
            1.0
        };
        RenderSpace { origin, scale }
    }

    pub fn point(&self, world: DVec3) -> DVec3 {
        (world - self.origin) * self.scale
    }

    /// Directions keep their length ratio; only the scale applies.
    pub fn vector(&self, world: DVec3) -> DVec3 {
        world * self.scale
    }

    pub fn length(&self, world: f64) -> f64 {
        world * self.scale
    }
}

/// Where a triangle came from: the object and the triangle's index in that object's mesh.
/// Stable across frames for the same object list, so a visible set from frame t-1 can be
/// applied to frame t even when meshes deform.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct TriangleRef {
    pub object: u32,
    pub primitive: u32,
}

impl TriangleRef {
    /// What a pixel whose ray hit nothing holds.
    pub const MISS: TriangleRef = TriangleRef {
        object: u32::MAX,
        primitive: u32::MAX,
    };
}

/// Render-space triangles of one ray class (camera or shadow). Triangle ids used by the tracers
/// are indices into these arrays.
#[derive(Clone, Debug, Default)]
pub struct TriangleSet {
    pub vertices: Vec<[Vec3; 3]>,
    pub refs: Vec<TriangleRef>,
    /// Zero-area triangles dropped from the set (they can never be hit).
    pub degenerate: usize,
}

impl TriangleSet {
    pub fn len(&self) -> usize {
        self.vertices.len()
    }
    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }
    /// The object of each triangle id (`TriangleRef::object`); u32::MAX (a miss) and ids out
    /// of range map to u32::MAX.
    pub fn objects_of(&self, ids: &[u32]) -> Vec<u32> {
        ids.iter()
            .map(|&id| {
                self.refs
                    .get(id as usize)
                    .map_or(u32::MAX, |r: &TriangleRef| r.object)
            })
            .collect()
    }
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for t in &self.vertices {
            for v in t {
                b.grow_point(*v);
            }
        }
        b
    }
}

/// One frame's geometry, ready for BVH builds.
#[derive(Clone, Debug)]
pub struct FrameGeometry {
    pub space: RenderSpace,
    /// Triangles seen by camera rays.
    pub camera: TriangleSet,
    /// Triangles that block shadow rays, when they differ from the camera set (some object is
    /// hidden from the camera or casts no shadow); `None` means the camera set serves both.
    pub shadow: Option<TriangleSet>,
}

impl FrameGeometry {
    /// Validates the scene and transforms every visible mesh into render space.
    pub fn from_scene(scene: &Scene) -> Result<Self> {
        scene.validate()?;
        Ok(Self::from_validated_scene(scene))
    }

    /// As [`FrameGeometry::from_scene`] for a scene the caller has just validated (the renderer
    /// validates every frame, also those whose geometry it reuses, so it does not pay twice).
    pub(crate) fn from_validated_scene(scene: &Scene) -> Self {
        let space = scene_render_space(scene);
        let same = scene
            .objects
            .iter()
            .all(|o| o.visible_to_camera == o.casts_shadow);
        let camera = collect(scene, &space, |_, o| o.visible_to_camera);
        let shadow = if same {
            None
        } else {
            Some(collect(scene, &space, |_, o| o.casts_shadow))
        };
        FrameGeometry {
            space,
            camera,
            shadow,
        }
    }

    pub fn shadow_set(&self) -> &TriangleSet {
        self.shadow.as_ref().unwrap_or(&self.camera)
    }
}

fn scene_render_space(scene: &Scene) -> RenderSpace {
    let (min, max) = scene_bounds(scene);
    RenderSpace::fit(min, max)
}

/// The world bounds of every object's mesh box (eight corners through its matrix, in f64).
/// Each mesh's box is found once, however many objects place it (a million instances of a
/// 100k-triangle mesh must not read its vertices a million times).
pub(crate) fn scene_bounds(scene: &Scene) -> (DVec3, DVec3) {
    let boxes: Vec<Option<Aabb>> = (scene.meshes.par_iter())
        .map(|mesh| {
            let mut local = Aabb::EMPTY;
            for &p in &mesh.positions {
                local.grow_point(p);
            }
            (!mesh.positions.is_empty()).then_some(local)
        })
        .collect();
    let empty = || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    (scene.objects.par_iter())
        .filter_map(|object| boxes[object.mesh].map(|b| (object, b)))
        .fold(empty, |(mut min, mut max), (object, local)| {
            for corner in 0..8 {
                let pick = |bit: usize, lo: f32, hi: f32| if corner & bit == 0 { lo } else { hi };
                let c = DVec3::new(
                    pick(1, local.min.x, local.max.x) as f64,
                    pick(2, local.min.y, local.max.y) as f64,
                    pick(4, local.min.z, local.max.z) as f64,
                );
                let w = object.world_from_object.transform_point3(c);
                min = min.min(w);
                max = max.max(w);
            }
            (min, max)
        })
        .reduce(empty, |(a0, a1), (b0, b1)| (a0.min(b0), a1.max(b1)))
}

/// The render-space triangles of the objects `include` picks (by index and object), in object
/// order: a flat frame's sets, and a two-level frame's group of static objects.
pub(crate) fn collect(
    scene: &Scene,
    space: &RenderSpace,
    include: impl Fn(usize, &super::Object) -> bool + Sync,
) -> TriangleSet {
    let parts: Vec<TriangleSet> = scene
        .objects
        .par_iter()
        .enumerate()
        .filter(|(i, o)| include(*i, o))
        .map(|(object_index, object)| {
            let mesh = &scene.meshes[object.mesh];
            let render_from_object = DMat4::from_scale(DVec3::splat(space.scale))
                * DMat4::from_translation(-space.origin)
                * object.world_from_object;
            let positions: Vec<Vec3> = mesh
                .positions
                .iter()
                .map(|p| render_from_object.transform_point3(p.as_dvec3()).as_vec3())
                .collect();
            let mut set = TriangleSet::default();
            set.vertices.reserve(mesh.triangles.len());
            set.refs.reserve(mesh.triangles.len());
            for (primitive, tri) in mesh.triangles.iter().enumerate() {
                let v = tri.map(|i| positions[i as usize]);
                if is_degenerate(tri.map(|i| mesh.positions[i as usize]))
                    || (v[1] - v[0]).cross(v[2] - v[0]) == Vec3::ZERO
                {
                    set.degenerate += 1;
                    continue;
                }
                set.vertices.push(v);
                set.refs.push(TriangleRef {
                    object: object_index as u32,
                    primitive: primitive as u32,
                });
            }
            set
        })
        .collect();
    let mut out = TriangleSet::default();
    out.vertices.reserve(parts.iter().map(|p| p.len()).sum());
    for part in parts {
        out.vertices.extend(part.vertices);
        out.refs.extend(part.refs);
        out.degenerate += part.degenerate;
    }
    out
}

/// Zero area in object space, decided in f64 where the differences and products of f32 vertices
/// of similar magnitude are exact, so collinear vertices give exactly zero and the rounding of the
/// object-to-render transform cannot turn them into a sliver. (A triangle that collapses only
/// after the transform is caught separately, in render space.)
pub(crate) fn is_degenerate(v: [Vec3; 3]) -> bool {
    let e1 = v[1].as_dvec3() - v[0].as_dvec3();
    let e2 = v[2].as_dvec3() - v[0].as_dvec3();
    e1.cross(e2) == DVec3::ZERO
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_space_scale_is_a_power_of_two_and_fits() {
        let s = RenderSpace::fit(
            DVec3::new(1e6, 1e6, 1e6),
            DVec3::new(1e6 + 10.0, 1e6 + 4.0, 1e6),
        );
        assert_eq!(s.scale.log2().fract(), 0.0);
        let p = s.point(DVec3::new(1e6 + 10.0, 1e6, 1e6));
        assert!(p.x > 0.5 && p.x <= 1.0, "{p}");
    }
}
