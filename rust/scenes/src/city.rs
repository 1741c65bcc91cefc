//! `city`: a grid of city blocks with towers of varied height and setbacks, window sills and hoods
//! on every facade, sidewalks and streets, under a low sun that throws long shadows down the
//! streets; a street lamp adds a spot light. Cars drive loops around blocks (rigid motion: one
//! shared car mesh, moving objects) while the camera flies over.

use std::f64::consts::{FRAC_PI_2, PI};
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, Light, LightKind, Scene};
use glam::{DAffine3, DMat4, DVec2, DVec3};

use crate::params::SceneParams;
use crate::primitives::WindowRows;
use crate::rng::Pcg32;
use crate::shapes::{fit_density, Parts, Shape};
use crate::stage::{add_object, aimed, camera, ease, sun, sun_direction, Clock, Stage};

const SEED: u64 = 0x4349_5459;
const BLOCK: f64 = 50.0;
const STREET: f64 = 14.0;
const PITCH: f64 = BLOCK + STREET;
const FLOOR: f64 = 3.5;
const SIDEWALK: f64 = 0.15;
/// Distance of a car from the street's centre line.
const LANE: f64 = 3.0;

/// A car driving round a rectangle of streets.
struct Car {
    corners: [DVec2; 4],
    start: f64,
    speed: f64,
}

impl Car {
    fn perimeter(&self) -> f64 {
        (0..4)
            .map(|k| self.corners[k].distance(self.corners[(k + 1) % 4]))
            .sum()
    }

    /// World placement at `seconds`: on the right-hand lane, facing along the street.
    fn placement(&self, seconds: f64) -> DMat4 {
        let perimeter = self.perimeter().max(1e-9);
        let mut s = (self.start + self.speed * seconds).rem_euclid(perimeter);
        for k in 0..4 {
            let (a, b) = (self.corners[k], self.corners[(k + 1) % 4]);
            let len = a.distance(b);
            if s <= len || k == 3 {
                let dir = (b - a).normalize_or_zero();
                let right = DVec2::new(dir.y, -dir.x);
                let p = a + dir * s.min(len) + right * LANE;
                return DMat4::from_translation(DVec3::new(p.x, p.y, 0.0))
                    * DMat4::from_rotation_z(dir.y.atan2(dir.x));
            }
            s -= len;
        }
        DMat4::IDENTITY
    }
}

pub(crate) struct City {
    clock: Clock,
    stage: Stage,
    car_mesh: usize,
    cars: Vec<Car>,
    extent: f64,
    tallest: f64,
    lamp: DVec3,
}

/// The centre line of street `s` (0..=blocks) across a city `extent` wide.
pub(crate) fn street(s: u32, extent: f64) -> f64 {
    -0.5 * extent + s as f64 * PITCH
}

fn car_parts() -> Parts {
    let mut p = Parts::new();
    let id = DAffine3::IDENTITY;
    p.cuboid(
        id,
        DVec3::new(-2.1, -0.85, 0.3),
        DVec3::new(2.1, 0.85, 0.95),
        0.5,
    );
    p.cuboid(
        id,
        DVec3::new(-1.1, -0.75, 0.95),
        DVec3::new(1.0, 0.75, 1.45),
        0.5,
    );
    for x in [-1.35, 1.35] {
        for y in [-0.95, 0.73] {
            // Wheels: cylinders turned from local Z onto Y.
            let xf = DAffine3::from_translation(DVec3::new(x, y, 0.32))
                * DAffine3::from_rotation_x(-FRAC_PI_2);
            let shape = Shape::Cylinder {
                r0: 0.32,
                r1: 0.32,
                height: 0.22,
                caps: true,
            };
            p.add(shape, xf, 0.5);
        }
    }
    p
}

/// A tower on `min..max` (x, y) from the sidewalk up: up to three tiers, each set back from the
/// one below, windows on every facade, a plant room on the roof.
fn building(p: &mut Parts, rng: &mut Pcg32, min: DVec2, max: DVec2, floors: u32) -> f64 {
    let tiers = 1 + (floors > 12) as u32 + (floors > 24) as u32;
    let (mut lo, mut hi) = (min, max);
    let mut z = SIDEWALK;
    for tier in 0..tiers {
        let tier_floors = floors / tiers + if tier == 0 { floors % tiers } else { 0 };
        let top = z + tier_floors as f64 * FLOOR;
        let id = DAffine3::IDENTITY;
        p.cuboid(id, lo.extend(z), hi.extend(top), 0.0);
        let size = hi - lo;
        let facades = [
            (DVec2::new(lo.x, lo.y), 0.0, size.x),
            (DVec2::new(hi.x, lo.y), FRAC_PI_2, size.y),
            (DVec2::new(hi.x, hi.y), PI, size.x),
            (DVec2::new(lo.x, hi.y), 3.0 * FRAC_PI_2, size.y),
        ];
        for (corner, angle, width) in facades {
            let xf =
                DAffine3::from_translation(corner.extend(z)) * DAffine3::from_rotation_z(angle);
            let rows = WindowRows {
                width,
                height: top - z,
                floor_height: FLOOR,
            };
            p.add(Shape::Windows(rows), xf, 1.0);
        }
        z = top;
        let inset = rng.range(1.5, 3.5);
        if (hi - lo).min_element() - 2.0 * inset < 8.0 {
            break;
        }
        lo += DVec2::splat(inset);
        hi -= DVec2::splat(inset);
    }
    let c = (lo + hi) * 0.5;
    p.cuboid(
        DAffine3::IDENTITY,
        (c - DVec2::splat(2.0)).extend(z),
        (c + DVec2::new(2.0, 1.5)).extend(z + 2.5),
        0.0,
    );
    z + 2.5
}

