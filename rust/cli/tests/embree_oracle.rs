//! Embree as the independent oracle: antumbra's occlusion answers equal `rtcOccluded1` on the
//! exact shadow rays of a frame of every built-in scene, and closest-hit triangle ids equal
//! `rtcIntersect1` on its camera rays. Differences are counted and must be explained: Embree
//! is not watertight in the same way, so rays through edges or vertices may differ; we require
//! agreement on all but a tiny, reported fraction.
#![cfg(feature = "embree")]

use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::bvh::WideBvh;
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray;
use antumbra_core::order::PreparedOrder;
use antumbra_core::order::ShadowOrder;
use antumbra_core::render::{
    samples_for, shadow_rays, LightSampler, PrimaryPass, PrimaryRays, SamplePlan,
};
use antumbra_core::scene::{FrameGeometry, Resolution};
use antumbra_core::trace::wide::{BoxKernel, WideQueries};
use antumbra_core::trace::{NoStats, RayQuery};
use antumbra_embree::{EmbreeQuality, EmbreeScene};
use antumbra_scenes::{builtin, SceneParams, BUILTIN_SCENES};

#[test]
fn occlusion_agrees_with_embree_on_every_builtin_scene() {
    let mut report = Vec::new();
    for name in BUILTIN_SCENES {
        let params = SceneParams {
            triangles: 30_000,
            frames: 1,
            rotated: false,
            instances: None,
        };
        let anim = builtin(name, &params).unwrap();
        let mut scene = anim.frame(*anim.frame_range().start());
        scene.resolution = Resolution::new(160, 90);
        let g = FrameGeometry::from_scene(&scene).unwrap();
        let tris = &g.camera.vertices;
        let bvh = build_binned_sah(tris, &BuildSettings::default());
        let embree = EmbreeScene::new(tris, EmbreeQuality::High, None).unwrap();

        let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
        let pass = PrimaryPass::trace::<NoStats>(&camera, &bvh, &g.camera, &CancelToken::new())
            .expect("a new token is never cancelled");
        let mut shadow: Vec<Ray> = Vec::new();
        for (i, l) in scene.lights.iter().enumerate() {
            let s = LightSampler::new(l, &g.space);
            let plan = SamplePlan {
                light_index: i as u32,
                samples: samples_for(&s, 4),
                seed: 3,
            };
            shadow.extend(shadow_rays(&pass, &s, plan));
        }
        let occ_diff = shadow
            .iter()
            .filter(|r| bvh.occluded(r, &mut NoStats) != embree.occluded(r))
            .count();
        let mut id_diff = 0;
        let mut primary = 0;
        for y in 0..90 {
            for x in 0..160 {
                let ray = camera.ray(x, y);
                primary += 1;
                let ours = bvh.closest_hit(&ray, &mut NoStats).map(|h| h.triangle);
                let theirs = embree.intersect(&ray).map(|(_, id)| id);
                if ours != theirs {
                    id_diff += 1;
                }
            }
        }
        let occ_ratio = occ_diff as f64 / shadow.len().max(1) as f64;
        let id_ratio = id_diff as f64 / primary as f64;
        report.push(format!(
            "{name}: shadow rays {} differ {} ({:.4}%); camera rays {} ids differ {} ({:.4}%)",
            shadow.len(),
            occ_diff,
            occ_ratio * 100.0,
            primary,
            id_diff,
            id_ratio * 100.0
        ));
        assert!(
            shadow.len() > 5000,
            "{name}: only {} shadow rays",
            shadow.len()
        );
        // Rays through shared edges/vertices and hits at the segment's end may differ between
        // two correct tracers; anything beyond a handful per thousand is a bug.
        assert!(occ_ratio < 1e-3, "{}", report.last().unwrap());
        assert!(id_ratio < 2e-3, "{}", report.last().unwrap());

        // The wide trees with their SIMD kernels and per-light sorted order give the binary
        // traversal's answers, so they differ from Embree on exactly the same rays.
        let wide = WideBvh::<8>::collapse(&bvh);
        let sorted: ShadowOrder = "sorted:budget=0.1".parse().unwrap();
        let prepared = PreparedOrder::new(&wide, &sorted, None, &shadow, BoxKernel::Auto);
        let wide_diff = shadow
            .iter()
            .filter(|r| {
                WideQueries::occluded(&wide, r, prepared.view(), BoxKernel::Auto, &mut NoStats)
                    != embree.occluded(r)
            })
            .count();
        assert_eq!(wide_diff, occ_diff, "{name}: 8-wide sorted vs Embree");
        let wide4 = WideBvh::<4>::collapse(&bvh);
        let mut wide_ids_diff = 0;
        for y in 0..90 {
            for x in 0..160 {
                let ray = camera.ray(x, y);
                let ours = WideQueries::closest_hit(&wide4, &ray, BoxKernel::Auto, &mut NoStats);
                let theirs = embree.intersect(&ray).map(|(_, id)| id);
                wide_ids_diff += (ours.map(|h| h.triangle) != theirs) as usize;
            }
        }
        assert_eq!(
            wide_ids_diff, id_diff,
            "{name}: 4-wide closest hit vs Embree"
        );
    }
    eprintln!("{}", report.join("\n"));
}

