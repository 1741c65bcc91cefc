//! `character-room`: one character (a body of ellipsoids and cylinders whose limbs swing and
//! whose torso twists: a new mesh every frame, same triangle list) walks a loop through a large
//! static hall: walls, a window, pillars, tables and chairs, a sofa, and shelves along one wall
//! full of small objects. The static set holds about 97% of the triangles and keeps its `Arc`s
//! and matrices in every frame; only the character and the camera following it move. A ceiling
//! lamp (point light), a ceiling panel (area light) and the sun through the window light it.

use std::f64::consts::{PI, TAU};
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, AreaShape, Light, LightKind, Mesh, Scene};
use glam::{DAffine3, DMat4, DQuat, DVec3, Vec3};

use crate::bedroom::chair;
use crate::builder::MeshBuilder;
use crate::params::SceneParams;
use crate::rng::Pcg32;
use crate::shapes::{fit_density, span as b, Parts, Shape};
use crate::stage::{add_deforming, aimed, camera, point, sun, sun_direction, Clock, Stage};

const SEED: u64 = 0x4348_4152_524f_4f4d;
/// Interior: x in -HX..HX, y in -HY..HY, z in 0..HEIGHT; walls THICK thick.
const HX: f64 = 10.0;
const HY: f64 = 6.0;
const HEIGHT: f64 = 4.0;
const THICK: f64 = 0.2;
/// The window in the south wall (y = -HY): x in -WX..WX, z in SILL..LINTEL.
const WX: f64 = 3.0;
const SILL: f64 = 1.0;
const LINTEL: f64 = 3.0;
/// Shelf units along the north wall, their levels, and their depth.
const SHELF_UNITS: usize = 6;
const SHELF_LEVELS: [f64; 6] = [0.0, 0.42, 0.84, 1.26, 1.68, 2.1];
const SHELF_DEPTH: f64 = 0.4;
/// The character's share of the budget (never below `CHARACTER_MIN` triangles).
const CHARACTER_SHARE: f64 = 0.03;
const CHARACTER_MIN: usize = 400;
/// The walk: an ellipse around the middle of the hall, at walking speed.
const WALK: (f64, f64) = (6.5, 1.8);
const SPEED: f64 = 1.3;
/// Metres per full gait cycle (two steps).
const STRIDE: f64 = 1.4;

/// Floor, ceiling and walls (overlapping at the corners, so closed but for the window), with
/// the window's sill and mullions.
fn shell(p: &mut Parts) {
    let id = DAffine3::IDENTITY;
    let (ox, oy) = (HX + THICK, HY + THICK);
    p.cuboids(
        [
            b([-ox, -oy, -THICK], [ox, oy, 0.0]),
            b([-ox, -oy, HEIGHT], [ox, oy, HEIGHT + THICK]),
            b([-ox, -oy, 0.0], [-HX, oy, HEIGHT]),
            b([HX, -oy, 0.0], [ox, oy, HEIGHT]),
            b([-HX, HY, 0.0], [HX, oy, HEIGHT]),
            b([-HX, -oy, 0.0], [HX, -HY, SILL]),
            b([-HX, -oy, LINTEL], [HX, -HY, HEIGHT]),
            b([-HX, -oy, SILL], [-WX, -HY, LINTEL]),
            b([WX, -oy, SILL], [HX, -HY, LINTEL]),
        ],
        0.15,
    );
    let (min, max) = b([-WX - 0.1, -HY, SILL - 0.04], [WX + 0.1, -HY + 0.2, SILL]);
    p.cuboid(id, min, max, 1.0);
    let mullion_y = (-HY - 0.12, -HY - 0.08);
    for x in [-1.0, 1.0] {
        let (min, max) = b(
            [x - 0.03, mullion_y.0, SILL],
            [x + 0.03, mullion_y.1, LINTEL],
        );
        p.cuboid(id, min, max, 1.0);
    }
    let (min, max) = b([-WX, mullion_y.0, 1.97], [WX, mullion_y.1, 2.03]);
    p.cuboid(id, min, max, 1.0);
    // Two pillars, and the ceiling lamp: a rod and a shade.
    for x in [-3.0, 3.0] {
        p.column(id, DVec3::new(x, 4.2, 0.0), 0.25, 0.25, HEIGHT, 0.5);
    }
    p.column(id, DVec3::new(0.0, 0.0, 3.65), 0.015, 0.015, 0.35, 1.0);
    p.column(id, DVec3::new(0.0, 0.0, 3.45), 0.3, 0.12, 0.2, 1.0);
}

