//! `bedroom`: a closed room (walls, floor and ceiling are real geometry) with a bed, wardrobe,
//! desk, chairs, a bookshelf full of books and a ceiling fan. Light comes in only through one
//! window, past venetian blinds of many thin slats: a sun and an area light outside the window,
//! so almost every shadow ray is occluded and the slats cut the light into stripes. The slats
//! tilt and the fan turns (rigid motion of shared meshes) while the camera dollies in.

use std::f64::consts::TAU;
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, AreaShape, Light, LightKind, Scene};
use glam::{DAffine3, DMat4, DVec3};

use crate::params::SceneParams;
use crate::rng::Pcg32;
use crate::shapes::{fit_density, span as b, Parts};
use crate::stage::{add_object, aimed, camera, ease, lerp3, sun, Clock, Stage};

const SEED: u64 = 0x0042_4544_524f_4f4d;
/// Interior: x in -HX..HX, y in -HY..HY, z in 0..HEIGHT; walls THICK thick.
const HX: f64 = 2.5;
const HY: f64 = 2.0;
const HEIGHT: f64 = 2.7;
const THICK: f64 = 0.15;
/// The window in the east wall (x = HX): y in -WY..WY, z in SILL..LINTEL.
const WY: f64 = 0.8;
const SILL: f64 = 0.9;
const LINTEL: f64 = 2.2;
const SLAT_X: f64 = HX - 0.08;
const SLAT_PITCH: f64 = 0.04;
const FAN_HUB: DVec3 = DVec3::new(0.0, 0.0, 2.3);

fn shell(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (ox, oy) = (HX + THICK, HY + THICK);
    // Floor and ceiling run under and over the walls, and the walls overlap at the corners, so
    // the room is closed to shadow rays everywhere but the window.
    p.cuboids(
        [
            b([-ox, -oy, -THICK], [ox, oy, 0.0]),
            b([-ox, -oy, HEIGHT], [ox, oy, HEIGHT + THICK]),
            b([-ox, -oy, 0.0], [-HX, oy, HEIGHT]),
            b([-HX, -oy, 0.0], [HX, -HY, HEIGHT]),
            b([-HX, HY, 0.0], [HX, oy, HEIGHT]),
            b([HX, -oy, 0.0], [ox, oy, SILL]),
            b([HX, -oy, LINTEL], [ox, oy, HEIGHT]),
            b([HX, -oy, SILL], [ox, -WY, LINTEL]),
            b([HX, WY, SILL], [ox, oy, LINTEL]),
        ],
        0.15,
    );
    let (min, max) = b([HX - 0.15, -WY - 0.1, SILL - 0.04], [HX, WY + 0.1, SILL]);
    p.cuboid(id, min, max, 0.5);
    // Head rail and ladder cords of the blinds.
    let (min, max) = b(
        [SLAT_X - 0.04, -0.87, LINTEL - 0.02],
        [SLAT_X + 0.04, 0.87, LINTEL + 0.04],
    );
    p.cuboid(id, min, max, 0.5);
    for y in [-0.6, 0.6] {
        let base = DVec3::new(SLAT_X, y, SILL);
        p.column(id, base, 0.002, 0.002, LINTEL - SILL - 0.02, 0.3);
    }
    // Fan mount: down-rod and motor housing stay still; the blades turn.
    p.column(
        id,
        DVec3::new(0.0, 0.0, 2.45),
        0.02,
        0.02,
        HEIGHT - 2.45,
        1.0,
    );
    p.column(id, DVec3::new(0.0, 0.0, FAN_HUB.z), 0.12, 0.1, 0.15, 1.0);
}

fn bed(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (x0, x1, y0, y1) = (-1.2, 0.4, -0.1, 2.0);
    p.cuboids(
        [
            b([x0 + 0.05, y0 + 0.05, 0.2], [x1 - 0.05, y1 - 0.05, 0.45]),
            b([x0 + 0.08, y0 + 0.08, 0.45], [x1 - 0.08, y1 - 0.08, 0.7]),
            b([x0, y0, 0.7], [x1, 1.3, 0.78]),
            b([x0 + 0.1, 1.45, 0.7], [-0.45, 1.9, 0.85]),
            b([-0.35, 1.45, 0.7], [x1 - 0.1, 1.9, 0.85]),
            b([x0 - 0.05, y1 - 0.06, 0.0], [x1 + 0.05, y1, 1.2]),
        ],
        1.0,
    );
    for (x, y) in [
        (x0 + 0.1, y0 + 0.1),
        (x1 - 0.1, y0 + 0.1),
        (x0 + 0.1, y1 - 0.15),
        (x1 - 0.1, y1 - 0.15),
    ] {
        p.column(id, DVec3::new(x, y, 0.0), 0.04, 0.035, 0.2, 1.0);
    }
    // Nightstand with a lamp.
    let (min, max) = b([0.5, 1.55, 0.0], [0.95, 2.0, 0.55]);
    p.cuboid(id, min, max, 1.0);
    p.column(id, DVec3::new(0.72, 1.78, 0.55), 0.08, 0.08, 0.03, 1.0);
    p.column(id, DVec3::new(0.72, 1.78, 0.58), 0.012, 0.012, 0.3, 1.0);
    p.column(id, DVec3::new(0.72, 1.78, 0.85), 0.15, 0.09, 0.2, 1.0);
}

