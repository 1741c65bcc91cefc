//! Lists the shadow rays on which antumbra and Embree disagree for one built-in scene, with
//! both tracers' hits and the watertight test's verdict on Embree's triangle, so that every
//! difference can be explained.
//!
//! `cargo run --release --features embree -p antumbra-cli --example embree_diff -- forest [TRIS] [WxH]`

use antumbra_cli::example_args::{ExampleFrame, FrameArgs, FrameDefaults};
use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::{intersect_triangle, WatertightRay};
use antumbra_core::render::{
    samples_for, shadow_rays, LightSampler, PrimaryPass, PrimaryRays, SamplePlan,
};
use antumbra_core::scene::ImageSize;
use antumbra_core::trace::{brute_occluded, NoStats, RayQuery};
use antumbra_embree::{EmbreeQuality, EmbreeScene};
use clap::Parser;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    frame: FrameArgs,
}

fn main() -> anyhow::Result<()> {
    let ExampleFrame {
        name,
        scene,
        geometry: g,
        ..
    } = Cli::parse().frame.open(FrameDefaults {
        scene: "forest",
        triangles: 350_000,
        size: ImageSize::new(512, 512),
    })?;
    let tris = &g.camera.vertices;
    let bvh = build_binned_sah(tris, &BuildSettings::default());
    let embree = EmbreeScene::new(tris, EmbreeQuality::Medium, None).map_err(anyhow::Error::msg)?;
    let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
    let pass = PrimaryPass::trace::<NoStats>(&camera, &bvh, &g.camera, &CancelToken::new())
        .expect("a new token is never cancelled");
    let (mut total, mut differ) = (0, 0);
    for (i, light) in scene.lights.iter().enumerate() {
        let sampler = LightSampler::new(light, &g.space);
        let plan = SamplePlan {
            light_index: i as u32,
            samples: samples_for(&sampler, 1),
            seed: 0,
        };
        for ray in shadow_rays(&pass, &sampler, plan) {
            total += 1;
            let ours = bvh.occluded(&ray, &mut NoStats);
            if ours == embree.occluded(&ray) {
                continue;
            }
            differ += 1;
            println!(
                "light {}: antumbra {ours}, embree {}, brute force {}; antumbra hit {:?}, embree hit {:?}; {ray:?}",
                light.name,
                !ours,
                brute_occluded(tris, &ray),
                bvh.closest_hit(&ray, &mut NoStats).map(|h| (h.t, h.triangle)),
                embree.intersect(&ray),
            );
            if let Some((t, id)) = embree.intersect(&ray) {
                let tri = &tris[id as usize];
                let ours = intersect_triangle(&WatertightRay::new(&ray), tri, ray.t_min, ray.t_max);
                println!("  watertight test on Embree's triangle {id} (t {t}): {ours:?}; vertices {tri:?}");
            }
        }
    }
    println!("{name}: {differ} of {total} shadow rays differ");
    Ok(())
}