/// A table of `top` (min, max corners) on four legs.
fn table(p: &mut Parts, min: DVec3, max: DVec3) {
    let id = DAffine3::IDENTITY;
    let thick = 0.04;
    p.cuboid(id, DVec3::new(min.x, min.y, max.z - thick), max, 1.0);
    for (x, y) in [
        (min.x + 0.06, min.y + 0.06),
        (max.x - 0.06, min.y + 0.06),
        (min.x + 0.06, max.y - 0.06),
        (max.x - 0.06, max.y - 0.06),
    ] {
        p.column(id, DVec3::new(x, y, 0.0), 0.03, 0.025, max.z - thick, 1.0);
    }
}

fn furniture(p: &mut Parts) {
    // Dining table with four chairs, a desk with one, by the window wall.
    table(p, DVec3::new(4.0, -4.5, 0.0), DVec3::new(6.0, -3.5, 0.76));
    table(p, DVec3::new(-6.0, -5.7, 0.0), DVec3::new(-4.0, -5.0, 0.78));
    let c = chair();
    for (x, y, turn) in [
        (4.5, -3.15, 0.0),
        (5.5, -3.15, 0.0),
        (4.5, -4.85, PI),
        (5.5, -4.85, PI),
        (-5.0, -4.65, 0.0),
    ] {
        let xf =
            DAffine3::from_translation(DVec3::new(x, y, 0.0)) * DAffine3::from_rotation_z(turn);
        p.extend(c.transformed(xf));
    }
    // Sofa against the west wall, and a low table in front of it.
    p.cuboids(
        [
            b([-9.95, -1.5, 0.0], [-9.0, 1.5, 0.42]),
            b([-9.95, -1.5, 0.42], [-9.7, 1.5, 0.9]),
            b([-9.95, -1.7, 0.0], [-9.0, -1.5, 0.65]),
            b([-9.95, 1.5, 0.0], [-9.0, 1.7, 0.65]),
        ],
        1.0,
    );
    table(p, DVec3::new(-8.5, -0.6, 0.0), DVec3::new(-7.9, 0.6, 0.45));
}

/// The frames of the shelf units: local X along the unit (0..width), the back at local
/// y = SHELF_DEPTH against the north wall.
fn shelf_frames() -> Vec<(DAffine3, f64)> {
    let width = 2.8;
    (0..SHELF_UNITS)
        .map(|k| {
            let x0 = -9.0 + 3.0 * k as f64;
            let at = DVec3::new(x0, HY - SHELF_DEPTH, 0.0);
            (DAffine3::from_translation(at), width)
        })
        .collect()
}

fn shelves(p: &mut Parts) {
    let top = SHELF_LEVELS[SHELF_LEVELS.len() - 1] + 0.02;
    for (xf, w) in shelf_frames() {
        for (min, max) in [
            b([0.0, 0.0, 0.0], [0.02, SHELF_DEPTH, top]),
            b([w - 0.02, 0.0, 0.0], [w, SHELF_DEPTH, top]),
            b(
                [0.02, SHELF_DEPTH - 0.02, 0.0],
                [w - 0.02, SHELF_DEPTH, top],
            ),
        ] {
            p.cuboid(xf, min, max, 1.0);
        }
        for z in SHELF_LEVELS {
            let (min, max) = b([0.02, 0.0, z], [w - 0.02, SHELF_DEPTH - 0.02, z + 0.02]);
            p.cuboid(xf, min, max, 1.0);
        }
    }
}

/// Books, boxes, jars and balls on every shelf, `count` of them at most, spread evenly over
/// the places there are.
fn clutter(count: usize) -> Parts {
    let mut rng = Pcg32::new(SEED, 1);
    let mut all = Vec::new();
    for (xf, w) in shelf_frames() {
        for level in SHELF_LEVELS.windows(2) {
            let (floor, room) = (level[0] + 0.02, level[1] - level[0] - 0.06);
            let mut x = 0.04;
            loop {
                let kind = rng.below(4);
                let width = rng.range(0.025, 0.09);
                if x + width > w - 0.04 {
                    break;
                }
                let h = rng.range(0.08, 0.32).min(room);
                let d = rng.range(0.12, 0.3);
                let back = SHELF_DEPTH - 0.03;
                let cx = x + 0.5 * width;
                let shape = match kind {
                    0 | 1 => Shape::Box {
                        min: DVec3::new(x, back - d, floor),
                        max: DVec3::new(x + width, back, floor + h),
                    },
                    2 => Shape::Cylinder {
                        r0: 0.5 * width,
                        r1: 0.45 * width,
                        height: h.min(2.0 * width + 0.05),
                        caps: true,
                    },
                    _ => Shape::Ellipsoid {
                        radii: DVec3::splat(0.5 * width),
                    },
                };
                let at = match kind {
                    0 | 1 => DAffine3::IDENTITY,
                    2 => DAffine3::from_translation(DVec3::new(cx, back - 0.5 * d, floor)),
                    _ => DAffine3::from_translation(DVec3::new(
                        cx,
                        back - 0.5 * d,
                        floor + 0.5 * width,
                    )),
                };
                all.push((shape, xf * at));
                x += width + 0.006;
            }
        }
    }
    let step = (all.len() as f64 / count.max(1) as f64).max(1.0);
    let mut p = Parts::new();
    let mut next = 0.0;
    while (next as usize) < all.len() {
        let (shape, xf) = all[next as usize];
        p.add(shape, xf, 1.0);
        next += step;
    }
    p
}

