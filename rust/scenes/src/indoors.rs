//! `indoors`: a house in a garden of trees and rocks. The camera flies from high over the garden
//! down through the open front door into a furnished room lit by a low sun through venetian
//! blinds, while a lamp travels from the open sky over the garden to behind the room's back wall.
//! Shadow rays go from mostly unoccluded to almost all occluded, so the best method changes; the
//! door swings open in the first third, after which no geometry moves.

use std::f64::consts::{FRAC_PI_2, TAU};
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, Light, Scene};
use glam::{DAffine3, DMat4, DVec3};

use crate::bedroom::chair;
use crate::params::SceneParams;
use crate::rng::Pcg32;
use crate::shapes::{fit_density, span as b, Parts, Shape};
use crate::stage::{add_object, camera, ease, lerp3, point, sun, sun_direction, Clock, Stage};

const SEED: u64 = 0x494e_444f_4f52_5321;
/// Interior: x in -HX..HX, y in -HY..HY, z in 0..HEIGHT; walls THICK thick.
const HX: f64 = 3.0;
const HY: f64 = 2.5;
const HEIGHT: f64 = 2.7;
const THICK: f64 = 0.2;
/// The front door in the south wall (y = -HY): x in -DOOR..DOOR, z below DOOR_TOP.
const DOOR: f64 = 0.55;
const DOOR_TOP: f64 = 2.15;
/// The window in the east wall (x = HX): y in -WY..WY, z in SILL..LINTEL, with blinds.
const WY: f64 = 1.0;
const SILL: f64 = 0.85;
const LINTEL: f64 = 2.2;
const SLAT_X: f64 = HX - 0.08;
const SLAT_PITCH: f64 = 0.045;
/// The garden: ground out to +-GARDEN; trees and rocks keep clear of the house and the path.
const GARDEN: f64 = 30.0;
const TREES: u64 = 28;
/// The camera's way: high over the garden, down the path and straight through the door.
const EYE_CURVE: [DVec3; 4] = [
    DVec3::new(-9.0, -24.0, 9.0),
    DVec3::new(0.0, -15.0, 2.0),
    DVec3::new(0.0, -6.0, 1.5),
    DVec3::new(0.2, 1.4, 1.45),
];
/// The lamp's way: over the garden, above the roof, down behind the back (north) wall.
const LAMP_PATH: [DVec3; 4] = [
    DVec3::new(-5.0, -14.0, 9.0),
    DVec3::new(-1.0, -4.0, 8.5),
    DVec3::new(0.5, 8.0, 6.0),
    DVec3::new(0.5, 5.0, 1.4),
];
const ROCKS: u64 = 40;

/// Walls, roof and floor of the house: closed to shadow rays but for the door and the window.
fn shell(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (ox, oy) = (HX + THICK, HY + THICK);
    p.cuboids(
        [
            b([-ox, -oy, HEIGHT], [ox, oy, HEIGHT + THICK]),
            b([-ox, -oy, 0.0], [-HX, oy, HEIGHT]),
            b([-HX, HY, 0.0], [HX, oy, HEIGHT]),
            // South wall around the door.
            b([-HX, -oy, 0.0], [-DOOR, -HY, HEIGHT]),
            b([DOOR, -oy, 0.0], [HX, -HY, HEIGHT]),
            b([-DOOR, -oy, DOOR_TOP], [DOOR, -HY, HEIGHT]),
            // East wall around the window.
            b([HX, -oy, 0.0], [ox, oy, SILL]),
            b([HX, -oy, LINTEL], [ox, oy, HEIGHT]),
            b([HX, -oy, SILL], [ox, -WY, LINTEL]),
            b([HX, WY, SILL], [ox, oy, LINTEL]),
        ],
        0.15,
    );
    // Floorboards a little above the garden's ground, and the blinds' head rail and cords.
    let (min, max) = b([-HX, -HY, 0.0], [HX, HY, 0.02]);
    p.cuboid(id, min, max, 0.3);
    let (min, max) = b(
        [SLAT_X - 0.04, -WY - 0.05, LINTEL - 0.02],
        [SLAT_X + 0.04, WY + 0.05, LINTEL + 0.04],
    );
    p.cuboid(id, min, max, 0.5);
    for y in [-0.7, 0.7] {
        let base = DVec3::new(SLAT_X, y, SILL);
        p.column(id, base, 0.002, 0.002, LINTEL - SILL - 0.02, 0.3);
    }
}

