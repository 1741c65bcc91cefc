//! The render-space normalisation, as `FrameGeometry` applies it to a frame: the caller's
//! vertices re-centred on their bounds and scaled by a power of two in f64, then rounded to f32;
//! rays moved in by the same map. Origins and directions move together (the direction by the
//! scale alone), so the ray parameter t is the same in both spaces and hits need no map back.

use antumbra_core::geometry::Ray as RenderRay;
use antumbra_core::scene::RenderSpace;
use antumbra_core::{Error, Result};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::{Interval, Ray};

/// A vertex the caller may hand in: f32 or f64 coordinates.
pub trait Point: Copy + Sync {
    fn to_dvec3(self) -> DVec3;
}

impl Point for [f32; 3] {
    fn to_dvec3(self) -> DVec3 {
        Vec3::from(self).as_dvec3()
    }
}

impl Point for [f64; 3] {
    fn to_dvec3(self) -> DVec3 {
        DVec3::from(self)
    }
}

/// The render space of `vertices`, fitted to their bounds, after checking that every vertex is
/// finite (so the bounds are).
pub(crate) fn fit<P: Point>(vertices: &[P]) -> Result<RenderSpace> {
    let mut min = DVec3::splat(f64::INFINITY);
    let mut max = DVec3::splat(f64::NEG_INFINITY);
    for (i, p) in vertices.iter().enumerate() {
        let p = p.to_dvec3();
        if let Some(axis) = (0..3).find(|&a| !p[a].is_finite()) {
            return Err(Error::NonFinite {
                owner: format!("vertex {i}"),
                what: "position",
                index: axis,
                value: p[axis],
            });
        }
        min = min.min(p);
        max = max.max(p);
    }
    Ok(RenderSpace::fit(min, max))
}

/// `ray` (number `index` of its batch) in render space, with the interval's start made
/// exclusive; an error names the ray and what is wrong with it.
pub(crate) fn render_ray(
    space: &RenderSpace,
    ray: &Ray,
    index: usize,
    interval: Interval,
) -> Result<RenderRay> {
    let owner = || format!("ray {index}");
    let (o, d) = (DVec3::from(ray.origin), DVec3::from(ray.direction));
    for (what, v) in [("origin", o), ("direction", d)] {
        if let Some(axis) = (0..3).find(|&a| !v[a].is_finite()) {
            return Err(Error::NonFinite {
                owner: owner(),
                what,
                index: axis,
                value: v[axis],
            });
        }
    }
    if d == DVec3::ZERO {
        return Err(Error::invalid(owner(), "direction is zero"));
    }
    if ray.t_near.is_nan() || ray.t_far.is_nan() {
        return Err(Error::invalid(
            owner(),
            format!(
                "t_near {} and t_far {} must be numbers",
                ray.t_near, ray.t_far
            ),
        ));
    }
    let origin = space.point(o).as_vec3();
    let direction = space.vector(d).as_vec3();
    if !origin.is_finite() {
        return Err(Error::invalid(
            owner(),
            format!("origin {o} is beyond f32's range once the scene is scaled into [-1, 1]"),
        ));
    }
    if !direction.is_finite() || direction == Vec3::ZERO {
        return Err(Error::invalid(
            owner(),
            format!(
                "direction {d} leaves f32's range once scaled with the scene (scale {})",
                space.scale
            ),
        ));
    }
    Ok(RenderRay::new(
        origin,
        direction,
        interval.exclusive_start(ray.t_near),
        ray.t_far,
    ))
}

/// Every ray of a batch in render space, or the first ray's error.
pub(crate) fn render_rays(
    space: &RenderSpace,
    rays: &[Ray],
    interval: Interval,
) -> Result<Vec<RenderRay>> {
    rays.par_iter()
        .enumerate()
        .map(|(i, r)| render_ray(space, r, i, interval))
        .collect()
}
