//! Light sampling in render space: for a shading point, where its shadow rays go.

use glam::{DMat4, DVec3, Vec3};

use crate::sampling::concentric_disk;
use crate::scene::{AreaShape, Light, LightKind, RenderSpace};

/// Where one shadow ray goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightSample {
    /// A point on the light: the ray ends there.
    Point(Vec3),
    /// A direction towards the sun (unit length): the ray is unbounded.
    Direction(Vec3),
}

/// One light prepared for sampling in render space.
#[derive(Clone, Debug)]
pub struct LightSampler {
    pub name: String,
    kind: Prepared,
    /// One sample is exact (hard light).
    pub hard: bool,
}

#[derive(Clone, Debug)]
enum Prepared {
    Sphere {
        center: Vec3,
        radius: f32,
        /// For spots: the cone axis (unit) and the cosine of the half angle.
        cone: Option<(Vec3, f32)>,
    },
    Sun {
        /// Unit direction towards the sun.
        to_sun: Vec3,
        tan_half_angle: f32,
        t1: Vec3,
        t2: Vec3,
    },
    Area {
        render_from_light: DMat4,
        shape: AreaShape,
        size: [f64; 2],
        /// Unit emission direction (the light's -Z): points behind the light are not lit.
        facing: Vec3,
        center: Vec3,
    },
}

impl LightSampler {
    pub fn new(light: &Light, space: &RenderSpace) -> Self {
        let render_from_world =
            DMat4::from_scale(DVec3::splat(space.scale)) * DMat4::from_translation(-space.origin);
        let center = space.point(light.position()).as_vec3();
        let kind = match light.kind {
            LightKind::Point { radius } => Prepared::Sphere {
                center,
                radius: space.length(radius) as f32,
                cone: None,
            },
            LightKind::Spot {
                radius, spot_size, ..
            } => Prepared::Sphere {
                center,
                radius: space.length(radius) as f32,
                cone: Some((light.direction().as_vec3(), (spot_size * 0.5).cos() as f32)),
            },
            LightKind::Sun { angle } => {
                let to_sun = (-light.direction()).as_vec3();
                let (t1, t2) = to_sun.any_orthonormal_pair();
                Prepared::Sun {
                    to_sun,
                    tan_half_angle: (angle * 0.5).tan() as f32,
                    t1,
                    t2,
                }
            }
            LightKind::Area {
                shape,
                size_x,
                size_y,
            } => {
                let size_y = match shape {
                    AreaShape::Square | AreaShape::Disk => size_x,
                    AreaShape::Rectangle | AreaShape::Ellipse => size_y,
                };
                Prepared::Area {
                    render_from_light: render_from_world * light.world_from_light,
                    shape,
                    size: [size_x, size_y],
                    facing: light.direction().as_vec3(),
                    center,
                }
            }
        };
        LightSampler {
            name: light.name.clone(),
            kind,
            hard: light.is_hard(),
        }
    }

    /// False when the light cannot reach `p` at all: outside a spot's cone, behind an area light.
    pub fn reaches(&self, p: Vec3) -> bool {
        match &self.kind {
            Prepared::Sphere {
                center,
                cone: Some((axis, cos_half)),
                ..
            } => {
                let d = p - *center;
                let len = d.length();
                len > 0.0 && axis.dot(d) >= cos_half * len
            }
            Prepared::Area { facing, center, .. } => facing.dot(p - *center) > 0.0,
            _ => true,
        }
    }

    /// The sample for `u` in [0,1)^2 as seen from shading point `p`.
    #[inline]
    pub fn sample(&self, p: Vec3, u: [f32; 2]) -> LightSample {
        self.seen_from(p).sample(u)
    }

    /// The light as seen from shading point `p`: what its samples share, made once for all of
    /// a point's samples.
    #[inline]
    pub fn seen_from(&self, p: Vec3) -> LightFrom<'_> {
        let disk = match &self.kind {
            Prepared::Sphere { center, radius, .. } if *radius != 0.0 => disk_axes(p, *center),
            _ => (Vec3::ZERO, Vec3::ZERO),
        };
        LightFrom { light: self, disk }
    }
}