/// A dining table with four chairs, a sofa, and a bookshelf of random books on the back wall.
fn furniture(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (x0, x1, y0, y1) = (-1.6, 0.2, -0.2, 0.8);
    let (min, max) = b([x0, y0, 0.72], [x1, y1, 0.76]);
    p.cuboid(id, min, max, 1.0);
    for (x, y) in [
        (x0 + 0.06, y0 + 0.06),
        (x1 - 0.06, y0 + 0.06),
        (x0 + 0.06, y1 - 0.06),
        (x1 - 0.06, y1 - 0.06),
    ] {
        p.column(id, DVec3::new(x, y, 0.0), 0.03, 0.03, 0.72, 1.0);
    }
    let c = chair();
    for (x, y, turn) in [
        (-1.1, -0.55, 0.0),
        (-0.3, -0.55, 0.0),
        (-1.1, 1.15, TAU / 2.0),
        (-0.3, 1.15, TAU / 2.0),
    ] {
        let xf = DAffine3::from_translation(DVec3::new(x, y, 0.0))
            * DAffine3::from_rotation_z(turn + TAU / 2.0);
        p.extend(c.transformed(xf));
    }
    // Sofa under the west wall.
    p.cuboids(
        [
            b([-HX, -1.8, 0.0], [-HX + 0.9, -0.2, 0.42]),
            b([-HX, -1.8, 0.42], [-HX + 0.25, -0.2, 0.85]),
            b([-HX + 0.25, -1.8, 0.42], [-HX + 0.9, -1.6, 0.62]),
            b([-HX + 0.25, -0.4, 0.42], [-HX + 0.9, -0.2, 0.62]),
        ],
        1.0,
    );
    bookshelf(p, 0.6, 2.6);
}

fn bookshelf(p: &mut Parts, x0: f64, x1: f64) {
    let id = DAffine3::IDENTITY;
    let (y0, y1) = (HY - 0.32, HY);
    let shelves = [0.0, 0.42, 0.84, 1.26, 1.68, 2.0];
    p.cuboids(
        [
            b([x0, y0, 0.0], [x0 + 0.02, y1, 2.02]),
            b([x1 - 0.02, y0, 0.0], [x1, y1, 2.02]),
        ],
        1.0,
    );
    for z in shelves {
        let (min, max) = b([x0 + 0.02, y0, z], [x1 - 0.02, y1, z + 0.02]);
        p.cuboid(id, min, max, 1.0);
    }
    let mut rng = Pcg32::new(SEED, 1);
    for level in shelves.windows(2) {
        let (floor, room) = (level[0] + 0.02, level[1] - level[0] - 0.05);
        let mut x = x0 + 0.03;
        loop {
            let w = rng.range(0.02, 0.05);
            if x + w > x1 - 0.03 {
                break;
            }
            let h = rng.range(0.18, 0.34).min(room);
            let d = rng.range(0.15, 0.26);
            let (min, max) = b([x, y1 - 0.02 - d, floor], [x + w, y1 - 0.02, floor + h]);
            p.cuboid(id, min, max, 1.0);
            x += w + 0.002;
        }
    }
}

/// Whether a trunk or rock at (x, y) would stand in the house, near the camera's or the lamp's
/// low stretches, or on the way to the door.
fn blocked(x: f64, y: f64, clearance: f64) -> bool {
    let house = x.abs() < HX + 1.0 + clearance && y.abs() < HY + 1.0 + clearance;
    let path = x.abs() < 3.0 + clearance && y < 0.0;
    let low = |path: [DVec3; 4]| {
        (0..=64).any(|k| {
            let p = bezier(path, k as f64 / 64.0);
            p.z < 8.0 && DVec3::new(p.x - x, p.y - y, 0.0).length() < 2.5 + clearance
        })
    };
    house || path || low(EYE_CURVE) || low(LAMP_PATH)
}

/// Ground, trees (trunk and crown) and rocks, scattered with a fixed seed.
fn garden(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (min, max) = b([-GARDEN, -GARDEN, -0.2], [GARDEN, GARDEN, 0.0]);
    p.cuboid(id, min, max, 0.01);
    let mut rng = Pcg32::new(SEED, 2);
    let spot = |rng: &mut Pcg32, clearance: f64| loop {
        let (x, y) = (rng.range(-18.0, 18.0), rng.range(-18.0, 18.0));
        if !blocked(x, y, clearance) {
            break DVec3::new(x, y, 0.0);
        }
    };
    for _ in 0..TREES {
        let at = spot(&mut rng, 2.0);
        let height = rng.range(2.5, 4.5);
        let radius = rng.range(0.12, 0.22);
        p.column(id, at, radius, 0.6 * radius, height, 0.5);
        let crown = DVec3::new(
            rng.range(1.2, 2.0),
            rng.range(1.2, 2.0),
            rng.range(1.0, 1.6),
        );
        let xf = DAffine3::from_translation(at + DVec3::Z * (height + 0.6 * crown.z));
        p.add(Shape::Ellipsoid { radii: crown }, xf, 1.0);
    }
    for _ in 0..ROCKS {
        let at = spot(&mut rng, 0.5);
        let r = rng.range(0.2, 0.7);
        let radii = DVec3::new(r, r * rng.range(0.6, 1.0), r * rng.range(0.4, 0.7));
        let xf = DAffine3::from_translation(at) * DAffine3::from_rotation_z(rng.range(0.0, TAU));
        p.add(Shape::Ellipsoid { radii }, xf, 1.0);
    }
}

