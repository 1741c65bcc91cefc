//! `colonnade`: a Sponza-like atrium. A courtyard open to the sky is ringed by two storeys of
//! arcades (columns with bases and capitals carrying arched wall panels), galleries behind them
//! with floor and roof slabs, a balustrade upstairs and a fountain in the middle. Under a high sun
//! the arches throw repeated curved shadows into the galleries. A lantern swings on a cable
//! across the courtyard (rigid motion, and its point light moves with it) and four banners wave
//! (deforming meshes) while the camera walks through the courtyard.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, Mesh, Scene};
use glam::{DAffine3, DMat4, DVec2, DVec3};

use crate::builder::MeshBuilder;
use crate::params::SceneParams;
use crate::primitives::{grid, ArchPanel};
use crate::shapes::{fit_density, Parts, Shape};
use crate::stage::{
    add_deforming, add_object, camera, ease, lerp3, point, sun, sun_direction, Clock, Stage,
};

/// Half extents of the column rectangle and the bay (column spacing).
const CX: f64 = 12.0;
const CY: f64 = 6.0;
const BAY: f64 = 3.0;
const GALLERY: f64 = 4.0;
const WALL: f64 = 0.5;
const ARCH_RADIUS: f64 = 1.15;
const ARCH_DEPTH: f64 = 0.7;
const SLAB: f64 = 0.3;
const PIVOT: DVec3 = DVec3::new(0.0, 0.0, 10.5);
const PENDULUM_LENGTH: f64 = 5.5;
/// Share of the budget given to the waving banners.
const BANNER_SHARE: f64 = 0.04;

/// One storey of the arcade: where it starts and the sizes of its parts.
struct Storey {
    floor: f64,
    plinth: f64,
    shaft: f64,
    capital: f64,
    arch_height: f64,
    radius: (f64, f64),
}

impl Storey {
    fn spring(&self) -> f64 {
        self.floor + self.plinth + self.shaft + self.capital
    }

    fn top(&self) -> f64 {
        self.spring() + self.arch_height
    }
}

/// Column positions around the courtyard, corners once.
fn column_positions() -> Vec<DVec2> {
    let mut v = Vec::new();
    let nx = (2.0 * CX / BAY).round() as i32;
    let ny = (2.0 * CY / BAY).round() as i32;
    for k in 0..=nx {
        let x = -CX + k as f64 * BAY;
        v.push(DVec2::new(x, -CY));
        v.push(DVec2::new(x, CY));
    }
    for k in 1..ny {
        let y = -CY + k as f64 * BAY;
        v.push(DVec2::new(-CX, y));
        v.push(DVec2::new(CX, y));
    }
    v
}

/// Each bay as (midpoint, rotation about Z that turns local X along the bay).
fn bays() -> Vec<(DVec2, f64)> {
    let mut v = Vec::new();
    let nx = (2.0 * CX / BAY).round() as i32;
    let ny = (2.0 * CY / BAY).round() as i32;
    for k in 0..nx {
        let x = -CX + (k as f64 + 0.5) * BAY;
        v.push((DVec2::new(x, -CY), 0.0));
        v.push((DVec2::new(x, CY), 0.0));
    }
    for k in 0..ny {
        let y = -CY + (k as f64 + 0.5) * BAY;
        v.push((DVec2::new(-CX, y), FRAC_PI_2));
        v.push((DVec2::new(CX, y), FRAC_PI_2));
    }
    v
}

fn arcade(p: &mut Parts, s: &Storey) {
    let id = DAffine3::IDENTITY;
    let half = 0.35;
    for c in column_positions() {
        p.cuboid(
            id,
            (c - half).extend(s.floor),
            (c + half).extend(s.floor + s.plinth),
            0.5,
        );
        let base = c.extend(s.floor + s.plinth);
        p.column(id, base, s.radius.0, s.radius.1, s.shaft, 1.0);
        let cap = s.spring() - s.capital;
        p.cuboid(
            id,
            (c - half).extend(cap),
            (c + half).extend(s.spring()),
            0.5,
        );
        // Corners carry no arch of their own: a pier fills the gap between the two arches.
        if c.x.abs() == CX && c.y.abs() == CY {
            p.cuboid(
                id,
                (c - half).extend(s.spring()),
                (c + half).extend(s.top()),
                0.5,
            );
        }
    }
    for (mid, angle) in bays() {
        let xf =
            DAffine3::from_translation(mid.extend(s.spring())) * DAffine3::from_rotation_z(angle);
        let arch = ArchPanel {
            width: BAY,
            height: s.arch_height,
            depth: ARCH_DEPTH,
            radius: ARCH_RADIUS,
        };
        p.add(Shape::Arch(arch), xf, 1.0);
    }
}