fn wardrobe(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (min, max) = b([-HX, 0.4, 0.0], [-1.9, 1.9, 2.1]);
    p.cuboid(id, min, max, 1.0);
    for (y0, y1) in [(0.42, 1.14), (1.16, 1.88)] {
        let (min, max) = b([-1.9, y0, 0.05], [-1.88, y1, 2.05]);
        p.cuboid(id, min, max, 1.0);
        let handle_y = if y0 < 1.0 { y1 - 0.06 } else { y0 + 0.06 };
        p.column(id, DVec3::new(-1.86, handle_y, 0.9), 0.01, 0.01, 0.3, 1.0);
    }
}

/// A chair in its own frame: seat centred on the origin, back towards +Y.
pub(crate) fn chair() -> Parts {
    let mut p = Parts::new();
    let id = DAffine3::IDENTITY;
    let (min, max) = b([-0.22, -0.22, 0.43], [0.22, 0.22, 0.47]);
    p.cuboid(id, min, max, 1.0);
    for (x, y) in [(-0.19, -0.19), (0.19, -0.19), (-0.19, 0.19), (0.19, 0.19)] {
        p.column(id, DVec3::new(x, y, 0.0), 0.018, 0.018, 0.43, 1.0);
    }
    for x in [-0.19, 0.19] {
        p.column(id, DVec3::new(x, 0.19, 0.47), 0.018, 0.018, 0.48, 1.0);
    }
    let (min, max) = b([-0.21, 0.17, 0.88], [0.21, 0.21, 0.95]);
    p.cuboid(id, min, max, 1.0);
    for x in [-0.09, 0.0, 0.09] {
        let (min, max) = b([x - 0.02, 0.18, 0.47], [x + 0.02, 0.2, 0.88]);
        p.cuboid(id, min, max, 1.0);
    }
    p
}

fn desk_and_chairs(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (x0, x1, y0, y1) = (0.6, 1.8, -HY, -1.3);
    let (min, max) = b([x0, y0, 0.72], [x1, y1, 0.76]);
    p.cuboid(id, min, max, 1.0);
    for (x, y) in [
        (x0 + 0.05, y0 + 0.05),
        (x1 - 0.05, y0 + 0.05),
        (x0 + 0.05, y1 - 0.05),
        (x1 - 0.05, y1 - 0.05),
    ] {
        p.column(id, DVec3::new(x, y, 0.0), 0.025, 0.025, 0.72, 1.0);
    }
    let c = chair();
    p.extend(c.transformed(DAffine3::from_translation(DVec3::new(1.2, -1.05, 0.0))));
    let by_window =
        DAffine3::from_translation(DVec3::new(1.7, 0.6, 0.0)) * DAffine3::from_rotation_z(2.0);
    p.extend(c.transformed(by_window));
    let (min, max) = b([-1.6, -1.4, 0.0], [1.0, 0.3, 0.01]);
    p.cuboid(id, min, max, 1.0);
}

/// A bookshelf against the north wall, its four shelves filled with books of random size.
fn bookshelf(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (x0, x1, y0, y1) = (1.0, 2.2, 1.7, HY);
    let shelves = [0.0, 0.45, 0.9, 1.35, 1.78];
    p.cuboids(
        [
            b([x0, y0, 0.0], [x0 + 0.02, y1, 1.8]),
            b([x1 - 0.02, y0, 0.0], [x1, y1, 1.8]),
            b([x0 + 0.02, y1 - 0.02, 0.0], [x1 - 0.02, y1, 1.8]),
        ],
        1.0,
    );
    for z in shelves {
        let (min, max) = b([x0 + 0.02, y0, z], [x1 - 0.02, y1 - 0.02, z + 0.02]);
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
            if rng.unit() < 0.06 {
                x += 0.04;
                continue;
            }
            let h = rng.range(0.18, 0.36).min(room);
            let d = rng.range(0.15, 0.24);
            let (min, max) = b([x, y1 - 0.03 - d, floor], [x + w, y1 - 0.03, floor + h]);
            p.cuboid(id, min, max, 1.0);
            x += w + 0.002;
        }
    }
}

