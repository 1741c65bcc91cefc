use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Axis-aligned bounding box. The empty box has min = +inf and max = -inf so that growing it by
/// anything gives that thing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    pub fn of_triangle(v: &[Vec3; 3]) -> Self {
        Aabb {
            min: v[0].min(v[1]).min(v[2]),
            max: v[0].max(v[1]).max(v[2]),
        }
    }

    #[inline]
    pub fn grow_point(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    #[inline]
    pub fn grow(&mut self, b: &Aabb) {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
    }

    #[inline]
    pub fn union(mut self, b: &Aabb) -> Aabb {
        self.grow(b);
        self
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Half the surface area (the SAH only needs ratios); 0 for an empty box.
    #[inline]
    pub fn half_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    pub fn contains(&self, b: &Aabb) -> bool {
        self.min.cmple(b.min).all() && self.max.cmpge(b.max).all()
    }
}