/// Runs `antumbra bench` on 4000 bedroom triangles with `args` and `--json`; its rows.
fn bench_rows(args: &[&str]) -> Vec<serde_json::Value> {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_antumbra"))
        .args([
            "bench",
            "--scene",
            "bedroom",
            "--triangles",
            "4000",
            "--json",
        ])
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    rows.as_array().unwrap().clone()
}

/// Fails unless every row has a finite, positive number under each key.
fn assert_positive(rows: &[serde_json::Value], keys: &[&str]) {
    for row in rows {
        for key in keys {
            let v = row[key].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v > 0.0, "{key} = {} in {row}", row[key]);
        }
    }
}

/// `antumbra bench --compare embree` as a user runs it: every row carries Embree's build time
/// and both of its ray rates, timed in turn with antumbra's, each of its packet and stream calls
/// beside them, and Embree agrees with antumbra's shadow answers on (nearly) every ray.
#[test]
fn bench_compares_with_embree_on_the_same_rays() {
    let rows = bench_rows(
        &["--size", "48x32", "--width", "8", "--order", "sorted"]
            .into_iter()
            .chain(["--compare", "embree", "--repeat", "2"])
            .collect::<Vec<_>>(),
    );
    assert_eq!(rows.len(), 2, "one row per thread count: {rows:?}");
    assert_positive(
        &rows,
        &[
            "primary_mrays",
            "shadow_mrays",
            "embree_build_ms",
            "embree_primary_mrays",
            "embree_shadow_mrays",
        ],
    );
    for row in &rows {
        let agreement = row["embree_agreement"].as_f64().unwrap();
        assert!(agreement > 0.999, "agreement {agreement} in {row}");
        let kernels = row["embree_kernels"].as_array().unwrap();
        assert_eq!(kernels.len(), 14, "7 calls per query: {kernels:?}");
        // Every incoherent call answers as the single-ray call of its query does (the embree
        // crate's tests check it ray for ray), so each disagrees with antumbra as often.
        for query in ["any_hit", "closest_hit"] {
            let of_query: Vec<_> = kernels.iter().filter(|k| k["query"] == query).collect();
            let single = of_query[0]["disagreements"].as_u64().unwrap();
            assert!(
                single * 1000 < row["shadow_rays"].as_u64().unwrap(),
                "{row}"
            );
            for k in &of_query {
                assert!(k["mrays"].as_f64().unwrap() > 0.0, "{k}");
                if k["context"] == "incoherent" {
                    assert_eq!(k["disagreements"].as_u64(), Some(single), "{k}");
                }
            }
        }
        let any_hit_single = &kernels[0];
        assert_eq!(any_hit_single["kernel"], "rtcOccluded1");
        assert_eq!(any_hit_single["mrays"], row["embree_shadow_mrays"]);
    }
}

/// `bench --methods ... --compare embree`: each method's row carries Embree's build time,
/// timed in turn with it; without `--compare` there is none.
#[test]
fn method_bench_times_embree_beside_each_method() {
    let rows = bench_rows(&[
        "--size",
        "32x32",
        "--methods",
        "sah,osah",
        "--repeat",
        "1",
        "--compare",
        "embree",
        "--embree-quality",
        "high",
    ]);
    assert_eq!(rows.len(), 8, "two methods on four viewpoints: {rows:?}");
    assert_positive(&rows, &["build_ms", "reference_build_ms"]);
    let rows = bench_rows(&["--size", "32x32", "--methods", "sah", "--repeat", "1"]);
    assert!(rows[0]["reference_build_ms"].is_null(), "{}", rows[0]);
}
