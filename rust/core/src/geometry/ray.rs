use glam::{BVec3, Vec3};

use super::gamma;

/// A ray segment `origin + t * direction` for t in (`t_min`, `t_max`). The direction need not be
/// normalised: shadow rays use the vector to the light sample with `t_max` = 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Self {
        Ray {
            origin,
            direction,
            t_min,
            t_max,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
}

/// Per-ray values for the slab test, computed once per ray.
///
/// Near and far planes are chosen by the sign bit of each direction component (so -0.0 picks
/// the planes of a negative direction). A zero component gives an infinite reciprocal: the slab
/// distances are then -inf/+inf when the origin lies inside the slab, +inf/-inf (a miss) when
/// it lies outside, and NaN when it lies exactly on a plane. `f32::max`/`f32::min` return the
/// non-NaN operand, so such a plane never rejects the box: conservative, as it must be (the
/// triangle test makes the final decision). The far distance is enlarged by 1 + 2·gamma(3) to
/// cover the rounding of the subtraction and the multiplication (pbrt-v4, section 6.8.2).
#[derive(Clone, Copy, Debug)]
pub struct RayBoxPrecomp {
    pub origin: Vec3,
    pub inv_dir: Vec3,
    /// Per axis: true if the direction component has its sign bit set.
    pub neg: BVec3,
}

pub(crate) const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

impl RayBoxPrecomp {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction;
        RayBoxPrecomp {
            origin: ray.origin,
            inv_dir: Vec3::ONE / d,
            neg: BVec3::new(
                d.x.is_sign_negative(),
                d.y.is_sign_negative(),
                d.z.is_sign_negative(),
            ),
        }
    }

    /// Entry distance of the box when the segment (t_min, t_max) overlaps it, else `None`.
    #[inline(always)]
    pub fn hit(&self, min: Vec3, max: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let near = (Vec3::select(self.neg, max, min) - self.origin) * self.inv_dir;
        let far = (Vec3::select(self.neg, min, max) - self.origin) * self.inv_dir;
        let t_near = near.x.max(near.y).max(near.z).max(t_min);
        let t_far = (far.x.min(far.y).min(far.z) * FAR_SCALE).min(t_max);
        (t_near <= t_far).then_some(t_near)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit() -> (Vec3, Vec3) {
        (Vec3::ZERO, Vec3::ONE)
    }

    #[test]
    fn axis_parallel_rays_with_zero_and_negative_zero() {
        let (lo, hi) = unit();
        for dz in [0.0f32, -0.0] {
            for dy in [0.0f32, -0.0] {
                let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::new(1.0, dy, dz), 0.0, 10.0);
                assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 10.0).is_some());
                let miss = Ray::new(Vec3::new(-1.0, 1.5, 0.5), Vec3::new(1.0, dy, dz), 0.0, 10.0);
                assert!(RayBoxPrecomp::new(&miss).hit(lo, hi, 0.0, 10.0).is_none());
            }
        }
    }

    #[test]
    fn ray_on_the_slab_plane_is_not_culled() {
        let (lo, hi) = unit();
        // Origin exactly on the y = 0 face, direction with y = 0: 0 * inf = NaN.
        let ray = Ray::new(
            Vec3::new(-1.0, 0.0, 0.5),
            Vec3::new(1.0, 0.0, 0.0),
            0.0,
            10.0,
        );
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 10.0).is_some());
        // A flat box (zero thickness in y) is hit by a ray crossing it.
        let flat_hi = Vec3::new(1.0, 0.0, 1.0);
        let down = Ray::new(
            Vec3::new(0.5, 1.0, 0.5),
            Vec3::new(0.0, -1.0, -0.0),
            0.0,
            10.0,
        );
        assert!(RayBoxPrecomp::new(&down)
            .hit(lo, flat_hi, 0.0, 10.0)
            .is_some());
    }

    #[test]
    fn segment_limits() {
        let (lo, hi) = unit();
        let ray = Ray::new(Vec3::new(-2.0, 0.5, 0.5), Vec3::X, 0.0, 1.5);
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 1.5).is_none());
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 0.0, 2.0).is_some());
        assert!(RayBoxPrecomp::new(&ray).hit(lo, hi, 3.5, 5.0).is_none());
    }
}