/// A slab over the gallery ring (from the arcade line to the outer wall) at `z`.
fn gallery_slab(p: &mut Parts, z: f64, weight: f64) {
    let id = DAffine3::IDENTITY;
    let (ox, oy) = (CX + GALLERY, CY + GALLERY);
    let (ix, iy) = (CX - 0.5 * ARCH_DEPTH, CY - 0.5 * ARCH_DEPTH);
    let top = z + SLAB;
    p.cuboid(id, DVec3::new(-ox, iy, z), DVec3::new(ox, oy, top), weight);
    p.cuboid(
        id,
        DVec3::new(-ox, -oy, z),
        DVec3::new(ox, -iy, top),
        weight,
    );
    p.cuboid(id, DVec3::new(ix, -iy, z), DVec3::new(ox, iy, top), weight);
    p.cuboid(
        id,
        DVec3::new(-ox, -iy, z),
        DVec3::new(-ix, iy, top),
        weight,
    );
}

fn balustrade(p: &mut Parts, floor: f64) {
    for (mid, angle) in bays() {
        let xf = DAffine3::from_translation(mid.extend(floor)) * DAffine3::from_rotation_z(angle);
        let half = 0.5 * BAY - 0.35;
        p.cuboid(
            xf,
            DVec3::new(-half, -0.08, 0.85),
            DVec3::new(half, 0.08, 0.95),
            0.5,
        );
        for k in 0..3 {
            let x = -half + 2.0 * half * (k as f64 + 1.0) / 4.0;
            p.column(xf, DVec3::new(x, 0.0, 0.0), 0.05, 0.04, 0.85, 1.0);
        }
    }
}

fn architecture() -> Parts {
    let mut p = Parts::new();
    let id = DAffine3::IDENTITY;
    let (ox, oy) = (CX + GALLERY, CY + GALLERY);
    p.cuboid(
        id,
        DVec3::new(-ox - WALL, -oy - WALL, -0.3),
        DVec3::new(ox + WALL, oy + WALL, 0.0),
        0.2,
    );
    let lower = Storey {
        floor: 0.0,
        plinth: 0.3,
        shaft: 3.4,
        capital: 0.3,
        arch_height: 1.6,
        radius: (0.26, 0.22),
    };
    arcade(&mut p, &lower);
    gallery_slab(&mut p, lower.top(), 0.1);
    let upper = Storey {
        floor: lower.top() + SLAB,
        plinth: 0.25,
        shaft: 2.8,
        capital: 0.25,
        arch_height: 1.4,
        radius: (0.22, 0.19),
    };
    arcade(&mut p, &upper);
    balustrade(&mut p, upper.floor);
    gallery_slab(&mut p, upper.top(), 0.1);
    let height = upper.top() + SLAB + 0.4;
    for (min, max) in [
        (DVec2::new(-ox - WALL, oy), DVec2::new(ox + WALL, oy + WALL)),
        (
            DVec2::new(-ox - WALL, -oy - WALL),
            DVec2::new(ox + WALL, -oy),
        ),
        (DVec2::new(ox, -oy), DVec2::new(ox + WALL, oy)),
        (DVec2::new(-ox - WALL, -oy), DVec2::new(-ox, oy)),
    ] {
        p.cuboid(id, min.extend(0.0), max.extend(height), 0.1);
    }
    // Fountain: basin, pedestal, bowl.
    p.column(id, DVec3::ZERO, 2.2, 2.2, 0.5, 1.0);
    p.column(id, DVec3::new(0.0, 0.0, 0.5), 0.3, 0.25, 1.0, 1.0);
    p.column(id, DVec3::new(0.0, 0.0, 1.5), 0.4, 0.9, 0.3, 1.0);
    let top = DAffine3::from_translation(DVec3::new(0.0, 0.0, 1.9));
    p.add(
        Shape::Ellipsoid {
            radii: DVec3::new(0.15, 0.15, 0.25),
        },
        top,
        1.0,
    );
    // The cable the lantern hangs from, spanning the courtyard.
    let cable = DAffine3::from_translation(DVec3::new(0.0, -CY, PIVOT.z))
        * DAffine3::from_rotation_x(-FRAC_PI_2);
    let shape = Shape::Cylinder {
        r0: 0.02,
        r1: 0.02,
        height: 2.0 * CY,
        caps: true,
    };
    p.add(shape, cable, 0.5);
    p
}

/// The lantern in its own frame: pivot at the origin, hanging down -Z.
fn pendulum() -> Parts {
    let mut p = Parts::new();
    let id = DAffine3::IDENTITY;
    let l = PENDULUM_LENGTH;
    p.column(
        id,
        DVec3::new(0.0, 0.0, -l + 0.5),
        0.015,
        0.015,
        l - 0.5,
        1.0,
    );
    p.column(id, DVec3::new(0.0, 0.0, -l), 0.25, 0.25, 0.5, 1.0);
    p.column(id, DVec3::new(0.0, 0.0, -l + 0.5), 0.32, 0.05, 0.25, 1.0);
    let finial = DAffine3::from_translation(DVec3::new(0.0, 0.0, -l + 0.8));
    p.add(
        Shape::Ellipsoid {
            radii: DVec3::splat(0.07),
        },
        finial,
        1.0,
    );
    p
}