/// The character in its rest pose, feet on the origin, facing local +X; each vertex belongs to
/// one bone: 0 the body and head, 1 and 2 the arms, 3 and 4 the legs.
struct Character {
    rest: Vec<Vec3>,
    bones: Vec<u8>,
    triangles: Vec<[u32; 3]>,
}

/// Shoulders and hips: where the limbs (bones 1..=4) turn.
const PIVOTS: [DVec3; 4] = [
    DVec3::new(0.0, 0.26, 1.46),
    DVec3::new(0.0, -0.26, 1.46),
    DVec3::new(0.0, 0.1, 0.92),
    DVec3::new(0.0, -0.1, 0.92),
];

impl Character {
    fn parts() -> Vec<(Parts, u8)> {
        let id = DAffine3::IDENTITY;
        let mut body = Parts::new();
        for (centre, radii) in [
            (DVec3::new(0.0, 0.0, 1.22), DVec3::new(0.15, 0.22, 0.32)),
            (DVec3::new(0.0, 0.0, 0.95), DVec3::new(0.13, 0.19, 0.13)),
            (DVec3::new(0.02, 0.0, 1.72), DVec3::new(0.11, 0.1, 0.13)),
        ] {
            body.add(
                Shape::Ellipsoid { radii },
                DAffine3::from_translation(centre),
                1.0,
            );
        }
        body.column(id, DVec3::new(0.0, 0.0, 1.5), 0.05, 0.05, 0.14, 1.0);
        let mut parts = vec![(body, 0)];
        for (k, pivot) in PIVOTS.iter().enumerate() {
            let arm = k < 2;
            let (r0, r1, length) = if arm {
                (0.05, 0.04, 0.62)
            } else {
                (0.075, 0.05, 0.86)
            };
            let mut limb = Parts::new();
            // Hanging down from the pivot.
            let down = DAffine3::from_translation(*pivot) * DAffine3::from_rotation_x(PI);
            limb.column(down, DVec3::ZERO, r0, r1, length, 1.0);
            let end = *pivot - DVec3::new(0.0, 0.0, length);
            if arm {
                limb.add(
                    Shape::Ellipsoid {
                        radii: DVec3::new(0.05, 0.035, 0.07),
                    },
                    DAffine3::from_translation(end - DVec3::new(0.0, 0.0, 0.05)),
                    1.0,
                );
            } else {
                let (min, max) = b([-0.06, -0.05, 0.0], [0.18, 0.05, 0.07]);
                limb.cuboid(
                    DAffine3::from_translation(DVec3::new(0.0, pivot.y, 0.0)),
                    min,
                    max,
                    1.0,
                );
            }
            parts.push((limb, 1 + k as u8));
        }
        parts
    }

    fn new(triangles: usize) -> Self {
        let parts = Character::parts();
        let groups: Vec<(&Parts, usize)> = parts.iter().map(|(p, _)| (p, 1)).collect();
        let density = fit_density(&groups, triangles);
        let mut mb = MeshBuilder::new();
        let mut bones = Vec::new();
        for (p, bone) in &parts {
            for part in &p.0 {
                part.emit(density, &mut mb);
            }
            bones.resize(mb.positions.len(), *bone);
        }
        Character {
            rest: mb.positions,
            bones,
            triangles: mb.triangles,
        }
    }

    fn triangle_count(triangles: usize) -> usize {
        let parts = Character::parts();
        let groups: Vec<(&Parts, usize)> = parts.iter().map(|(p, _)| (p, 1)).collect();
        let density = fit_density(&groups, triangles);
        parts.iter().map(|(p, _)| p.triangles(density)).sum()
    }

