//! Calibrates the weights of `auto`'s cost model (`rust/core/src/render/auto/cost.rs`) on this
//! machine: trace time (median of 3 timed passes) against the exact counters of many passes
//! (non-negative least squares: per ray, per node entered by each traversal kernel, per box and
//! triangle test), and each preparation's time per unit of the count the model prices it by.
//! Run it on an otherwise idle machine.
//!
//! ```text
//! cargo run --release -p antumbra-cli --example auto_weights -- [TRIANGLES] [WxH] [SCENE ...]
//! ```
//! (defaults: 100000 640x360 and the five animated scenes).

use std::time::Instant;

use antumbra_core::build::{build_binned_sah, build_with_visibility, BuildMethod, BuildSettings};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::cancel::CancelToken;
use antumbra_core::compare::MethodSpec;
use antumbra_core::order::{ShadowOrder, SrdhSettings};
use antumbra_core::render::auto::{OrderChoice, Traversal};
use antumbra_core::render::{
    representative_rays, samples_for, srdh_rays, visibility_flags, LightSampler, PrimaryPass,
    PrimaryRays, Renderer, SamplePlan, StatsMode, WideTree,
};
use antumbra_core::scene::{FrameGeometry, ImageSize, Resolution};
use antumbra_core::settings::NamedSettings;
use antumbra_core::srdh::{build_srdh, RaySet};
use antumbra_core::trace::NoStats;
use antumbra_scenes::{builtin, SceneParams};

/// Unknowns of the trace fit: ns per box test, triangle test, shadow ray, camera ray, and per
/// node entered by each kernel (in the order of `Traversal::ALL`).
const K: usize = 4 + Traversal::ALL.len();
const NAMES: [&str; K] = [
    "box_test",
    "triangle_test",
    "shadow_ray",
    "camera_ray",
    "node binary_any_hit",
    "node wide_any_hit",
    "node wide_front_to_back",
    "node binary_closest",
    "node wide_closest",
];

const METHODS: &[&str] = &[
    "a=build=sah,width=2,order=fbto",
    "b=build=sah,width=4,order=fbto",
    "b8=build=sah,width=8,order=fbto",
    "c=build=sah,width=8,order=sato",
    "d=build=sah,width=8,order=sorted",
    "e=build=osah,width=8,order=fbto",
    "f=build=srdh,width=2",
];

/// Median milliseconds of `f` over 3 runs.
fn ms<T>(mut f: impl FnMut() -> T) -> f64 {
    let mut t: Vec<f64> = (0..3)
        .map(|_| {
            let s = Instant::now();
            std::hint::black_box(f());
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[1]
}

/// Least squares x of A x = b over the unknowns in `keep` (others 0), by the normal equations.
fn fit(rows: &[([f64; K], f64)], keep: &[usize]) -> Option<[f64; K]> {
    let k = keep.len();
    let mut m = vec![vec![0.0; k + 1]; k];
    for (a, b) in rows {
        for (i, &p) in keep.iter().enumerate() {
            m[i][k] += a[p] * b;
            for (j, &q) in keep.iter().enumerate() {
                m[i][j] += a[p] * a[q];
            }
        }
    }
    // Gauss-Jordan on the small augmented matrix.
    for c in 0..k {
        let pivot = (c..k).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))?;
        m.swap(c, pivot);
        if m[c][c].abs() < 1e-300 {
            return None;
        }
        let row = m[c].clone();
        for (_, target) in m.iter_mut().enumerate().filter(|(r, _)| *r != c) {
            let f = target[c] / row[c];
            for (t, v) in target.iter_mut().zip(&row).skip(c) {
                *t -= f * v;
            }
        }
    }
    let mut x = [0.0; K];
    for (i, &p) in keep.iter().enumerate() {
        x[p] = m[i][k] / m[i][i];
    }
    Some(x)
}

