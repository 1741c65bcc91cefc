//! Tessellated solids appended to a [`MeshBuilder`]: grids, boxes, cylinders, spheres, arched wall
//! panels, window rows and swept tubes. Each has a matching `*_triangles` function giving the
//! exact count it emits, so scenes can plan a triangle budget without building anything.
//!
//! Faces wind counter-clockwise seen from outside. Vertices on edges shared by two faces are
//! computed from the same numbers, so closed solids have no cracks for watertight ray tests.

use std::f64::consts::{PI, TAU};

use glam::{DAffine3, DQuat, DVec2, DVec3};

use crate::builder::MeshBuilder;

/// Linear interpolation that returns `a` and `b` exactly at `t = 0` and `t = 1`.
pub(crate) fn mix(a: f64, b: f64, t: f64) -> f64 {
    a * (1.0 - t) + b * t
}

/// Vertex indices of a grid made by [`grid`].
pub(crate) struct Grid {
    base: u32,
    cols: u32,
    rows: u32,
}

impl Grid {
    /// Index of vertex (i, j); wrapped directions take indices modulo their size.
    pub fn index(&self, i: u32, j: u32) -> u32 {
        self.base + (j % self.rows) * self.cols + (i % self.cols)
    }
}

/// An `nu` x `nv` grid of quads whose vertex (i, j) is `f(i, j)`. A wrapped direction reuses its
/// first column (row) as the last, closing the surface without a seam. Faces point along
/// `d/du x d/dv`.
pub(crate) fn grid(
    mb: &mut MeshBuilder,
    nu: u32,
    nv: u32,
    wrap_u: bool,
    wrap_v: bool,
    mut f: impl FnMut(u32, u32) -> DVec3,
) -> Grid {
    let cols = if wrap_u { nu } else { nu + 1 };
    let rows = if wrap_v { nv } else { nv + 1 };
    let g = Grid {
        base: mb.next_index(),
        cols,
        rows,
    };
    for j in 0..rows {
        for i in 0..cols {
            mb.vertex(f(i, j));
        }
    }
    for j in 0..nv {
        for i in 0..nu {
            mb.quad(
                g.index(i, j),
                g.index(i + 1, j),
                g.index(i + 1, j + 1),
                g.index(i, j + 1),
            );
        }
    }
    g
}

pub(crate) fn box_triangles(divs: [u32; 3]) -> usize {
    let [x, y, z] = divs.map(|d| d.max(1) as usize);
    4 * (x * y + y * z + z * x)
}

/// The box `min..max` in local space, each face a grid with `divs` cells along each axis.
pub(crate) fn box_grid(
    mb: &mut MeshBuilder,
    xf: &DAffine3,
    min: DVec3,
    max: DVec3,
    divs: [u32; 3],
) {
    let divs = divs.map(|d| d.max(1));
    let coords: [Vec<f64>; 3] = std::array::from_fn(|a| {
        (0..=divs[a])
            .map(|k| mix(min[a], max[a], k as f64 / divs[a] as f64))
            .collect()
    });
    for axis in 0..3 {
        let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
        for (fixed, (ua, va)) in [(min[axis], (a2, a1)), (max[axis], (a1, a2))] {
            grid(mb, divs[ua], divs[va], false, false, |i, j| {
                let mut p = DVec3::ZERO;
                p[axis] = fixed;
                p[ua] = coords[ua][i as usize];
                p[va] = coords[va][j as usize];
                xf.transform_point3(p)
            });
        }
    }
}

pub(crate) fn cylinder_triangles(sides: u32, rings: u32, caps: bool) -> usize {
    let (s, r) = (sides.max(3) as usize, rings.max(1) as usize);
    2 * s * r + if caps { 2 * s } else { 0 }
}

/// A (tapered) cylinder along local +Z from 0 to `height`, radius `r0` at the bottom and `r1` at
/// the top (both should be > 0), with optional flat caps.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cylinder(
    mb: &mut MeshBuilder,
    xf: &DAffine3,
    r0: f64,
    r1: f64,
    height: f64,
    sides: u32,
    rings: u32,
    caps: bool,
) {
    let (sides, rings) = (sides.max(3), rings.max(1));
    let g = grid(mb, sides, rings, true, false, |i, j| {
        let t = j as f64 / rings as f64;
        let r = mix(r0, r1, t);
        let a = TAU * i as f64 / sides as f64;
        xf.transform_point3(DVec3::new(r * a.cos(), r * a.sin(), mix(0.0, height, t)))
    });
    if caps {
        let bottom = mb.vertex(xf.transform_point3(DVec3::ZERO));
        let top = mb.vertex(xf.transform_point3(DVec3::new(0.0, 0.0, height)));
        for i in 0..sides {
            mb.triangle(bottom, g.index(i + 1, 0), g.index(i, 0));
            mb.triangle(top, g.index(i, rings), g.index(i + 1, rings));
        }
    }
}

