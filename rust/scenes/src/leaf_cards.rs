//! `leaf-cards`: a garden of alpha-textured cards (issue 38) over a ground plane. Trees are
//! trunks under crowns of leaf cards (quads whose shape is a procedural leaf mask, Linear and
//! Clip), a fence of picket cards (a bar mask, Closest and Repeat) and two overlapping glass
//! panes of constant alpha 0.5, under a sun and a point light. Crowns sway (rigid motion of
//! their objects); the camera walks past. What it exercises: transparent shadows, camera rays
//! past clipped texels, fractional masks, and the cost of traversal past transparent texels.

use std::ops::RangeInclusive;
use std::sync::Arc;

use antumbra_core::alpha::{AlphaImage, AlphaProgram, Extension, Interpolation};
use antumbra_core::scene::{AlphaMaterial, Animation, Mesh, Scene, SceneAlpha, UvMap};
use glam::{DAffine3, DMat4, DQuat, DVec3, Vec3};

use crate::params::SceneParams;
use crate::rng::Pcg32;
use crate::stage::{add_object, camera, ease, lerp3, point, sun, sun_direction, Clock, Stage};

const SEED: u64 = 0x4c45_4146;
const TREES: usize = 8;
/// Fence cards, each 2 m wide.
const FENCE_CARDS: usize = 12;
/// Leaf cards per crown at the smallest budget.
const MIN_CARDS: usize = 16;
/// The UV map every card mesh carries and the materials read.
const UV_MAP: &str = "UVMap";
/// Alpha materials, by index: the leaves, the fence, the glass.
const LEAF: u32 = 0;
const FENCE: u32 = 1;
const GLASS: u32 = 2;

/// A 64x64 leaf: an ellipse along v with a soft rim (alpha falls from 1 to 0 over its last
/// eighth), transparent outside.
pub fn leaf_image() -> AlphaImage {
    let n = 64u32;
    let texels = (0..n * n)
        .map(|i| {
            let u = ((i % n) as f64 + 0.5) / n as f64;
            let v = ((i / n) as f64 + 0.5) / n as f64;
            let d = (((u - 0.5) / 0.28).powi(2) + ((v - 0.5) / 0.46).powi(2)).sqrt();
            ((1.0 - d) * 8.0).clamp(0.0, 1.0) as f32
        })
        .collect();
    AlphaImage {
        width: n,
        height: n,
        texels,
    }
}

