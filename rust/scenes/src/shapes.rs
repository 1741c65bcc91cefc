//! Solids whose tessellation follows a triangle density, so a whole scene can be fitted to a
//! triangle budget: [`fit_density`] finds the density (triangles per square metre) at which the
//! parts add up to the target, then [`Part::emit`] builds each part at that density.

use std::f64::consts::PI;

use glam::{DAffine3, DVec3};

use crate::builder::MeshBuilder;
use crate::primitives::{self as prim, ArchPanel, WindowRows};

/// Caps that keep one part from taking unbounded memory whatever the density.
const MAX_DIVS: u32 = 2048;
const MIN_SIDES: u32 = 6;

#[derive(Clone, Copy, Debug)]
pub(crate) enum Shape {
    Box {
        min: DVec3,
        max: DVec3,
    },
    /// Along local +Z from 0 to `height`; see [`prim::cylinder`].
    Cylinder {
        r0: f64,
        r1: f64,
        height: f64,
        caps: bool,
    },
    Ellipsoid {
        radii: DVec3,
    },
    Arch(ArchPanel),
    Windows(WindowRows),
}

/// A shape placed by a rigid transform, with a weight that scales the scene's density for it
/// (0 keeps the shape at its coarsest tessellation).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Part {
    pub shape: Shape,
    pub xf: DAffine3,
    pub weight: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Tess {
    Box([u32; 3]),
    Cylinder { sides: u32, rings: u32 },
    Ellipsoid { nu: u32, nv: u32 },
    Arch { segments: u32, radial: u32 },
    Windows { columns: u32 },
}

fn clamp_div(v: f64, min: u32) -> u32 {
    // NaN (a zero-sized part) and infinities fall back to the coarsest tessellation.
    if v.is_finite() {
        v.round().clamp(min as f64, MAX_DIVS as f64) as u32
    } else {
        min
    }
}

impl Part {
    pub fn new(shape: Shape, xf: DAffine3, weight: f64) -> Self {
        Part { shape, xf, weight }
    }

    fn area(&self) -> f64 {
        match self.shape {
            Shape::Box { min, max } => {
                let s = (max - min).abs();
                2.0 * (s.x * s.y + s.y * s.z + s.z * s.x)
            }
            Shape::Cylinder { r0, r1, height, .. } => {
                PI * (r0 + r1) * height + PI * (r0 * r0 + r1 * r1)
            }
            Shape::Ellipsoid { radii } => {
                // Surface of the sphere with the mean radius: close enough for a budget.
                let r = (radii.x + radii.y + radii.z) / 3.0;
                4.0 * PI * r * r
            }
            Shape::Arch(a) => {
                let face = a.width * a.height - 0.5 * PI * a.radius * a.radius;
                2.0 * face + PI * a.radius * a.depth + (2.0 * a.height + a.width) * a.depth
            }
            Shape::Windows(w) => w.width * w.height,
        }
    }

    /// The tessellation at `density`: the number of cells such that cells are about square and
    /// their triangles add up to density * weight * area.
    fn tessellation(&self, density: f64) -> Tess {
        let budget = (density * self.weight * self.area()).max(0.0);
        match self.shape {
            Shape::Box { min, max } => {
                let size = (max - min).abs();
                let area = self.area();
                // A box of cell size c has about 2 * area / c^2 triangles.
                let cell = (2.0 * area / budget).sqrt();
                Tess::Box([0, 1, 2].map(|a| clamp_div(size[a] / cell, 1)))
            }
            Shape::Cylinder {
                r0,
                r1,
                height,
                caps,
            } => {
                let circumference = PI * (r0 + r1);
                let sides = clamp_div(
                    (budget * 0.5 * circumference / height.max(1e-9)).sqrt(),
                    MIN_SIDES,
                );
                let caps_tris = if caps { 2.0 * sides as f64 } else { 0.0 };
                let rings = clamp_div((budget - caps_tris) / (2.0 * sides as f64), 1);
                Tess::Cylinder { sides, rings }
            }
            Shape::Ellipsoid { .. } => {
                let nv = clamp_div((budget / 4.0).sqrt(), 3);
                Tess::Ellipsoid { nu: 2 * nv, nv }
            }
            Shape::Arch(a) => {
                // Cells about square: radial cells span the band between opening and outline.
                let band = ((a.width * 0.5 + a.height) * 0.5 - a.radius).max(1e-3);
                let arc = PI * a.radius;
                let segments = clamp_div((budget * arc / (4.0 * band)).sqrt(), 8);
                let segments = prim::arch_segments(segments);
                let radial = clamp_div(
                    (budget - 4.0 * segments as f64) / (4.0 * segments as f64),
                    1,
                );
                Tess::Arch { segments, radial }
            }
            Shape::Windows(w) => {
                let per_column = 24.0 * w.floors() as f64;
                let columns = if per_column > 0.0 {
                    (budget / per_column)
                        .round()
                        .clamp(0.0, w.max_columns() as f64) as u32
                } else {
                    0
                };
                Tess::Windows { columns }
            }
        }
    }

    pub fn triangles(&self, density: f64) -> usize {
        match (self.shape, self.tessellation(density)) {
            (_, Tess::Box(divs)) => prim::box_triangles(divs),
            (Shape::Cylinder { caps, .. }, Tess::Cylinder { sides, rings }) => {
                prim::cylinder_triangles(sides, rings, caps)
            }
            (_, Tess::Ellipsoid { nu, nv }) => prim::sphere_triangles(nu, nv),
            (_, Tess::Arch { segments, radial }) => prim::arch_triangles(segments, radial),
            (Shape::Windows(w), Tess::Windows { columns }) => {
                prim::window_rows_triangles(&w, columns)
            }
            _ => 0,
        }
    }