impl City {
    pub fn new(params: SceneParams) -> Self {
        let target = params.triangles;
        let blocks = ((target as f64 / 2500.0).sqrt().round() as u32).clamp(3, 10);
        let extent = blocks as f64 * PITCH;
        let mut parts = Parts::new();
        // Ground well past the blocks, so the low camera never sees its edge.
        let margin = extent;
        parts.cuboid(
            DAffine3::IDENTITY,
            DVec3::new(-0.5 * extent - margin, -0.5 * extent - margin, -0.5),
            DVec3::new(0.5 * extent + margin, 0.5 * extent + margin, 0.0),
            0.0,
        );
        let mut tallest: f64 = 0.0;
        for bj in 0..blocks {
            for bi in 0..blocks {
                let mut rng = Pcg32::new(SEED, (bj * blocks + bi) as u64);
                let b0 = DVec2::new(street(bi, extent), street(bj, extent)) + STREET * 0.5;
                parts.cuboid(
                    DAffine3::IDENTITY,
                    b0.extend(0.0),
                    (b0 + BLOCK).extend(SIDEWALK),
                    0.0,
                );
                let centre = b0 + BLOCK * 0.5;
                let central = 1.0 - (centre.length() / (0.7 * extent)).clamp(0.0, 1.0);
                let (nx, ny) = (1 + rng.below(3), 1 + rng.below(3));
                let inner = BLOCK - 6.0;
                let lot = DVec2::new(
                    (inner - 2.0 * (nx - 1) as f64) / nx as f64,
                    (inner - 2.0 * (ny - 1) as f64) / ny as f64,
                );
                for ly in 0..ny {
                    for lx in 0..nx {
                        let min = b0 + 3.0 + DVec2::new(lx as f64, ly as f64) * (lot + 2.0);
                        let u = rng.unit();
                        let floors = 3 + (u * u * (6.0 + 30.0 * central)).round() as u32;
                        let top = building(&mut parts, &mut rng, min, min + lot, floors);
                        tallest = tallest.max(top);
                    }
                }
            }
        }
        let lamp = DVec3::new(
            street(blocks / 2, extent) + 0.5 * STREET - 1.0,
            street(blocks / 2 - 1, extent) + 0.5 * STREET - 1.0,
            0.0,
        );
        parts.column(DAffine3::IDENTITY, lamp, 0.12, 0.08, 9.0, 0.0);

        let cars = City::cars(blocks, extent);
        let car = car_parts();
        let density = fit_density(&[(&parts, 1), (&car, cars.len())], target);
        let mut stage = Stage::new();
        stage.add_static(parts.build(density, "city"), DMat4::IDENTITY);
        let car_mesh = stage.add_mesh(car.build(density, "car"));
        City {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            car_mesh,
            cars,
            extent,
            tallest,
            lamp: lamp + DVec3::Z * 8.8,
        }
    }

    fn cars(blocks: u32, extent: f64) -> Vec<Car> {
        let count = 4 * blocks + 4;
        (0..count)
            .map(|k| {
                let mut rng = Pcg32::new(SEED, 10_000 + k as u64);
                let s0 = rng.below(blocks);
                let s1 = s0 + 1 + rng.below((blocks - s0).min(3));
                let t0 = rng.below(blocks);
                let t1 = t0 + 1 + rng.below((blocks - t0).min(3));
                let (x0, x1) = (street(s0, extent), street(s1, extent));
                let (y0, y1) = (street(t0, extent), street(t1, extent));
                Car {
                    corners: [
                        DVec2::new(x0, y0),
                        DVec2::new(x1, y0),
                        DVec2::new(x1, y1),
                        DVec2::new(x0, y1),
                    ],
                    start: rng.range(0.0, 4.0 * extent),
                    speed: rng.range(8.0, 14.0),
                }
            })
            .collect()
    }

    fn lights(&self) -> Vec<Light> {
        vec![
            // Low sun (12 degrees up, behind the camera's left) with the real sun's half-degree
            // disk.
            sun("Sun", sun_direction(0.21, -2.2), 0.0093),
            Light::new(
                "StreetLamp",
                aimed(self.lamp, DVec3::new(0.3, 0.3, -1.0)),
                LightKind::Spot {
                    radius: 0.15,
                    spot_size: 1.2,
                    spot_blend: 0.2,
                },
            ),
        ]
    }
}

impl Animation for City {
    fn name(&self) -> &str {
        "city"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let u = ease(self.clock.progress(frame));
        let e = self.extent;
        let altitude = (self.tallest + 60.0).max(0.35 * e);
        let eye = DVec3::new(-0.55 * e + 0.7 * e * u, -0.8 * e, altitude);
        let target = DVec3::new(-0.2 * e + 0.5 * e * u, 0.1 * e, 0.0);
        let cam = camera(eye, target, 30.0, (1.0, 4.0 * e + 1000.0));
        let mut scene = self.stage.scene(frame, cam, self.lights());
        let seconds = self.clock.seconds(frame);
        for (k, car) in self.cars.iter().enumerate() {
            add_object(
                &mut scene,
                format!("car.{k:03}"),
                self.car_mesh,
                car.placement(seconds),
            );
        }
        scene
    }
}