/// A waving banner: `cols` x `rows` cells hanging from its top edge.
struct Banner {
    xf: DMat4,
    cols: u32,
    rows: u32,
    phase: f64,
    index: usize,
}

impl Banner {
    const WIDTH: f64 = 1.6;
    const HEIGHT: f64 = 4.0;

    /// The cloth at `seconds`: fixed along the top, waves travelling down it and growing
    /// towards the free edge.
    fn mesh_at(&self, seconds: f64) -> Mesh {
        let mut mb = MeshBuilder::new();
        let w = TAU * 0.6 * seconds + self.phase;
        grid(&mut mb, self.cols, self.rows, false, false, |i, j| {
            let x = Banner::WIDTH * (i as f64 / self.cols as f64 - 0.5);
            let s = j as f64 / self.rows as f64;
            let wave = 0.25 * s * s * (2.2 * s * Banner::HEIGHT - w).sin()
                + 0.04 * s * (4.0 * x + 1.3 * w).sin();
            DVec3::new(x, wave, -s * Banner::HEIGHT)
        });
        mb.build(format!("banner.{}", self.index))
    }
}

pub(crate) struct Colonnade {
    clock: Clock,
    stage: Stage,
    pendulum: usize,
    banners: Vec<Banner>,
}

impl Colonnade {
    pub fn new(params: SceneParams) -> Self {
        let target = params.triangles;
        let banner_cells = (BANNER_SHARE * target as f64 / 4.0 / 2.0).max(8.0);
        // Cells about square: cols / rows = width / height.
        let rows = ((banner_cells * Banner::HEIGHT / Banner::WIDTH)
            .sqrt()
            .round() as u32)
            .max(4);
        let cols = ((banner_cells / rows as f64).round() as u32).max(2);
        // Far enough from the arches that the waves never reach them.
        let banner_y = CY - 0.5 * ARCH_DEPTH - 0.4;
        let banners = [(-7.5, -1.0), (7.5, -1.0), (-7.5, 1.0), (7.5, 1.0)]
            .iter()
            .enumerate()
            .map(|(index, &(x, side))| Banner {
                // Turned so each banner's local +Y points into the courtyard.
                xf: DMat4::from_translation(DVec3::new(x, side * banner_y, PIVOT.z))
                    * DMat4::from_rotation_z(if side < 0.0 { 0.0 } else { PI }),
                cols,
                rows,
                phase: 1.7 * index as f64,
                index,
            })
            .collect::<Vec<_>>();
        let banner_tris = banners.len() * 2 * (cols * rows) as usize;

        let building = architecture();
        let lantern = pendulum();
        let density = fit_density(
            &[(&building, 1), (&lantern, 1)],
            target.saturating_sub(banner_tris),
        );
        let mut stage = Stage::new();
        stage.add_static(building.build(density, "atrium"), DMat4::IDENTITY);
        let pendulum = stage.add_mesh(lantern.build(density, "lantern"));
        Colonnade {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            pendulum,
            banners,
        }
    }

    /// The lantern's swing across the cable: a pendulum's period for its length, 0.3 rad each
    /// way.
    fn swing(&self, seconds: f64) -> DMat4 {
        let period = TAU * (PENDULUM_LENGTH / 9.81).sqrt();
        let angle = 0.3 * (TAU * seconds / period).sin();
        DMat4::from_translation(PIVOT) * DMat4::from_rotation_y(angle)
    }
}

impl Animation for Colonnade {
    fn name(&self) -> &str {
        "colonnade"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let u = ease(self.clock.progress(frame));
        let eye = lerp3(DVec3::new(-10.0, -4.3, 1.7), DVec3::new(5.0, -4.6, 2.2), u);
        let target = lerp3(DVec3::new(2.0, 4.0, 5.5), DVec3::new(8.0, 3.0, 5.0), u);
        let cam = camera(eye, target, 18.0, (0.1, 150.0));
        let seconds = self.clock.seconds(frame);
        let swing = self.swing(seconds);
        let lantern_light = swing.transform_point3(DVec3::new(0.0, 0.0, -PENDULUM_LENGTH - 0.3));
        let lights = vec![
            sun("Sun", sun_direction(0.96, 4.0), 0.0093),
            point("Lantern", lantern_light, 0.08),
        ];
        let mut scene = self.stage.scene(frame, cam, lights);
        add_object(&mut scene, "lantern".into(), self.pendulum, swing);
        for banner in &self.banners {
            add_deforming(&mut scene, banner.mesh_at(seconds), banner.xf);
        }
        scene
    }
}
