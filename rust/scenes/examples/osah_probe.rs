//! Build-time probe (not part of the bench): builds one viewpoint's tree with a method, for
//! profilers. `osah_probe SCENE TRIANGLES CAMERA METHOD REPEAT [SPATIAL_AXES [SPLIT_ALPHA [CLIP_MIN_REFS [NODE_OVERLAP [MIN_REFS [MIN_LEAF_SIZE]]]]]]`
use antumbra_core::build::{build_binned_sah, build_with_visibility, BuildMethod, BuildSettings};
use antumbra_core::cancel::CancelToken;
use antumbra_core::render::{visibility_flags, PrimaryPass, PrimaryRays};
use antumbra_core::scene::{FrameGeometry, Resolution};
use antumbra_core::trace::NoStats;
use std::time::Instant;

// The allocator of the `antumbra` binary, so that builds here cost what they cost there.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let params = antumbra_scenes::SceneParams {
        triangles: a[2].parse().unwrap(),
        frames: 24,
        ..Default::default()
    };
    let anim = antumbra_scenes::builtin(&a[1], &params).unwrap();
    let (_, camera) = antumbra_scenes::viewpoints(&a[1], &params)
        .unwrap()
        .into_iter()
        .find(|(n, _)| *n == a[3])
        .unwrap();
    let mut scene = anim.frame(*anim.frame_range().start());
    scene.camera = camera;
    scene.resolution = Resolution::new(256, 256);
    let geometry = FrameGeometry::from_scene(&scene).unwrap();
    let set = &geometry.camera;
    let mut settings = BuildSettings::default();
    if let Some(axes) = a.get(6) {
        settings.spatial.axes = axes.parse().unwrap();
    }
    if let Some(alpha) = a.get(7) {
        settings.spatial.alpha = alpha.parse().unwrap();
    }
    if let Some(refs) = a.get(8) {
        settings.spatial.clip_min_refs = refs.parse().unwrap();
    }
    if let Some(o) = a.get(9) {
        settings.spatial.node_overlap = o.parse().unwrap();
    }
    if let Some(m) = a.get(10) {
        settings.spatial.min_refs = m.parse().unwrap();
    }
    if let Some(m) = a.get(11) {
        settings.min_leaf_size = m.parse().unwrap();
    }
    let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
    let sah = build_binned_sah(&set.vertices, &settings);
    let pass = PrimaryPass::trace::<NoStats>(&rays, &sah, set, &CancelToken::new())
        .expect("a new token is never cancelled");
    let mut visible: Vec<_> = pass
        .surfaces
        .iter()
        .flatten()
        .map(|s| set.refs[s.triangle as usize])
        .collect();
    visible.sort_unstable();
    visible.dedup();
    let flags = visibility_flags(set, &visible);
    let method: BuildMethod = a[4].parse().unwrap();
    for _ in 0..a[5].parse::<usize>().unwrap() {
        let t = Instant::now();
        let b = build_with_visibility(method, &set.vertices, Some(&flags), &settings);
        println!(
            "{} tris {} visible {} refs {} ms {:.1}",
            a[4],
            set.len(),
            visible.len(),
            b.triangles.len(),
            t.elapsed().as_secs_f64() * 1e3
        );
    }
}