/// A 32x32 tile of two pickets and two rails: 1 on wood, 0 between.
pub fn fence_image() -> AlphaImage {
    let n = 32u32;
    let texels = (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            let picket = x % 16 < 10;
            let rail = (6..10).contains(&y) || (22..26).contains(&y);
            if picket || rail {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    AlphaImage {
        width: n,
        height: n,
        texels,
    }
}

/// The scene's images and materials.
fn scene_alpha() -> SceneAlpha {
    let material = |name: &str, program| AlphaMaterial {
        name: name.into(),
        uv_map: UV_MAP.into(),
        program,
    };
    SceneAlpha {
        images: vec![Arc::new(leaf_image()), Arc::new(fence_image())],
        materials: vec![
            material(
                "Leaf",
                AlphaProgram::image(0, 0, Interpolation::Linear, Extension::Clip),
            ),
            material(
                "Fence",
                AlphaProgram::image(1, 0, Interpolation::Closest, Extension::Repeat),
            ),
            material("Glass", AlphaProgram::constant(0.5)),
        ],
    }
}

/// Quads as a mesh with the UV map `UV_MAP`: each card's corners (counter-clockwise) with
/// their UVs, two triangles a card.
#[derive(Default)]
struct Cards {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    uvs: Vec<[[f32; 2]; 3]>,
}

impl Cards {
    fn card(&mut self, corners: [DVec3; 4], uv: [[f32; 2]; 4]) {
        let base = self.positions.len() as u32;
        self.positions.extend(corners.map(|c| c.as_vec3()));
        for [a, b, c] in [[0, 1, 2], [0, 2, 3]] {
            self.triangles.push([base + a, base + b, base + c]);
            self.uvs
                .push([uv[a as usize], uv[b as usize], uv[c as usize]]);
        }
    }

    /// A `w` x `h` card centred at `xf`'s origin in its local XY plane, UVs scaled by `repeat`.
    fn rect(&mut self, xf: &DAffine3, w: f64, h: f64, repeat: [f32; 2]) {
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(x, y)| xf.transform_point3(DVec3::new(x * w / 2.0, y * h / 2.0, 0.0)));
        let [ru, rv] = repeat;
        self.card(corners, [[0.0, 0.0], [ru, 0.0], [ru, rv], [0.0, rv]]);
    }

    fn build(self, name: &str) -> Mesh {
        let map = UvMap {
            name: UV_MAP.into(),
            corners: self.uvs,
        };
        Mesh::new(name, self.positions, self.triangles).with_alpha(Vec::new(), vec![map])
    }
}

/// A box from `min` to `max` (12 triangles, opaque).
fn cuboid(name: &str, min: DVec3, max: DVec3) -> Mesh {
    let c = |i: u32| {
        DVec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
        .as_vec3()
    };
    let positions = (0..8).map(c).collect();
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = faces
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    Mesh::new(name, positions, triangles)
}

/// One tree: where it stands, and its crown's mesh in the stage.
struct Tree {
    base: DVec3,
    crown: usize,
    phase: f64,
}

pub struct LeafCards {
    stage: Stage,
    trees: Vec<Tree>,
    alpha: SceneAlpha,
    clock: Clock,
}

impl LeafCards {
    pub fn new(params: SceneParams) -> Self {
        let mut rng = Pcg32::new(SEED, 1);
        let mut stage = Stage::new();
        let ground = Mesh::new(
            "Ground",
            vec![
                Vec3::new(-20.0, -20.0, 0.0),
                Vec3::new(20.0, -20.0, 0.0),
                Vec3::new(20.0, 20.0, 0.0),
                Vec3::new(-20.0, 20.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        stage.add_static(ground, DMat4::IDENTITY);

        // Fence along y = -6, its pickets 8 to a card.
        let mut fence = Cards::default();
        for i in 0..FENCE_CARDS {
            let x = -12.0 + 2.0 * i as f64 + 1.0;
            let xf = DAffine3::from_translation(DVec3::new(x, -6.0, 0.6))
                * DAffine3::from_rotation_x(std::f64::consts::FRAC_PI_2);
            fence.rect(&xf, 2.0, 1.2, [4.0, 1.0]);
        }
        stage.add_static_with(fence.build("Fence"), DMat4::IDENTITY, vec![Some(FENCE)]);

        // Two glass panes overlapping by half: 0.5 through one, 0.25 through both.
        let mut glass = Cards::default();
        for (x, y) in [(6.0, -3.0), (7.0, -2.5)] {
            let xf = DAffine3::from_translation(DVec3::new(x, y, 1.0))
                * DAffine3::from_rotation_x(std::f64::consts::FRAC_PI_2);
            glass.rect(&xf, 2.0, 2.0, [1.0, 1.0]);
        }
        stage.add_static_with(glass.build("Glass"), DMat4::IDENTITY, vec![Some(GLASS)]);

        // The cards' share of the budget, split between the crowns.
        let fixed = 2 + 2 * FENCE_CARDS + 4 + TREES * 12;
        let cards = (params.triangles.saturating_sub(fixed) / (2 * TREES)).max(MIN_CARDS);
        // Cards shrink as they multiply, so a crown holds about the same leaf area.
        let half = (0.35 * (400.0 / cards as f64).sqrt()).clamp(0.04, 0.35);
        let mut trees = Vec::with_capacity(TREES);
        for t in 0..TREES {
            let base = DVec3::new(-9.0 + 2.6 * t as f64, 1.0 + 2.0 * (t % 2) as f64, 0.0);
            let trunk = cuboid(
                &format!("Trunk.{t:02}"),
                base + DVec3::new(-0.12, -0.12, 0.0),
                base + DVec3::new(0.12, 0.12, 3.0),
            );
            stage.add_static(trunk, DMat4::IDENTITY);
            // The crown in the tree's own frame (base at the origin), placed per frame.
            let mut crown = Cards::default();
            for _ in 0..cards {
                let centre = loop {
                    let p = DVec3::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    );
                    if p.length_squared() <= 1.0 {
                        break p * 1.4 + DVec3::new(0.0, 0.0, 3.8);
                    }
                };
                let rotation =
                    DQuat::from_axis_angle(rng.direction(), rng.range(0.0, std::f64::consts::TAU));
                let xf = DAffine3::from_rotation_translation(rotation, centre);
                crown.rect(&xf, 2.0 * half, 2.0 * half, [1.0, 1.0]);
            }
            let crown = stage.add_mesh(crown.build(&format!("Crown.{t:02}")));
            trees.push(Tree {
                base,
                crown,
                phase: rng.range(0.0, std::f64::consts::TAU),
            });
        }
        LeafCards {
            stage,
            trees,
            alpha: scene_alpha(),
            clock: Clock {
                frames: params.frames,
            },
        }
    }
}

impl Animation for LeafCards {
    fn name(&self) -> &str {
        "leaf-cards"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let u = ease(self.clock.progress(frame));
        let eye = lerp3(
            DVec3::new(-12.0, -14.0, 3.0),
            DVec3::new(10.0, -14.0, 3.5),
            u,
        );
        let target = lerp3(DVec3::new(-3.0, 1.0, 2.0), DVec3::new(3.0, 1.0, 2.0), u);
        let cam = camera(eye, target, 24.0, (0.1, 100.0));
        let lights = vec![
            sun("Sun", sun_direction(0.8, 4.2), 0.0093),
            point("Lamp", DVec3::new(2.0, -4.0, 4.5), 0.1),
        ];
        let mut scene = self.stage.scene(frame, cam, lights);
        let seconds = self.clock.seconds(frame);
        for (t, tree) in self.trees.iter().enumerate() {
            // The crown sways about the trunk's top.
            let angle = 0.05 * (seconds * 2.0 + tree.phase).sin();
            let pivot = DVec3::new(0.0, 0.0, 3.0);
            let sway = DMat4::from_translation(tree.base + pivot)
                * DMat4::from_rotation_x(angle)
                * DMat4::from_translation(-pivot);
            add_object(&mut scene, format!("Crown.{t:02}"), tree.crown, sway);
            if let Some(o) = scene.objects.last_mut() {
                o.materials = vec![Some(LEAF)];
            }
        }
        scene.alpha = self.alpha.clone();
        scene
    }
}
