//! `hairball`: a ball of many thin closed tubes above a ground plane. Little occlusion per ray but
//! long, thin, overlapping triangles whose boxes overlap badly: a hard case for box-based BVHs.
//! The ball turns slowly while the camera orbits it.

use std::f64::consts::TAU;
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, Light, LightKind, Scene};
use glam::{DAffine3, DMat4, DQuat, DVec3};

use crate::builder::MeshBuilder;
use crate::params::SceneParams;
use crate::primitives::{box_grid, tube, tube_triangles};
use crate::rng::Pcg32;
use crate::stage::{add_object, aimed, camera, point, Clock, Stage};

const SEED: u64 = 0x4841_4952_4241_4c4c;
const SIDES: u32 = 6;
/// Tube radius relative to the ball's radius of 1.
const TUBE_RADIUS: f64 = 0.004;
const CENTER: DVec3 = DVec3::new(0.0, 0.0, 1.6);
const GROUND_TRIANGLES: usize = 12;

pub(crate) struct Hairball {
    clock: Clock,
    stage: Stage,
    ball: usize,
}

impl Hairball {
    pub fn new(params: SceneParams) -> Self {
        let target = params.triangles.saturating_sub(GROUND_TRIANGLES);
        // Longer strands get more segments so they stay smooth; the strand count takes the rest.
        let segments = (8.0 * (target as f64 / 1000.0).cbrt())
            .round()
            .clamp(24.0, 128.0) as usize;
        let per_strand = tube_triangles(segments, SIDES, true);
        let strands = (target as f64 / per_strand as f64).round().max(8.0) as u64;

        let mut mb = MeshBuilder::new();
        for s in 0..strands {
            tube(&mut mb, &strand(s, segments), TUBE_RADIUS, SIDES, true);
        }
        let mut stage = Stage::new();
        let ball = stage.add_mesh(mb.build("hairball"));
        let mut ground = MeshBuilder::new();
        box_grid(
            &mut ground,
            &DAffine3::IDENTITY,
            DVec3::new(-15.0, -15.0, -0.1),
            DVec3::new(15.0, 15.0, 0.0),
            [1, 1, 1],
        );
        stage.add_static(ground.build("ground"), DMat4::IDENTITY);
        Hairball {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            ball,
        }
    }

    fn lights() -> Vec<Light> {
        let spot_at = DVec3::new(-3.0, 1.5, 4.5);
        vec![
            point("Key", DVec3::new(2.5, -2.0, 4.0), 0.2),
            Light::new(
                "Spot",
                aimed(spot_at, CENTER - spot_at),
                LightKind::Spot {
                    radius: 0.05,
                    spot_size: 0.7,
                    spot_blend: 0.15,
                },
            ),
        ]
    }
}

/// One closed strand: a circle of random radius in a random plane, wobbling in and out of it.
fn strand(index: u64, segments: usize) -> Vec<DVec3> {
    let mut rng = Pcg32::new(SEED, index);
    let normal = rng.direction();
    let spin = DQuat::from_axis_angle(normal, rng.range(0.0, TAU));
    let e1 = spin * normal.any_orthonormal_vector();
    let e2 = normal.cross(e1);
    let r = 0.3 + 0.7 * rng.unit().sqrt();
    let mut wave = |amplitude: f64, lo: u32, span: u32| {
        (
            amplitude * r,
            (lo + rng.below(span)) as f64,
            rng.range(0.0, TAU),
        )
    };
    let (a1, f1, p1) = wave(0.1, 2, 3);
    let (a2, f2, p2) = wave(0.2, 3, 4);
    let (a3, f3, p3) = wave(0.06, 7, 5);
    (0..segments)
        .map(|k| {
            let t = TAU * k as f64 / segments as f64;
            let radial = r + a1 * (f1 * t + p1).sin();
            let lift = a2 * (f2 * t + p2).sin() + a3 * (f3 * t + p3).sin();
            e1 * (radial * t.cos()) + e2 * (radial * t.sin()) + normal * lift
        })
        .collect()
}

impl Animation for Hairball {
    fn name(&self) -> &str {
        "hairball"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let u = self.clock.progress(frame);
        let angle = -TAU * 0.25 + 0.8 * u;
        let eye = DVec3::new(5.5 * angle.cos(), 5.5 * angle.sin(), 2.4);
        let cam = camera(eye, CENTER, 35.0, (0.1, 100.0));
        let mut scene = self.stage.scene(frame, cam, Hairball::lights());
        // A slow spin about Z of a ball tilted once, so the strands sweep through the BVH's boxes.
        let spin = DMat4::from_translation(CENTER)
            * DMat4::from_rotation_z(0.3 * self.clock.seconds(frame))
            * DMat4::from_rotation_x(0.35);
        add_object(&mut scene, "hairball".into(), self.ball, spin);
        scene
    }
}
