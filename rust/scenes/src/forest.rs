//! `forest`: branching trees (recursive tapered cylinders with leaf quads) on rolling terrain
//! under a soft sun. Dense, irregular occlusion from many small leaves. Every tree sways in the
//! wind and its leaves flutter: the tree meshes deform, so each frame has new tree meshes (new
//! `Arc`s, same triangle lists) while the terrain and rocks are shared.

use std::f64::consts::TAU;
use std::ops::RangeInclusive;

use antumbra_core::scene::{Animation, Light, Mesh, Scene};
use glam::{DAffine3, DMat4, DQuat, DVec3, Vec3};

use crate::builder::MeshBuilder;
use crate::params::SceneParams;
use crate::primitives::{cylinder, cylinder_triangles, grid, quad, sphere, sphere_triangles};
use crate::rng::Pcg32;
use crate::stage::{add_deforming, camera, ease, sun, sun_direction, Clock, Stage};

const SEED: u64 = 0x464f_5245_5354;
const SPACING: f64 = 7.0;
const CHILDREN: u32 = 3;
const TRUNK_RINGS: u32 = 3;
const ROCK_SEGMENTS: (u32, u32) = (10, 6);
/// Radians per second of the main sway.
const SWAY_RATE: f64 = TAU * 0.5;

/// How detailed each tree is; chosen from the budget so that small scenes still hold a dozen
/// trees and large ones get finer trees rather than only more of them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TreeDetail {
    depth: u32,
    sides: u32,
    leaves_per_tip: u32,
    leaf_half_size: f64,
}

impl TreeDetail {
    fn for_budget(triangles: usize) -> Self {
        let (depth, sides, leaves_per_tip, leaf_half_size) = match triangles {
            0..=59_999 => (3, 5, 6, 0.3),
            60_000..=599_999 => (4, 6, 10, 0.2),
            _ => (5, 7, 10, 0.14),
        };
        TreeDetail {
            depth,
            sides,
            leaves_per_tip,
            leaf_half_size,
        }
    }

    /// The detail whose tree comes closest to `triangles` (never below the smallest tree, 60):
    /// as many branch levels as fit with two leaves per tip, then more leaves fill the rest.
    pub(crate) fn for_tree(triangles: usize) -> Self {
        let sides = match triangles {
            0..=1_999 => 4,
            2_000..=19_999 => 5,
            _ => 6,
        };
        let mut detail = TreeDetail {
            depth: 1,
            sides,
            leaves_per_tip: 2,
            leaf_half_size: 0.0,
        };
        while detail.depth < 12 {
            let deeper = TreeDetail {
                depth: detail.depth + 1,
                ..detail
            };
            if deeper.triangles() > triangles {
                break;
            }
            detail = deeper;
        }
        let tips = CHILDREN.pow(detail.depth) as usize;
        let wood = detail.triangles() - tips * detail.leaves_per_tip as usize * 2;
        let per_tip = (triangles.saturating_sub(wood) as f64 / (2 * tips) as f64).round();
        detail.leaves_per_tip = per_tip.clamp(2.0, 64.0) as u32;
        // About 100 square metres of leaves whatever their number.
        let leaves = (tips * detail.leaves_per_tip as usize) as f64;
        detail.leaf_half_size = (6.0 / leaves.sqrt()).clamp(0.03, 0.6);
        detail
    }

    pub(crate) fn triangles(&self) -> usize {
        let trunk = cylinder_triangles(self.sides, TRUNK_RINGS, false);
        let branches: usize = (1..=self.depth)
            .map(|d| CHILDREN.pow(d) as usize * cylinder_triangles(self.sides, 1, false))
            .sum();
        let tips = CHILDREN.pow(self.depth) as usize;
        trunk + branches + tips * self.leaves_per_tip as usize * 2
    }
}

/// One tree's rest pose and what each vertex does in the wind.
struct Tree {
    name: String,
    base: DVec3,
    rest: Vec<Vec3>,
    /// Sway weight: 0 at the root, 1 at the top (quadratic in height, as a cantilever bends).
    sway: Vec<f32>,
    /// Leaf flutter (amplitude in metres, phase); amplitude 0 for wood.
    flutter: Vec<(f32, f32)>,
    triangles: Vec<[u32; 3]>,
    amplitude: f64,
    phase: f64,
}

impl Tree {
    fn grow(index: u64, base: DVec3, detail: &TreeDetail) -> Self {
        let mut rng = Pcg32::new(SEED, 1000 + index);
        let (mb, leaves) = grow_tree(&mut rng, detail);
        let height = mb
            .positions
            .iter()
            .fold(1e-3f32, |h, p| h.max(p.z))
            .max(1e-3);
        let sway = mb
            .positions
            .iter()
            .map(|p| (p.z / height).clamp(0.0, 1.0).powi(2))
            .collect();
        let mut flutter = vec![(0.0f32, 0.0f32); mb.positions.len()];
        for first in leaves {
            let phase = rng.range(0.0, TAU) as f32;
            for f in &mut flutter[first as usize..first as usize + 4] {
                *f = (0.03, phase);
            }
        }
        Tree {
            name: format!("tree.{index:04}"),
            base,
            amplitude: 0.04 * height as f64,
            phase: rng.range(0.0, TAU),
            rest: mb.positions,
            sway,
            flutter,
            triangles: mb.triangles,
        }
    }