/// What a light's samples are made of, for the tile's lanes ([`super::sample_lanes`]): the
/// same arithmetic as [`LightFrom::sample`], read apart.
#[derive(Clone, Copy, Debug)]
pub(super) enum LightLanes {
    /// Every sample is this one (a sphere of radius 0, a sun of angle 0).
    Fixed(LightSample),
    /// A sphere: a disk facing each point ([`disk_axes`]), scaled by `radius`.
    Sphere { center: Vec3, radius: f32 },
    /// A sun: the disk of directions around `to_sun`, normalised.
    Sun {
        to_sun: Vec3,
        tan_half_angle: f32,
        t1: Vec3,
        t2: Vec3,
    },
    /// An area light: sampled one at a time ([`LightFrom::sample`]).
    Area,
}

impl LightSampler {
    /// How this light's samples are made ([`LightLanes`]).
    pub(super) fn lanes(&self) -> LightLanes {
        match &self.kind {
            Prepared::Sphere { center, radius, .. } if *radius == 0.0 => {
                LightLanes::Fixed(LightSample::Point(*center))
            }
            Prepared::Sphere { center, radius, .. } => LightLanes::Sphere {
                center: *center,
                radius: *radius,
            },
            Prepared::Sun {
                to_sun,
                tan_half_angle,
                ..
            } if *tan_half_angle == 0.0 => LightLanes::Fixed(LightSample::Direction(*to_sun)),
            Prepared::Sun {
                to_sun,
                tan_half_angle,
                t1,
                t2,
            } => LightLanes::Sun {
                to_sun: *to_sun,
                tan_half_angle: *tan_half_angle,
                t1: *t1,
                t2: *t2,
            },
            Prepared::Area { .. } => LightLanes::Area,
        }
    }
}

/// The axes of a sphere light's disk seen from `p` (a sphere seen from a point is a disk facing
/// it, as Blender samples it).
#[inline(always)]
pub(super) fn disk_axes(p: Vec3, center: Vec3) -> (Vec3, Vec3) {
    (p - center).normalize_or(Vec3::Z).any_orthonormal_pair()
}

/// A light as seen from one shading point ([`LightSampler::seen_from`]).
#[derive(Clone, Copy, Debug)]
pub struct LightFrom<'a> {
    light: &'a LightSampler,
    /// A sphere light's disk axes facing the point.
    disk: (Vec3, Vec3),
}

impl LightFrom<'_> {
    /// The sample for `u` in [0,1)^2.
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> LightSample {
        match &self.light.kind {
            Prepared::Sphere { center, radius, .. } => {
                if *radius == 0.0 {
                    return LightSample::Point(*center);
                }
                let (t1, t2) = self.disk;
                let d = concentric_disk(u);
                LightSample::Point(*center + (t1 * d[0] + t2 * d[1]) * *radius)
            }
            Prepared::Sun {
                to_sun,
                tan_half_angle,
                t1,
                t2,
            } => {
                if *tan_half_angle == 0.0 {
                    return LightSample::Direction(*to_sun);
                }
                let d = concentric_disk(u);
                let w = *to_sun + (*t1 * d[0] + *t2 * d[1]) * *tan_half_angle;
                LightSample::Direction(w.normalize())
            }
            Prepared::Area {
                render_from_light,
                shape,
                size,
                ..
            } => {
                let (x, y) = match shape {
                    AreaShape::Square | AreaShape::Rectangle => {
                        ((u[0] as f64 - 0.5) * size[0], (u[1] as f64 - 0.5) * size[1])
                    }
                    AreaShape::Disk | AreaShape::Ellipse => {
                        let d = concentric_disk(u);
                        (d[0] as f64 * 0.5 * size[0], d[1] as f64 * 0.5 * size[1])
                    }
                };
                LightSample::Point(
                    render_from_light
                        .transform_point3(DVec3::new(x, y, 0.0))
                        .as_vec3(),
                )
            }
        }
    }
}