pub(crate) fn sphere_triangles(nu: u32, nv: u32) -> usize {
    2 * nu.max(3) as usize * (nv.max(2) as usize - 1)
}

/// An ellipsoid with semi-axes `radii` centred on the local origin: `nu` segments around, `nv`
/// bands from pole to pole (the poles are fans, so no triangle is degenerate).
pub(crate) fn sphere(mb: &mut MeshBuilder, xf: &DAffine3, radii: DVec3, nu: u32, nv: u32) {
    let (nu, nv) = (nu.max(3), nv.max(2));
    // Rows from the bottom (j = 0) to the top (j = nv - 2), so that d/du x d/dv points outwards.
    let g = grid(mb, nu, nv - 2, true, false, |i, j| {
        let polar = PI * (nv - 1 - j) as f64 / nv as f64;
        let a = TAU * i as f64 / nu as f64;
        let p = DVec3::new(polar.sin() * a.cos(), polar.sin() * a.sin(), polar.cos());
        xf.transform_point3(p * radii)
    });
    let bottom = mb.vertex(xf.transform_point3(DVec3::new(0.0, 0.0, -radii.z)));
    let top = mb.vertex(xf.transform_point3(DVec3::new(0.0, 0.0, radii.z)));
    for i in 0..nu {
        mb.triangle(bottom, g.index(i + 1, 0), g.index(i, 0));
        mb.triangle(top, g.index(i, nv - 2), g.index(i + 1, nv - 2));
    }
}

/// A wall panel with a semicircular opening: local X across (`-width/2..width/2`), Z up
/// (`0..height`, the springing line at 0), Y through the wall (`-depth/2..depth/2`), the opening
/// of `radius` (< width/2 and < height) centred on the origin.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ArchPanel {
    pub width: f64,
    pub height: f64,
    pub depth: f64,
    pub radius: f64,
}

/// Arch segments must be a multiple of 4 (the outline's corners fall on segment ends) and >= 8.
pub(crate) fn arch_segments(segments: u32) -> u32 {
    (segments.max(8) / 4) * 4
}

pub(crate) fn arch_triangles(segments: u32, radial: u32) -> usize {
    let (s, m) = (arch_segments(segments) as usize, radial.max(1) as usize);
    4 * s * m + 4 * s + 4 * m
}

/// A closed [`ArchPanel`]: `segments` around the opening, `radial` cells from the opening to the
/// outline on the front and back faces.
pub(crate) fn arch_panel(
    mb: &mut MeshBuilder,
    xf: &DAffine3,
    a: &ArchPanel,
    segments: u32,
    radial: u32,
) {
    let (seg, m) = (arch_segments(segments), radial.max(1));
    let q = seg / 4;
    let hw = a.width * 0.5;
    let inner = |k: u32| -> DVec2 {
        match k {
            0 => DVec2::new(a.radius, 0.0),
            k if k == seg => DVec2::new(-a.radius, 0.0),
            k => {
                let t = PI * k as f64 / seg as f64;
                DVec2::new(a.radius * t.cos(), a.radius * t.sin())
            }
        }
    };
    // The outline runs up the right side, across the top and down the left side; its corners are
    // at k = q and k = 3q, so the panel keeps square corners at every tessellation.
    let outer = |k: u32| -> DVec2 {
        if k <= q {
            DVec2::new(hw, mix(0.0, a.height, k as f64 / q as f64))
        } else if k <= 3 * q {
            DVec2::new(mix(hw, -hw, (k - q) as f64 / (2 * q) as f64), a.height)
        } else {
            DVec2::new(-hw, mix(a.height, 0.0, (k - 3 * q) as f64 / q as f64))
        }
    };
    let point = |k: u32, j: u32, y: f64| -> DVec3 {
        let t = j as f64 / m as f64;
        let p = inner(k) * (1.0 - t) + outer(k) * t;
        xf.transform_point3(DVec3::new(p.x, y, p.y))
    };
    let ys = [-a.depth * 0.5, a.depth * 0.5];
    grid(mb, m, seg, false, false, |j, k| point(k, j, ys[0]));
    grid(mb, seg, m, false, false, |k, j| point(k, j, ys[1]));
    grid(mb, seg, 1, false, false, |k, d| point(k, 0, ys[d as usize]));
    grid(mb, 1, seg, false, false, |d, k| point(k, m, ys[d as usize]));
    grid(mb, 1, m, false, false, |d, j| point(0, j, ys[d as usize]));
    grid(mb, m, 1, false, false, |j, d| point(seg, j, ys[d as usize]));
}