    /// The deformed mesh at `seconds`: a smooth displacement field (so coincident vertices of
    /// touching branches move together) plus per-leaf flutter.
    fn mesh_at(&self, seconds: f64, wind: DVec3) -> Mesh {
        let w = SWAY_RATE * seconds + self.phase;
        let along = self.amplitude * (w.sin() + 0.3 * (2.3 * w + 1.1).sin());
        let across = 0.25 * self.amplitude * (1.3 * w + 0.6).sin();
        let side = DVec3::Z.cross(wind);
        let offset = (wind * along + side * across).as_vec3();
        let flutter_dir = (wind * 0.4 + DVec3::Z).normalize().as_vec3();
        let flutter_angle = (4.0 * SWAY_RATE * seconds) as f32;
        let positions = self
            .rest
            .iter()
            .zip(&self.sway)
            .zip(&self.flutter)
            .map(|((&p, &s), &(amp, phase))| {
                let mut q = p + offset * s;
                if amp > 0.0 {
                    q += flutter_dir * (amp * (flutter_angle + phase).sin());
                }
                q
            })
            .collect();
        Mesh::new(self.name.clone(), positions, self.triangles.clone())
    }
}

/// A tree's wood and leaves in its rest pose, base at the origin; also the first vertex of each
/// leaf quad.
fn grow_tree(rng: &mut Pcg32, detail: &TreeDetail) -> (MeshBuilder, Vec<u32>) {
    let mut mb = MeshBuilder::new();
    let mut leaves = Vec::new();
    let trunk_length = rng.range(3.5, 5.0);
    let trunk_radius = rng.range(0.18, 0.28);
    let lean = DVec3::new(rng.range(-0.08, 0.08), rng.range(-0.08, 0.08), 1.0).normalize();
    let branch = Branch {
        start: DVec3::ZERO,
        dir: lean,
        length: trunk_length,
        radius: trunk_radius,
        level: 0,
    };
    grow_branch(&mut mb, &mut leaves, rng, branch, detail);
    (mb, leaves)
}

/// A still tree (the forest's branching tree in its rest pose) as one mesh, for scenes that
/// instance it; `seed` and `stream` pick its shape.
pub(crate) fn still_tree(seed: u64, stream: u64, detail: &TreeDetail, name: &str) -> Mesh {
    let (mb, _) = grow_tree(&mut Pcg32::new(seed, stream), detail);
    mb.build(name)
}

#[derive(Clone, Copy)]
struct Branch {
    start: DVec3,
    dir: DVec3,
    length: f64,
    radius: f64,
    level: u32,
}

fn grow_branch(
    mb: &mut MeshBuilder,
    leaves: &mut Vec<u32>,
    rng: &mut Pcg32,
    b: Branch,
    detail: &TreeDetail,
) {
    let tip_radius = b.radius * 0.62;
    let xf =
        DAffine3::from_rotation_translation(DQuat::from_rotation_arc(DVec3::Z, b.dir), b.start);
    let rings = if b.level == 0 { TRUNK_RINGS } else { 1 };
    cylinder(
        mb,
        &xf,
        b.radius,
        tip_radius,
        b.length,
        detail.sides,
        rings,
        false,
    );
    let end = b.start + b.dir * b.length;
    if b.level == detail.depth {
        for _ in 0..detail.leaves_per_tip {
            let centre = end + b.dir * rng.range(-0.2, 0.2) * b.length + rng.direction() * 0.3;
            let facing = DQuat::from_rotation_arc(DVec3::Z, rng.direction());
            leaves.push(mb.next_index());
            let h = detail.leaf_half_size;
            quad(
                mb,
                &DAffine3::from_rotation_translation(facing, centre),
                h,
                0.7 * h,
            );
        }
        return;
    }
    let azimuth = rng.range(0.0, TAU);
    let perpendicular = b.dir.any_orthonormal_vector();
    for c in 0..CHILDREN {
        let around = azimuth + TAU * c as f64 / CHILDREN as f64 + rng.range(-0.3, 0.3);
        let axis = DQuat::from_axis_angle(b.dir, around) * perpendicular;
        let tilt = rng.range(0.45, 0.8);
        // A little upward growth keeps the crown from drooping.
        let dir = (DQuat::from_axis_angle(axis, tilt) * b.dir + DVec3::Z * 0.25).normalize();
        let child = Branch {
            start: end,
            dir,
            length: b.length * rng.range(0.62, 0.75),
            radius: tip_radius * 0.9,
            level: b.level + 1,
        };
        grow_branch(mb, leaves, rng, child, detail);
    }
}