/// One slat in its own frame: long along Y, tilting about Y.
fn slat() -> Parts {
    let mut p = Parts::new();
    let (min, max) = b([-0.028, -WY, -0.0015], [0.028, WY, 0.0015]);
    p.cuboid(DAffine3::IDENTITY, min, max, 1.0);
    p
}

/// The door leaf in its own frame: hinge on the origin, closed along +X.
fn door() -> Parts {
    let mut p = Parts::new();
    let (min, max) = b([0.0, 0.0, 0.01], [2.0 * DOOR - 0.02, 0.04, DOOR_TOP - 0.02]);
    p.cuboid(DAffine3::IDENTITY, min, max, 1.0);
    p.column(
        DAffine3::from_rotation_x(-FRAC_PI_2),
        DVec3::new(2.0 * DOOR - 0.12, -1.0, -0.04),
        0.02,
        0.02,
        0.12,
        1.0,
    );
    p
}

pub(crate) struct Indoors {
    clock: Clock,
    stage: Stage,
    slat_mesh: usize,
    slat_heights: Vec<f64>,
    door_mesh: usize,
}

impl Indoors {
    pub fn new(params: SceneParams) -> Self {
        let mut house = Parts::new();
        shell(&mut house);
        furniture(&mut house);
        let mut outside = Parts::new();
        garden(&mut outside);
        let slat_heights: Vec<f64> = (0..)
            .map(|k| LINTEL - 0.04 - k as f64 * SLAT_PITCH)
            .take_while(|&z| z > SILL + 0.03)
            .collect();
        let (slat, door) = (slat(), door());
        let density = fit_density(
            &[
                (&house, 1),
                (&outside, 1),
                (&slat, slat_heights.len()),
                (&door, 1),
            ],
            params.triangles,
        );
        let mut stage = Stage::new();
        stage.add_static(house.build(density, "house"), DMat4::IDENTITY);
        stage.add_static(outside.build(density, "garden"), DMat4::IDENTITY);
        let slat_mesh = stage.add_mesh(slat.build(density, "slat"));
        let door_mesh = stage.add_mesh(door.build(density, "door"));
        Indoors {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            slat_mesh,
            slat_heights,
            door_mesh,
        }
    }

    /// A low sun in the east, through the blinds, and a lamp that travels from high over the
    /// garden in front of the house to behind its back wall.
    fn lights(u: f64) -> Vec<Light> {
        let lamp = bezier(LAMP_PATH, u);
        vec![
            sun("Sun", sun_direction(0.45, 0.2), 0.02),
            point("Lamp", lamp, 0.15),
        ]
    }
}

/// A cubic Bezier curve through `p[0]` and `p[3]`.
fn bezier(p: [DVec3; 4], t: f64) -> DVec3 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

impl Animation for Indoors {
    fn name(&self) -> &str {
        "indoors"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let t = self.clock.progress(frame);
        let u = ease(t);
        // High over the garden, down the path and straight through the middle of the door.
        let eye = bezier(EYE_CURVE, u);
        let target = lerp3(DVec3::new(0.0, 0.0, 0.8), DVec3::new(-1.5, -1.0, 0.3), u);
        let cam = camera(eye, target, 20.0, (0.05, 120.0));
        let mut scene = self.stage.scene(frame, cam, Indoors::lights(u));
        // The door swings inwards in the first third; then nothing moves but the camera and the
        // lamp, so trees can be kept and the frame's cost is the rays'. The slats stand at the
        // sun's elevation, edge on to its rays.
        let open = FRAC_PI_2 * ease((3.0 * t).min(1.0));
        let hinge = DMat4::from_translation(DVec3::new(-DOOR + 0.01, -HY - 0.04, 0.0));
        add_object(
            &mut scene,
            "door".into(),
            self.door_mesh,
            hinge * DMat4::from_rotation_z(open),
        );
        let tilt = -0.45;
        for (k, &z) in self.slat_heights.iter().enumerate() {
            let xf =
                DMat4::from_translation(DVec3::new(SLAT_X, 0.0, z)) * DMat4::from_rotation_y(tilt);
            add_object(&mut scene, format!("slat.{k:02}"), self.slat_mesh, xf);
        }
        scene
    }
}