/// Rows of window sills and hoods on a facade: local X along the facade (`0..width`), Z up
/// (`0..height`), the wall in the plane y = 0 with the outside towards -Y.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WindowRows {
    pub width: f64,
    pub height: f64,
    pub floor_height: f64,
}

impl WindowRows {
    pub fn floors(&self) -> u32 {
        if self.floor_height > 0.0 && self.height >= self.floor_height {
            (self.height / self.floor_height).floor() as u32
        } else {
            0
        }
    }

    /// Windows closer than 1.6 m would overlap their neighbours' sills.
    pub fn max_columns(&self) -> u32 {
        (self.width / 1.6).floor().max(0.0) as u32
    }
}

pub(crate) fn window_rows_triangles(w: &WindowRows, columns: u32) -> usize {
    24 * columns.min(w.max_columns()) as usize * w.floors() as usize
}

/// `columns` windows per floor, each a sill and a hood box reaching 5 cm into the wall (so their
/// back faces are hidden inside it).
pub(crate) fn window_rows(mb: &mut MeshBuilder, xf: &DAffine3, w: &WindowRows, columns: u32) {
    let columns = columns.min(w.max_columns());
    if columns == 0 {
        return;
    }
    let pitch = w.width / columns as f64;
    let half = (0.55 * pitch).min(2.2) * 0.5;
    let fh = w.floor_height;
    for f in 0..w.floors() {
        let z0 = f as f64 * fh;
        for c in 0..columns {
            let xc = (c as f64 + 0.5) * pitch;
            let sill = (
                DVec3::new(xc - half - 0.08, -0.3, z0 + 0.8),
                DVec3::new(xc + half + 0.08, 0.05, z0 + 0.92),
            );
            let hood = (
                DVec3::new(xc - half - 0.12, -0.45, z0 + 0.78 * fh),
                DVec3::new(xc + half + 0.12, 0.05, z0 + 0.78 * fh + 0.12),
            );
            for (min, max) in [sill, hood] {
                box_grid(mb, xf, min, max, [1, 1, 1]);
            }
        }
    }
}

pub(crate) fn tube_triangles(points: usize, sides: u32, closed: bool) -> usize {
    let segments = match (closed, points) {
        (true, n) if n >= 3 => n,
        (false, n) if n >= 2 => n - 1,
        _ => 0,
    };
    2 * sides.max(3) as usize * segments
}

/// A tube of `radius` swept along `points` (a closed loop when `closed`), with frames carried by
/// parallel transport so the tube does not twist; on a loop the remaining twist is spread evenly
/// so the last ring joins the first without a seam.
pub(crate) fn tube(mb: &mut MeshBuilder, points: &[DVec3], radius: f64, sides: u32, closed: bool) {
    let n = points.len();
    if tube_triangles(n, sides, closed) == 0 {
        return;
    }
    let sides = sides.max(3);
    let at = |i: isize| -> DVec3 {
        if closed {
            points[i.rem_euclid(n as isize) as usize]
        } else {
            points[i.clamp(0, n as isize - 1) as usize]
        }
    };
    let mut tangents: Vec<DVec3> = Vec::with_capacity(n);
    for i in 0..n as isize {
        let t = (at(i + 1) - at(i - 1)).normalize_or_zero();
        let fallback = tangents.last().copied().unwrap_or(DVec3::Z);
        tangents.push(if t == DVec3::ZERO { fallback } else { t });
    }
    let mut normals: Vec<DVec3> = Vec::with_capacity(n);
    normals.push(tangents[0].any_orthonormal_vector());
    for (i, t) in tangents.iter().enumerate().skip(1) {
        let prev = normals[i - 1];
        let v = prev - *t * prev.dot(*t);
        normals.push(if v.length_squared() > 1e-18 {
            v.normalize()
        } else {
            t.any_orthonormal_vector()
        });
    }
    if closed {
        let t0 = tangents[0];
        let last = normals[n - 1];
        let carried = (last - t0 * last.dot(t0)).normalize_or_zero();
        if carried != DVec3::ZERO {
            let twist = t0
                .dot(carried.cross(normals[0]))
                .atan2(carried.dot(normals[0]));
            for (i, (nrm, t)) in normals.iter_mut().zip(&tangents).enumerate() {
                *nrm = DQuat::from_axis_angle(*t, twist * i as f64 / n as f64) * *nrm;
            }
        }
    }
    let segments = if closed { n as u32 } else { n as u32 - 1 };
    let ring: Vec<(f64, f64)> = (0..sides)
        .map(|s| {
            let a = TAU * s as f64 / sides as f64;
            (a.cos() * radius, a.sin() * radius)
        })
        .collect();
    grid(mb, sides, segments, true, closed, |s, i| {
        let i = i as usize;
        let (c, sn) = ring[s as usize];
        let b = tangents[i].cross(normals[i]);
        points[i] + normals[i] * c + b * sn
    });
}

