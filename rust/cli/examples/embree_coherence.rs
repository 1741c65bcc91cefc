//! Whether Embree's coherent packet and stream occlusion calls answer as `rtcOccluded1` for
//! shadow rays starting a small distance from a surface: a built-in scene's shadow rays, their
//! origins moved to `offset` above the surface along its geometric normal (0: antumbra's own
//! offset), grouped 64 at a time in pixel order, every call and flag against `rtcOccluded1`.
//!
//! `cargo run --release --features embree -p antumbra-cli --example embree_coherence -- bedroom [TRIS] [WxH]`

use antumbra_cli::example_args::{ExampleFrame, FrameArgs, FrameDefaults};
use antumbra_cli::shadow_lights::shadow_lights;
use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray;
use antumbra_core::render::{PrimaryPass, PrimaryRays};
use antumbra_core::scene::ImageSize;
use antumbra_core::trace::NoStats;
use antumbra_embree::{Coherence, EmbreeKernel, EmbreeQuality, EmbreeScene};
use clap::Parser;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    frame: FrameArgs,
}

/// Distances of the origins from the surface, in render space (the scene spans about [-1, 1]).
const OFFSETS: [f32; 4] = [0.0, 1e-5, 1e-4, 1e-3];

fn main() -> anyhow::Result<()> {
    let ExampleFrame {
        name,
        scene,
        geometry: g,
        ..
    } = Cli::parse().frame.open(FrameDefaults {
        scene: "bedroom",
        triangles: 350_000,
        size: ImageSize::new(512, 512),
    })?;
    let tris = &g.camera.vertices;
    let bvh = build_binned_sah(tris, &BuildSettings::default());
    let embree = EmbreeScene::new(tris, EmbreeQuality::Medium, None).map_err(anyhow::Error::msg)?;
    let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
    let pass = PrimaryPass::trace::<NoStats>(&camera, &bvh, &g.camera, &CancelToken::new())
        .expect("a new token is never cancelled");
    let lights = shadow_lights(&scene, &g.space, 1, 0);
    println!("{name}: shadow rays whose answer differs from rtcOccluded1's");
    println!(
        "{:>8} {:>8} {:>9}  calls (incoherent | coherent)",
        "offset", "rays", "occluded"
    );
    for offset in OFFSETS {
        let mut rays = Vec::new();
        let mut scratch = Vec::new();
        for light in &lights {
            for (p, s) in pass.surfaces.iter().enumerate() {
                let Some(s) = s else { continue };
                let [a, b, c] = tris[s.triangle as usize];
                let n = (b - a).cross(c - a).normalize();
                light
                    .plan
                    .for_each_ray(s, p, &light.sampler, &mut scratch, |r| {
                        rays.extend(r.map(|r| moved(r, s.position, n, offset)))
                    });
            }
        }
        let single: Vec<bool> = rays.iter().map(|r| embree.occluded(r)).collect();
        let occluded = single.iter().filter(|o| **o).count();
        let mut cells = Vec::new();
        for coherence in [Coherence::Incoherent, Coherence::Coherent] {
            for kernel in &EmbreeKernel::ALL[1..] {
                let mut out = vec![false; rays.len()];
                for (r, o) in rays.chunks(64).zip(out.chunks_mut(64)) {
                    embree.occluded_with(*kernel, coherence, r, o);
                }
                let differ = out.iter().zip(&single).filter(|(a, b)| a != b).count();
                cells.push(format!("{} {differ}", kernel.occluded_name()));
            }
        }
        println!(
            "{offset:>8.0e} {:>8} {:>8.1}%  {} | {}",
            rays.len(),
            100.0 * occluded as f64 / rays.len().max(1) as f64,
            cells[..3].join(", "),
            cells[3..].join(", ")
        );
    }
    Ok(())
}

/// `r` from `offset` above `p` on the side it leaves to (antumbra's own origin for 0), with the
/// same end point.
fn moved(r: Ray, p: glam::Vec3, n: glam::Vec3, offset: f32) -> Ray {
    if offset == 0.0 {
        return r;
    }
    let side = if n.dot(r.direction) > 0.0 { n } else { -n };
    let origin = p + offset * side;
    if r.t_max.is_finite() {
        Ray::new(origin, r.origin + r.direction * r.t_max - origin, 0.0, 1.0)
    } else {
        Ray::new(origin, r.direction, 0.0, f32::INFINITY)
    }
}