/// Non-negative least squares: the best fit of every subset of the unknowns whose weights are
/// all non-negative.
fn fit_nonnegative(rows: &[([f64; K], f64)]) -> [f64; K] {
    let residual = |x: &[f64; K]| -> f64 {
        rows.iter()
            .map(|(a, b)| (a.iter().zip(x).map(|(a, x)| a * x).sum::<f64>() - b).powi(2))
            .sum()
    };
    (1..1u32 << K)
        .map(|mask| (0..K).filter(|i| mask >> i & 1 == 1).collect::<Vec<_>>())
        .filter_map(|s| fit(rows, &s))
        .filter(|x| x.iter().all(|v| *v >= 0.0))
        .min_by(|a, b| residual(a).total_cmp(&residual(b)))
        .unwrap_or([0.0; K])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let triangles: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(100_000);
    let size: ImageSize = args
        .get(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(ImageSize::new(640, 360));
    let scenes: Vec<&str> = match args.get(2..) {
        Some(s) if !s.is_empty() => s.iter().map(String::as_str).collect(),
        _ => vec!["bedroom", "city", "forest", "colonnade", "hairball"],
    };
    let mut trace_rows = Vec::new();
    let mut tags: Vec<String> = Vec::new();
    let mut per_unit: Vec<(&str, f64)> = Vec::new();
    for name in &scenes {
        let params = SceneParams {
            triangles,
            frames: 4,
            rotated: false,
            instances: None,
        };
        let anim = builtin(name, &params).unwrap();
        let frames: Vec<_> = anim
            .frame_range()
            .take(3)
            .map(|f| {
                let mut s = anim.frame(f);
                s.resolution = Resolution::new(size.width, size.height);
                s
            })
            .collect();
        // Trace: every pass of the last two frames, counted and timed without counters.
        let common = NamedSettings::new().with("spp", 4).with("timing", "on");
        let mut visible = Vec::new();
        for spec in METHODS {
            let settings = spec
                .parse::<MethodSpec>()
                .unwrap()
                .resolve(&common)
                .unwrap();
            assert_eq!(settings.stats, StatsMode::CountsAndTiming);
            let wide = settings.width != BvhWidth::Two;
            let order = match settings.shadow_order.fixed() {
                Some(ShadowOrder::Fbto) => OrderChoice::Fbto,
                Some(ShadowOrder::Sato) => OrderChoice::Sato,
                Some(ShadowOrder::Sorted(_)) => OrderChoice::Sorted,
                Some(ShadowOrder::Srdh(_)) => OrderChoice::Srdh,
                o => panic!("no kernel for {o:?}"),
            };
            let mut r = Renderer::new();
            for (i, scene) in frames.iter().enumerate() {
                // Three timed passes from the same state; the median times each row.
                let runs: Vec<_> = (0..3)
                    .map(|_| r.clone().render(name, scene, &settings).unwrap())
                    .collect();
                let result = r.render(name, scene, &settings).unwrap();
                if i == 1 {
                    visible = result.visible.clone();
                }
                if i == 0 {
                    continue;
                }
                for (j, row) in result.stats.iter().enumerate() {
                    if row.rays <= 1000 {
                        continue;
                    }
                    let mut times: Vec<f64> = runs.iter().map(|x| x.stats[j].trace_ms).collect();
                    times.sort_by(f64::total_cmp);
                    let n = row.rays as f64;
                    let nodes = (row.nb_per_ray + row.nl_per_ray) * n;
                    let camera = row.pass == "primary";
                    let kernel = if camera {
                        Traversal::camera(wide)
                    } else {
                        order.kernel(wide)
                    };
                    let mut work = [0.0; K];
                    work[0] = row.nbox_per_ray * n;
                    work[1] = row.nt_per_ray * n;
                    work[if camera { 3 } else { 2 }] = n;
                    work[4 + kernel as usize] = nodes;
                    trace_rows.push((work, times[1] * 1e6));
                    tags.push(format!("{name} {}", kernel.name()));
                }
            }
        }
        // Builds and per-tree preparations on the last frame's geometry.
        let scene = &frames[2];
        let g = FrameGeometry::from_scene(scene).unwrap();
        let set = &g.camera;
        let t = set.len() as f64;
        let bs = BuildSettings::default();
        let flags = visibility_flags(set, &visible);
        per_unit.push((
            "sah_triangle",
            ms(|| build_binned_sah(&set.vertices, &bs)) / t,
        ));
        let osah = || build_with_visibility(BuildMethod::Osah, &set.vertices, Some(&flags), &bs);
        per_unit.push(("osah_triangle", ms(osah) / t));
        let bvh = build_binned_sah(&set.vertices, &bs);
        let collapse = || WideTree::collapse(&bvh, BvhWidth::Eight, &Default::default());
        per_unit.push(("collapse_triangle", ms(collapse) / t));
        let wide = collapse();
        let nodes = wide.node_count() as f64;
        per_unit.push(("per_tree_node (tables)", ms(|| wide.sort_tables()) / nodes));
        let sato = || wide.prepare(&ShadowOrder::Sato, None, &[]);
        per_unit.push(("per_tree_node (sato)", ms(sato) / nodes));
        // Per light: sorting and SRDH.
        let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &g.space);
        let primary = PrimaryPass::trace::<NoStats>(&rays, &bvh, set, &CancelToken::new())
            .expect("a new token is never cancelled");
        let tables = wide.sort_tables();
        for (i, light) in scene.lights.iter().enumerate() {
            let sampler = LightSampler::new(light, &g.space);
            let plan = SamplePlan {
                light_index: i as u32,
                samples: samples_for(&sampler, 4),
                seed: 0,
            };
            let sorted = ShadowOrder::Sorted(Default::default());
            // Choosing the representative rays is part of the logging, as the renderer
            // reports it.
            let s = Instant::now();
            let rep = representative_rays(&primary, &sampler, plan, 0.05);
            let choosing_ms = s.elapsed().as_secs_f64() * 1e3;
            if rep.len() > 100 {
                let order = wide.prepare(&sorted, Some(&tables), &rep);
                let antumbra_core::order::PreparedOrder::Sorted(o) = order else {
                    unreachable!()
                };
                let logging_ms = choosing_ms + o.logging_ms;
                per_unit.push(("log_ray", logging_ms / rep.len() as f64));
                per_unit.push(("sort_node", o.sorting_ms / nodes));
            }
            let s = SrdhSettings::default();
            let srdh = srdh_rays(&primary, &sampler, plan, s.rays);
            if srdh.len() > 100 {
                let n = srdh.len() as f64;
                let rs = RaySet::trace(&bvh, srdh);
                per_unit.push(("srdh_ray", rs.trace_ms / n));
                let built = ms(|| build_srdh(&set.vertices, &rs, &s, &bs));
                per_unit.push(("srdh_triangle", built / t));
            }
        }
    }
    let w = fit_nonnegative(&trace_rows);
    println!(
        "trace fit over {} passes (ns, non-negative least squares):",
        trace_rows.len()
    );
    for (name, v) in NAMES.iter().zip(w) {
        println!("  {name:24} {v:10.3}");
    }
    let residual: f64 = trace_rows
        .iter()
        .map(|(a, b)| {
            let e = a.iter().zip(&w).map(|(a, x)| a * x).sum::<f64>();
            ((e - b) / b).abs()
        })
        .sum::<f64>()
        / trace_rows.len() as f64;
    println!("  mean relative error of a pass's estimate: {residual:.3}");
    // Measured over estimated time per scene and kernel: what the model misses where.
    let mut by_tag: std::collections::BTreeMap<&str, (f64, f64)> = Default::default();
    for ((a, b), tag) in trace_rows.iter().zip(&tags) {
        let e: f64 = a.iter().zip(&w).map(|(a, x)| a * x).sum();
        let t = by_tag.entry(tag).or_default();
        t.0 += b;
        t.1 += e;
    }
    println!("measured / estimated, per scene and kernel:");
    for (tag, (b, e)) in by_tag {
        println!("  {tag:36} {:.3}", b / e);
    }
    let mut names: Vec<&str> = per_unit.iter().map(|p| p.0).collect();
    names.dedup();
    names.sort_unstable();
    names.dedup();
    println!("preparation, ns per unit (median over scenes and lights):");
    for n in names {
        let mut v: Vec<f64> = per_unit
            .iter()
            .filter(|p| p.0 == n)
            .map(|p| p.1 * 1e6)
            .collect();
        v.sort_by(f64::total_cmp);
        println!("  {n:24} {:10.1}  (n = {})", v[v.len() / 2], v.len());
    }
}
