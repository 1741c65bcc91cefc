//! What a caller hands in and gets back: rays in its own space, hits with its own triangle ids,
//! and the convention of the ray's t interval.

/// A ray `origin + t * direction` in the caller's space, for t in the interval its [`Interval`]
/// convention gives (`(t_near, t_far]` by default). The direction need not be unit length: t is
/// measured in multiples of it, and hit distances come back in those units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: [f64; 3],
    pub direction: [f64; 3],
    /// Start of the segment (excluded by [`Interval::OpenClosed`], included by [`Interval::Closed`]).
    pub t_near: f32,
    /// End of the segment, always included; `f32::INFINITY` for an unbounded ray.
    pub t_far: f32,
}

impl Ray {
    /// The whole half-line in front of `origin`: t in (0, inf).
    pub fn new(origin: [f64; 3], direction: [f64; 3]) -> Self {
        Ray::segment(origin, direction, 0.0, f32::INFINITY)
    }

    /// The segment between `t_near` and `t_far`.
    pub fn segment(origin: [f64; 3], direction: [f64; 3], t_near: f32, t_far: f32) -> Self {
        Ray {
            origin,
            direction,
            t_near,
            t_far,
        }
    }
}

/// Whether a hit exactly at `t_near` counts. `t_far` is included either way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Interval {
    /// `(t_near, t_far]`: antumbra's own, so a shadow ray leaving a surface at t = 0 does not
    /// hit the surface it leaves.
    #[default]
    OpenClosed,
    /// `[t_near, t_far]`: Embree's (`rtcIntersect1`/`rtcOccluded1`, and embreex, whose `tnear`
    /// is 0), so a ray starting on a triangle hits it at t = 0.
    Closed,
}

impl Interval {
    /// The exclusive lower bound the traversals take: `t_near` itself, or the largest float
    /// below it, so that `t > bound` is `t >= t_near` for every f32 t.
    pub(crate) fn exclusive_start(self, t_near: f32) -> f32 {
        match self {
            Interval::OpenClosed => t_near,
            Interval::Closed => t_near.next_down(),
        }
    }
}

/// A closest hit in the caller's terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The ray parameter: the hit point is `origin + t * direction` (in the caller's units; the
    /// normalisation into render space does not change it, see the crate documentation).
    pub t: f32,
    /// Index of the triangle in the caller's triangle list.
    pub triangle: u32,
    /// Barycentric coordinates as Embree gives them: the hit point is
    /// `(1 - u - v) * v0 + u * v1 + v * v2` for the triangle's vertices in the caller's order.
    pub u: f32,
    pub v: f32,
}