/// One slat in its own frame: long along Y, tilting about Y.
fn slat() -> Parts {
    let mut p = Parts::new();
    let (min, max) = b([-0.025, -0.85, -0.0015], [0.025, 0.85, 0.0015]);
    p.cuboid(DAffine3::IDENTITY, min, max, 1.0);
    p
}

/// The fan's turning part in its own frame: hub on the origin, five pitched blades.
fn fan_blades() -> Parts {
    let mut p = Parts::new();
    p.column(
        DAffine3::IDENTITY,
        DVec3::new(0.0, 0.0, -0.04),
        0.1,
        0.1,
        0.04,
        1.0,
    );
    for k in 0..5 {
        let xf = DAffine3::from_rotation_z(TAU * k as f64 / 5.0)
            * DAffine3::from_translation(DVec3::new(0.42, 0.0, -0.03))
            * DAffine3::from_rotation_x(0.2);
        let (min, max) = b([-0.3, -0.07, -0.005], [0.3, 0.07, 0.005]);
        p.cuboid(xf, min, max, 1.0);
    }
    p
}

pub(crate) struct Bedroom {
    clock: Clock,
    stage: Stage,
    slat_mesh: usize,
    slat_heights: Vec<f64>,
    fan_mesh: usize,
}

impl Bedroom {
    pub fn new(params: SceneParams) -> Self {
        let mut room = Parts::new();
        shell(&mut room);
        bed(&mut room);
        wardrobe(&mut room);
        desk_and_chairs(&mut room);
        bookshelf(&mut room);
        let slat_heights: Vec<f64> = (0..)
            .map(|k| LINTEL - 0.04 - k as f64 * SLAT_PITCH)
            .take_while(|&z| z > SILL + 0.03)
            .collect();
        let (slat, fan) = (slat(), fan_blades());
        let density = fit_density(
            &[(&room, 1), (&slat, slat_heights.len()), (&fan, 1)],
            params.triangles,
        );
        let mut stage = Stage::new();
        stage.add_static(room.build(density, "room"), DMat4::IDENTITY);
        let slat_mesh = stage.add_mesh(slat.build(density, "slat"));
        let fan_mesh = stage.add_mesh(fan.build(density, "fan"));
        Bedroom {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            slat_mesh,
            slat_heights,
            fan_mesh,
        }
    }

    fn lights() -> Vec<Light> {
        let sun_dir = DVec3::new(-0.8, 0.25, -0.55);
        // A sky portal just outside the window: soft striped light through the blinds.
        let portal = Light::new(
            "Window",
            aimed(
                DVec3::new(HX + 0.45, 0.0, 0.5 * (SILL + LINTEL)),
                DVec3::NEG_X,
            ),
            LightKind::Area {
                shape: AreaShape::Rectangle,
                size_x: 2.0 * WY,
                size_y: LINTEL - SILL,
            },
        );
        vec![sun("Sun", sun_dir, 0.02), portal]
    }
}

impl Animation for Bedroom {
    fn name(&self) -> &str {
        "bedroom"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let u = ease(self.clock.progress(frame));
        let eye = lerp3(DVec3::new(-2.1, -1.6, 1.6), DVec3::new(-1.2, -1.1, 1.45), u);
        let target = lerp3(DVec3::new(2.0, 0.3, 1.2), DVec3::new(0.8, 1.2, 0.9), u);
        let cam = camera(eye, target, 18.0, (0.05, 20.0));
        let mut scene = self.stage.scene(frame, cam, Bedroom::lights());
        let seconds = self.clock.seconds(frame);
        // The blinds open and close over four seconds, tilting 0.15 (nearly flat) to 1.35 rad
        // with their outer edge up: parallel to the sun's rays (0.6 rad) lets it in, steeper
        // shuts it out.
        let tilt = -(0.75 + 0.6 * (TAU * seconds / 4.0).sin());
        for (k, &z) in self.slat_heights.iter().enumerate() {
            let xf =
                DMat4::from_translation(DVec3::new(SLAT_X, 0.0, z)) * DMat4::from_rotation_y(tilt);
            add_object(&mut scene, format!("slat.{k:02}"), self.slat_mesh, xf);
        }
        let fan = DMat4::from_translation(FAN_HUB) * DMat4::from_rotation_z(TAU * 0.8 * seconds);
        add_object(&mut scene, "fan".into(), self.fan_mesh, fan);
        scene
    }
}