/// Rolling hills a couple of metres high: a few fixed sines, smooth and cheap.
fn terrain_height(x: f64, y: f64) -> f64 {
    1.5 * (0.045 * x + 0.7).sin() * (0.06 * y - 0.3).cos()
        + 0.6 * (0.11 * x + 0.13 * y + 1.9).sin()
        + 0.25 * (0.31 * x - 0.27 * y + 0.4).sin()
}

pub(crate) struct Forest {
    clock: Clock,
    stage: Stage,
    trees: Vec<Tree>,
    extent: f64,
}

impl Forest {
    pub fn new(params: SceneParams) -> Self {
        let target = params.triangles;
        let detail = TreeDetail::for_budget(target);
        let cells = ((0.02 * target as f64).sqrt().round() as u32).clamp(8, 1024);
        let terrain_tris = 2 * (cells as usize).pow(2);
        let rock_tris = sphere_triangles(ROCK_SEGMENTS.0, ROCK_SEGMENTS.1);
        let rocks = ((0.03 * target as f64) / rock_tris as f64)
            .round()
            .clamp(4.0, 400.0) as u64;
        let rest = target.saturating_sub(terrain_tris + rocks as usize * rock_tris);
        let tree_count = (rest as f64 / detail.triangles() as f64).round().max(3.0) as u64;

        let per_side = (tree_count as f64).sqrt().ceil() as u64;
        let extent = per_side as f64 * SPACING;
        let mut placer = Pcg32::new(SEED, 0);
        let trees = (0..tree_count)
            .map(|i| {
                let (cx, cy) = ((i % per_side) as f64, (i / per_side) as f64);
                let x = -0.5 * extent + (cx + 0.5 + placer.range(-0.45, 0.45)) * SPACING;
                let y = -0.5 * extent + (cy + 0.5 + placer.range(-0.45, 0.45)) * SPACING;
                // Sunk a little so the trunk meets the ground on a slope.
                let base = DVec3::new(x, y, terrain_height(x, y) - 0.15);
                Tree::grow(i, base, &detail)
            })
            .collect();

        let mut stage = Stage::new();
        let half = 0.5 * extent + 25.0;
        let mut ground = MeshBuilder::new();
        grid(&mut ground, cells, cells, false, false, |i, j| {
            let x = -half + 2.0 * half * i as f64 / cells as f64;
            let y = -half + 2.0 * half * j as f64 / cells as f64;
            DVec3::new(x, y, terrain_height(x, y))
        });
        stage.add_static(ground.build("terrain"), DMat4::IDENTITY);
        let mut rock_mb = MeshBuilder::new();
        let mut rng = Pcg32::new(SEED, 1);
        for _ in 0..rocks {
            let x = rng.range(-0.5, 0.5) * extent;
            let y = rng.range(-0.5, 0.5) * extent;
            let r = rng.range(0.3, 1.1);
            let radii = DVec3::new(r, r * rng.range(0.6, 1.0), r * rng.range(0.4, 0.7));
            let xf = DAffine3::from_rotation_translation(
                DQuat::from_rotation_z(rng.range(0.0, TAU)),
                DVec3::new(x, y, terrain_height(x, y)),
            );
            sphere(&mut rock_mb, &xf, radii, ROCK_SEGMENTS.0, ROCK_SEGMENTS.1);
        }
        stage.add_static(rock_mb.build("rocks"), DMat4::IDENTITY);
        Forest {
            clock: Clock {
                frames: params.frames,
            },
            stage,
            trees,
            extent,
        }
    }

    fn lights() -> Vec<Light> {
        // A soft sun (about 3 degrees across): leaves give wide penumbrae.
        vec![sun("Sun", sun_direction(0.7, 3.6), 0.05)]
    }
}

impl Animation for Forest {
    fn name(&self) -> &str {
        "forest"
    }

    fn frame_range(&self) -> RangeInclusive<i32> {
        self.clock.range()
    }

    fn frame(&self, frame: i32) -> Scene {
        let u = ease(self.clock.progress(frame));
        let radius = 0.5 * self.extent + 6.0;
        let angle = -1.75 + 0.7 * u;
        let (x, y) = (radius * angle.cos(), radius * angle.sin());
        let eye = DVec3::new(x, y, terrain_height(x, y) + 10.0 - 3.0 * u);
        let target = DVec3::new(0.0, 0.0, 5.0);
        let cam = camera(eye, target, 28.0, (0.1, 4.0 * self.extent + 100.0));
        let mut scene = self.stage.scene(frame, cam, Forest::lights());
        let seconds = self.clock.seconds(frame);
        let wind = DVec3::new(1.0, 0.3, 0.0).normalize();
        for tree in &self.trees {
            add_deforming(
                &mut scene,
                tree.mesh_at(seconds, wind),
                DMat4::from_translation(tree.base),
            );
        }
        scene
    }
}