    /// The pose `phase` radians into the gait: legs and arms swing about their pivots in
    /// opposition, the upper body twists (smoothly, growing with height) and bobs.
    fn mesh_at(&self, phase: f64) -> Mesh {
        let swing = phase.sin();
        let limbs: [DAffine3; 4] = std::array::from_fn(|k| {
            let amplitude = if k < 2 { 0.4 } else { 0.45 };
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let sign = if k < 2 { -side } else { side };
            let pivot = PIVOTS[k];
            DAffine3::from_translation(pivot)
                * DAffine3::from_rotation_y(sign * amplitude * swing)
                * DAffine3::from_translation(-pivot)
        });
        let bob = DVec3::new(0.0, 0.0, 0.02 * (1.0 - (2.0 * phase).cos()));
        let positions = self
            .rest
            .iter()
            .zip(&self.bones)
            .map(|(&p, &bone)| {
                let p = p.as_dvec3();
                let q = match bone {
                    0 => {
                        let t = ((p.z - 0.9) / 0.9).clamp(0.0, 1.0);
                        DQuat::from_rotation_z(0.15 * swing * t) * p
                    }
                    k => limbs[k as usize - 1].transform_point3(p),
                };
                (q + bob).as_vec3()
            })
            .collect();
        Mesh::new("character", positions, self.triangles.clone())
    }
}

/// Where the walk is after `distance` metres, and the heading there (radians about Z).
fn walk(distance: f64) -> (DVec3, f64) {
    let (a, b) = WALK;
    // Arc length of an ellipse over the mean radius: close enough for a steady pace.
    let mean = ((a * a + b * b) * 0.5).sqrt();
    let t = PI + distance / mean;
    let position = DVec3::new(a * t.cos(), b * t.sin(), 0.0);
    let heading = (b * t.cos()).atan2(-a * t.sin());
    (position, heading)
}

pub(crate) struct CharacterRoom {
    clock: Clock,
    stage: Stage,
    character: Character,
}

impl CharacterRoom {
    pub fn new(params: SceneParams) -> Self {
        let target = params.triangles;
        let character_target = ((target as f64 * CHARACTER_SHARE) as usize).max(CHARACTER_MIN);
        let character_triangles = Character::triangle_count(character_target);
        let mut room = Parts::new();
        shell(&mut room);
        furniture(&mut room);
        shelves(&mut room);
        // Small objects take about a third of the budget at their coarsest (12 to 24
        // triangles each), as many as the shelves hold.
        let objects = clutter(target / 48);
        let density = fit_density(
            &[(&room, 1), (&objects, 1)],
            target.saturating_sub(character_triangles),
        );
        let mut stage = Stage::new();
        stage.add_static(room.build(density, "hall"), DMat4::IDENTITY);
        stage.add_static(objects.build(density, "shelf-objects"), DMat4::IDENTITY);
        CharacterRoom {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            character: Character::new(character_target),
        }
    }

    fn lights() -> Vec<Light> {
        let panel = Light::new(
            "Panel",
            aimed(DVec3::new(-5.0, 0.0, HEIGHT - 0.02), DVec3::NEG_Z),
            LightKind::Area {
                shape: AreaShape::Rectangle,
                size_x: 1.2,
                size_y: 0.6,
            },
        );
        vec![
            sun("Sun", sun_direction(0.6, -1.3), 0.01),
            point("Lamp", DVec3::new(0.0, 0.0, 3.3), 0.08),
            panel,
        ]
    }
}

impl Animation for CharacterRoom {
    fn name(&self) -> &str {
        "character-room"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let distance = SPEED * self.clock.seconds(frame);
        let (at, heading) = walk(distance);
        // The camera follows behind and to the inside of the loop, turning with a lag.
        let (_, lagged) = walk(distance - 1.5);
        let behind = DQuat::from_rotation_z(lagged) * DVec3::new(-3.2, 1.2, 0.0);
        let forward = DQuat::from_rotation_z(heading) * DVec3::X;
        let eye = at + behind + DVec3::new(0.0, 0.0, 2.2);
        let cam = camera(
            eye,
            at + forward + DVec3::new(0.0, 0.0, 1.0),
            24.0,
            (0.05, 40.0),
        );
        let mut scene = self.stage.scene(frame, cam, CharacterRoom::lights());
        let phase = TAU * distance / STRIDE;
        let xf = DMat4::from_translation(at) * DMat4::from_rotation_z(heading);
        add_deforming(&mut scene, self.character.mesh_at(phase), xf);
        scene
    }
}
