//! `instanced-forest`: thousands of instances (up to millions with `instances`) of three still
//! trees on a flat ground, each turned about Z and scaled; about one in fifty is mirrored
//! (negative scale on one axis) and one in fifty sheared, the transforms a top-level tree over
//! instances must handle. Meshes and objects are the same in every frame: the camera flies over
//! while the sun sinks slowly, and a beacon (point light) hangs over the middle.

use std::f64::consts::TAU;
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, Camera, Light, Scene};
use glam::{DMat4, DQuat, DVec3, DVec4};

use crate::builder::MeshBuilder;
use crate::forest::{still_tree, TreeDetail};
use crate::params::SceneParams;
use crate::primitives::grid;
use crate::rng::Pcg32;
use crate::stage::{camera, ease, lerp3, point, sun, sun_direction, Clock, Stage};

const SEED: u64 = 0x494e_5354_414e_4345;
/// Each tree's share of the trees' triangle budget (they add up to the number of trees).
const TREE_SHARES: [f64; 3] = [0.8, 1.0, 1.2];
const SPACING: f64 = 7.0;
const GROUND_CELLS: u32 = 16;
/// Below this many instances the scene would hardly be a forest.
const MIN_INSTANCES: usize = 16;
/// Shares of mirrored and of sheared instances.
const MIRRORED: f64 = 0.02;
const SHEARED: f64 = 0.02;

/// The triangles of one tree when the world budget is `triangles`: small trees, so that the
/// budget buys thousands of instances (about 70 triangles and 5,000 trees at 350k).
fn world_tree_budget(triangles: usize) -> f64 {
    ((triangles as f64).sqrt() / 8.0).max(60.0)
}

pub(crate) struct InstancedForest {
    clock: Clock,
    stage: Stage,
    extent: f64,
}

impl InstancedForest {
    pub fn new(params: SceneParams) -> Self {
        let mut stage = Stage::new();
        // With `instances` the budget is that of the unique triangles, shared by the trees.
        let per_tree = match params.instances {
            Some(_) => params.triangles as f64 / TREE_SHARES.len() as f64,
            None => world_tree_budget(params.triangles),
        };
        let mut tree_triangles = Vec::new();
        let trees: Vec<usize> = TREE_SHARES
            .iter()
            .enumerate()
            .map(|(k, share)| {
                let detail = TreeDetail::for_tree((per_tree * share).round() as usize);
                let mesh = still_tree(SEED, 1 + k as u64, &detail, &format!("tree.{k}"));
                tree_triangles.push(mesh.triangles.len());
                stage.add_mesh(mesh)
            })
            .collect();
        let ground_triangles = 2 * (GROUND_CELLS as usize).pow(2);
        let count = params.instances.unwrap_or_else(|| {
            let mean = tree_triangles.iter().sum::<usize>() as f64 / trees.len() as f64;
            let rest = params.triangles.saturating_sub(ground_triangles);
            ((rest as f64 / mean).round() as usize).max(MIN_INSTANCES)
        });

        // One jittered grid cell per tree, so trees never stand inside each other. A fixed number
        // of draws per tree keeps every tree where it is whatever the count.
        let per_side = (count as f64).sqrt().ceil() as usize;
        let extent = per_side as f64 * SPACING;
        let mut rng = Pcg32::new(SEED, 0);
        stage.reserve_objects(count + 1);
        for i in 0..count {
            let (cx, cy) = ((i % per_side) as f64, (i / per_side) as f64);
            let x = -0.5 * extent + (cx + 0.5 + rng.range(-0.4, 0.4)) * SPACING;
            let y = -0.5 * extent + (cy + 0.5 + rng.range(-0.4, 0.4)) * SPACING;
            let turn = DQuat::from_rotation_z(rng.range(0.0, TAU));
            let scale = rng.range(0.7, 1.3);
            let tree = trees[rng.below(trees.len() as u32) as usize];
            let (kind, lean) = (rng.unit(), rng.range(0.05, 0.2));
            // Sunk a little so the trunk meets the ground.
            let at = DVec3::new(x, y, -0.05);
            let mut xf = DMat4::from_scale_rotation_translation(DVec3::splat(scale), turn, at);
            if kind < MIRRORED {
                xf *= DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
            } else if kind < MIRRORED + SHEARED {
                // x += lean * z: a tree leaning over, its horizontal sections unchanged.
                xf *= DMat4::from_cols(
                    DVec4::X,
                    DVec4::Y,
                    DVec4::new(lean, 0.0, 1.0, 0.0),
                    DVec4::W,
                );
            }
            stage.place(format!("tree.{i:07}"), tree, xf);
        }

        let half = 0.5 * extent + 20.0;
        let mut ground = MeshBuilder::new();
        grid(
            &mut ground,
            GROUND_CELLS,
            GROUND_CELLS,
            false,
            false,
            |i, j| {
                let s = 2.0 * half / GROUND_CELLS as f64;
                DVec3::new(-half + s * i as f64, -half + s * j as f64, 0.0)
            },
        );
        stage.add_static(ground.build("ground"), DMat4::IDENTITY);
        InstancedForest {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            extent,
        }
    }

    /// What moves: the camera flying over and the sinking sun, with the beacon.
    fn view(&self, frame: i32) -> (Camera, Vec<Light>) {
        let e = self.extent;
        let u = self.clock.progress(frame);
        let height = 15.0 + 0.02 * e;
        let eased = ease(u);
        let eye = lerp3(
            DVec3::new(-0.4 * e, -0.45 * e, height),
            DVec3::new(-0.05 * e, -0.1 * e, 0.8 * height),
            eased,
        );
        let target = lerp3(
            DVec3::new(0.0, -0.1 * e, 0.0),
            DVec3::new(0.25 * e, 0.2 * e, 0.0),
            eased,
        );
        let cam = camera(eye, target, 28.0, (0.1, 4.0 * e + 100.0));
        let lights = vec![
            sun("Sun", sun_direction(0.75 - 0.15 * u, 3.6 + 0.25 * u), 0.02),
            point("Beacon", DVec3::new(0.0, 0.0, 14.0), 0.25),
        ];
        (cam, lights)
    }
}

impl Animation for InstancedForest {
    fn name(&self) -> &str {
        "instanced-forest"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let (cam, lights) = self.view(frame);
        self.stage.scene(frame, cam, lights)
    }

    /// The stage's objects (a million with `--instances 1000000`) move into the frame.
    fn into_frame(self: Box<Self>, frame: i32) -> Scene {
        let (cam, lights) = self.view(frame);
        self.stage.into_scene(frame, cam, lights)
    }
}