/// A single-sided rectangle `-hx..hx` x `-hy..hy` in the local XY plane, facing +Z.
pub(crate) fn quad(mb: &mut MeshBuilder, xf: &DAffine3, hx: f64, hy: f64) {
    let v = [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
        .map(|(x, y)| mb.vertex(xf.transform_point3(DVec3::new(x, y, 0.0))));
    mb.quad(v[0], v[1], v[2], v[3]);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Six times the signed volume: positive for a closed surface wound outwards.
    fn volume6(mb: &MeshBuilder) -> f64 {
        mb.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mb.positions[i as usize].as_dvec3());
                a.dot(b.cross(c))
            })
            .sum()
    }

    /// Every edge of a closed surface is used once in each direction.
    fn is_closed(mb: &MeshBuilder) -> bool {
        let key = |i: u32| {
            let p = mb.positions[i as usize];
            (p.x.to_bits(), p.y.to_bits(), p.z.to_bits())
        };
        let mut edges = std::collections::HashMap::new();
        for t in &mb.triangles {
            for e in 0..3 {
                let (a, b) = (key(t[e]), key(t[(e + 1) % 3]));
                *edges.entry((a, b)).or_insert(0i32) += 1;
                *edges.entry((b, a)).or_insert(0i32) -= 1;
            }
        }
        edges.values().all(|&v| v == 0)
    }

    fn check_closed(mb: &MeshBuilder, expected: usize, volume: f64) {
        assert_eq!(mb.triangles.len(), expected);
        assert!(is_closed(mb), "surface has an open edge");
        let v = volume6(mb) / 6.0;
        assert!(
            (v - volume).abs() < 0.02 * volume,
            "volume {v}, expected {volume}"
        );
    }

    #[test]
    fn box_is_closed_outward_and_counted() {
        let mut mb = MeshBuilder::new();
        let xf = DAffine3::from_rotation_z(0.3);
        box_grid(
            &mut mb,
            &xf,
            DVec3::ZERO,
            DVec3::new(1.0, 2.0, 3.0),
            [2, 3, 4],
        );
        check_closed(&mb, box_triangles([2, 3, 4]), 6.0);
    }

    #[test]
    fn cylinder_is_closed_outward_and_counted() {
        let mut mb = MeshBuilder::new();
        cylinder(&mut mb, &DAffine3::IDENTITY, 1.0, 1.0, 2.0, 64, 3, true);
        check_closed(&mb, cylinder_triangles(64, 3, true), PI * 2.0);
    }

    #[test]
    fn sphere_is_closed_outward_and_counted() {
        let mut mb = MeshBuilder::new();
        sphere(&mut mb, &DAffine3::IDENTITY, DVec3::splat(1.0), 64, 32);
        check_closed(&mb, sphere_triangles(64, 32), 4.0 / 3.0 * PI);
    }

    #[test]
    fn arch_panel_is_closed_outward_and_counted() {
        let a = ArchPanel {
            width: 3.0,
            height: 2.0,
            depth: 0.5,
            radius: 1.0,
        };
        let mut mb = MeshBuilder::new();
        arch_panel(&mut mb, &DAffine3::IDENTITY, &a, 64, 3);
        let volume = (3.0 * 2.0 - PI * 0.5) * 0.5;
        check_closed(&mb, arch_triangles(64, 3), volume);
    }

    #[test]
    fn closed_tube_is_closed_outward_and_counted() {
        let points: Vec<DVec3> = (0..200)
            .map(|i| {
                let t = TAU * i as f64 / 200.0;
                DVec3::new(t.cos(), t.sin(), 0.3 * (3.0 * t).sin())
            })
            .collect();
        let mut mb = MeshBuilder::new();
        tube(&mut mb, &points, 0.05, 8, true);
        assert_eq!(mb.triangles.len(), tube_triangles(200, 8, true));
        assert!(is_closed(&mb));
        assert!(volume6(&mb) > 0.0);
    }

    #[test]
    fn window_rows_count() {
        let w = WindowRows {
            width: 20.0,
            height: 10.0,
            floor_height: 3.5,
        };
        let mut mb = MeshBuilder::new();
        window_rows(&mut mb, &DAffine3::IDENTITY, &w, 5);
        assert_eq!(mb.triangles.len(), window_rows_triangles(&w, 5));
        assert_eq!(mb.triangles.len(), 24 * 5 * 2);
        assert_eq!(window_rows_triangles(&w, 100), 24 * 12 * 2);
    }
}