    pub fn emit(&self, density: f64, mb: &mut MeshBuilder) {
        let xf = &self.xf;
        match (self.shape, self.tessellation(density)) {
            (Shape::Box { min, max }, Tess::Box(divs)) => prim::box_grid(mb, xf, min, max, divs),
            (
                Shape::Cylinder {
                    r0,
                    r1,
                    height,
                    caps,
                },
                Tess::Cylinder { sides, rings },
            ) => prim::cylinder(mb, xf, r0, r1, height, sides, rings, caps),
            (Shape::Ellipsoid { radii }, Tess::Ellipsoid { nu, nv }) => {
                prim::sphere(mb, xf, radii, nu, nv)
            }
            (Shape::Arch(a), Tess::Arch { segments, radial }) => {
                prim::arch_panel(mb, xf, &a, segments, radial)
            }
            (Shape::Windows(w), Tess::Windows { columns }) => {
                prim::window_rows(mb, xf, &w, columns)
            }
            _ => {}
        }
    }
}

/// The box with corners `min` and `max`, as [`Parts::cuboid`] takes it.
pub(crate) fn span(min: [f64; 3], max: [f64; 3]) -> (DVec3, DVec3) {
    (DVec3::from_array(min), DVec3::from_array(max))
}

/// A list of parts that becomes one mesh.
#[derive(Clone, Debug, Default)]
pub(crate) struct Parts(pub Vec<Part>);

impl Parts {
    pub fn new() -> Self {
        Parts(Vec::new())
    }

    pub fn add(&mut self, shape: Shape, xf: DAffine3, weight: f64) {
        self.0.push(Part::new(shape, xf, weight));
    }

    pub fn cuboid(&mut self, xf: DAffine3, min: DVec3, max: DVec3, weight: f64) {
        self.add(Shape::Box { min, max }, xf, weight);
    }

    /// Untransformed boxes of one weight, each given by its corners (a room's walls).
    pub fn cuboids(&mut self, boxes: impl IntoIterator<Item = (DVec3, DVec3)>, weight: f64) {
        for (min, max) in boxes {
            self.cuboid(DAffine3::IDENTITY, min, max, weight);
        }
    }

    /// A cylinder standing on `base` (in the frame `xf`), straight or tapered.
    pub fn column(
        &mut self,
        xf: DAffine3,
        base: DVec3,
        r0: f64,
        r1: f64,
        height: f64,
        weight: f64,
    ) {
        let shape = Shape::Cylinder {
            r0,
            r1,
            height,
            caps: true,
        };
        self.add(shape, xf * DAffine3::from_translation(base), weight);
    }

    /// Moves every part by `xf` (applied after the parts' own transforms).
    pub fn transformed(&self, xf: DAffine3) -> Parts {
        Parts(
            self.0
                .iter()
                .map(|p| Part {
                    xf: xf * p.xf,
                    ..*p
                })
                .collect(),
        )
    }

    pub fn extend(&mut self, other: Parts) {
        self.0.extend(other.0);
    }

    pub fn triangles(&self, density: f64) -> usize {
        self.0.iter().map(|p| p.triangles(density)).sum()
    }

    pub fn build(&self, density: f64, name: &str) -> antumbra_core::scene::Mesh {
        let mut mb = MeshBuilder::new();
        for p in &self.0 {
            p.emit(density, &mut mb);
        }
        mb.build(name)
    }
}

/// The density at which `groups` (each part list with how many times it is instanced) come
/// closest to `target` triangles, in ratio. Counting is analytic, so this costs no geometry.
pub(crate) fn fit_density(groups: &[(&Parts, usize)], target: usize) -> f64 {
    let count = |d: f64| -> usize { groups.iter().map(|(p, n)| p.triangles(d) * n).sum() };
    let target = target.max(1) as f64;
    let (mut lo, mut hi) = (1e-6f64, 1e9f64);
    for _ in 0..64 {
        let mid = (lo * hi).sqrt();
        if (count(mid) as f64) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let miss = |d: f64| (count(d).max(1) as f64 / target).ln().abs();
    if miss(lo) <= miss(hi) {
        lo
    } else {
        hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_parts() -> Parts {
        let mut p = Parts::new();
        p.cuboid(
            DAffine3::IDENTITY,
            DVec3::ZERO,
            DVec3::new(4.0, 3.0, 0.2),
            1.0,
        );
        p.column(DAffine3::IDENTITY, DVec3::ZERO, 0.3, 0.25, 3.0, 1.0);
        p.add(
            Shape::Ellipsoid {
                radii: DVec3::new(1.0, 1.0, 0.5),
            },
            DAffine3::IDENTITY,
            1.0,
        );
        p.add(
            Shape::Arch(ArchPanel {
                width: 3.0,
                height: 1.8,
                depth: 0.5,
                radius: 1.2,
            }),
            DAffine3::IDENTITY,
            1.0,
        );
        p.add(
            Shape::Windows(WindowRows {
                width: 20.0,
                height: 30.0,
                floor_height: 3.5,
            }),
            DAffine3::IDENTITY,
            1.0,
        );
        p
    }

    #[test]
    fn counts_match_what_is_built() {
        let parts = sample_parts();
        for density in [0.0, 1.0, 50.0, 3000.0] {
            let mesh = parts.build(density, "m");
            assert_eq!(
                mesh.triangles.len(),
                parts.triangles(density),
                "density {density}"
            );
        }
    }

    #[test]
    fn fitted_density_hits_the_target() {
        let parts = sample_parts();
        for target in [5_000, 50_000, 500_000] {
            let d = fit_density(&[(&parts, 3)], target);
            let got = parts.triangles(d) * 3;
            let ratio = got as f64 / target as f64;
            assert!((0.9..1.1).contains(&ratio), "target {target}: {got}");
        }
    }
}
