//! Lists the shadow rays on which antumbra and Embree disagree for one built-in scene, with
//! both tracers' hits and the watertight test's verdict on Embree's triangle, so that every
//! difference can be explained.
//!
//! `cargo run --release --features embree -p antumbra-cli --example embree_diff -- forest [TRIS]`

use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::geometry::{intersect_triangle, WatertightRay};
use antumbra_core::render::{
    samples_for, shadow_rays, LightSampler, PrimaryPass, PrimaryRays, SamplePlan,
};
use antumbra_core::scene::{FrameGeometry, Resolution};
use antumbra_core::trace::{brute_occluded, closest_hit, occluded, AnyHitOrder, NoStats};
use antumbra_embree::{EmbreeQuality, EmbreeScene};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "forest".into());
    let triangles = args.next().map_or(Ok(350_000), |s| s.parse())?;
    let params = antumbra_scenes::SceneParams {
        triangles,
        frames: 1,
        rotated: false,
    };
    let anim = antumbra_scenes::builtin(&name, &params)?;
    let mut scene = anim.frame(*anim.frame_range().start());
    scene.resolution = Resolution::new(512, 512);
    let g = FrameGeometry::from_scene(&scene)?;
    let tris = &g.camera.vertices;
    let bvh = build_binned_sah(tris, &BuildSettings::default());
    let embree = EmbreeScene::new(tris, EmbreeQuality::Medium, None).map_err(anyhow::Error::msg)?;
    let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
    let pass = PrimaryPass::timed(&camera, &bvh, &g.camera);
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
            let ours = occluded(&bvh, &ray, AnyHitOrder::NearFirst, &mut NoStats);
            if ours == embree.occluded(&ray) {
                continue;
            }
            differ += 1;
            println!(
                "light {}: antumbra {ours}, embree {}, brute force {}; antumbra hit {:?}, embree hit {:?}; {ray:?}",
                light.name,
                !ours,
                brute_occluded(tris, &ray),
                closest_hit(&bvh, &ray, &mut NoStats).map(|h| (h.t, h.triangle)),
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
