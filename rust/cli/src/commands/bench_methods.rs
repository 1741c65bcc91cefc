//! `antumbra bench --methods ...`: the OSAH paper's comparison (its Tables 3-4) on our scenes:
//! per scene and viewpoint, build ms, references and traversal work (N_IT = triangle tests,
//! N_TS = nodes entered) and Mrays/s for primary and shadow rays, each build method beside SAH.
//! Visibility-driven builds get the exact visible set of the same primary rays, as in the paper.
//! `--animation N` instead renders N frames per method and writes the per-frame curve.

use std::path::Path;
use std::time::Instant;

use antumbra_core::bvh::{
    build_binned_sah, build_with_visibility, BuildMethod, BuildSettings, Bvh,
};
use antumbra_core::geometry::Ray;
use antumbra_core::output::write_bytes_atomic;
use antumbra_core::render::{
    samples_for, shadow_rays, visibility_flags, LightSampler, PrimaryPass, PrimaryRays,
    RenderSettings, Renderer, SamplePlan, StatsMode, VisibilitySource,
};
use antumbra_core::scene::{FrameGeometry, Resolution, TriangleRef};
use antumbra_core::trace::{occluded, AnyHitOrder, NoStats, TraversalStats};
use anyhow::{bail, Result};
use rayon::prelude::*;
use serde::Serialize;

use crate::line_plot::LinePlot;

/// One method on one viewpoint.
#[derive(Debug, Default, Serialize)]
pub struct MethodRow {
    pub scene: String,
    pub camera: String,
    pub method: String,
    pub osah_w: f32,
    pub spatial_splits: bool,
    pub min_leaf_size: usize,
    pub triangles: usize,
    pub visible: usize,
    pub references: usize,
    pub bvh_bytes: usize,
    pub build_ms: f64,
    /// With a reference builder (`--compare embree`): its best time on the same triangles,
    /// its builds alternating with this method's.
    pub reference_build_ms: Option<f64>,
    pub primary_nit: f64,
    pub primary_nts: f64,
    pub primary_mrays: f64,
    pub shadow_nit: f64,
    pub shadow_nts: f64,
    pub shadow_mrays: f64,
}

/// The variants measured: each method, and for visibility-driven ones each weight and
/// spatial-split switch.
pub struct Variants {
    pub methods: Vec<BuildMethod>,
    pub weights: Vec<f32>,
    pub spatial: Vec<bool>,
    pub settings: BuildSettings,
}

impl Variants {
    fn each(&self) -> Vec<(BuildMethod, BuildSettings)> {
        let mut out = Vec::new();
        for &m in &self.methods {
            let weights = if m == BuildMethod::Osah {
                self.weights.clone()
            } else {
                vec![self.settings.osah_weight]
            };
            let spatial = if matches!(m, BuildMethod::Sah | BuildMethod::Vsah) {
                vec![self.settings.spatial.enabled]
            } else {
                self.spatial.clone()
            };
            for &w in &weights {
                for &on in &spatial {
                    let mut s = self.settings;
                    s.osah_weight = w;
                    s.spatial.enabled = on;
                    out.push((m, s));
                }
            }
        }
        out
    }
}

/// A reference builder timed beside each method (`--compare embree`): builds the triangles and
/// returns its build ms.
pub type ReferenceBuild<'a> = &'a dyn Fn(&[[glam::Vec3; 3]]) -> Result<f64>;

/// Measures every variant on every viewpoint of `scene_name`.
pub fn method_rows(
    scene_name: &str,
    triangles: usize,
    (w, h): (u32, u32),
    spp: u32,
    repeat: u32,
    variants: &Variants,
    reference_builder: Option<ReferenceBuild>,
) -> Result<Vec<MethodRow>> {
    let params = antumbra_scenes::SceneParams {
        triangles,
        frames: 24,
        ..Default::default()
    };
    let anim = antumbra_scenes::builtin(scene_name, &params)?;
    let mut rows = Vec::new();
    for (camera_name, camera) in antumbra_scenes::viewpoints(scene_name, &params)? {
        let mut scene = anim.frame(*anim.frame_range().start());
        scene.camera = camera;
        scene.resolution = Resolution::new(w, h);
        let geometry = FrameGeometry::from_scene(&scene)?;
        let set = &geometry.camera;
        let shadow_set = geometry.shadow.as_ref().unwrap_or(set);
        let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
        let sah = build_binned_sah(&set.vertices, &variants.settings);
        let reference = PrimaryPass::timed(&rays, &sah, set);
        let ids: Vec<u32> = reference
            .surfaces
            .iter()
            .map(|s| s.map_or(u32::MAX, |s| s.triangle))
            .collect();
        let visible = visible_refs(&ids, &set.refs);
        let flags = visibility_flags(set, &visible);
        let shadow_flags = visibility_flags(shadow_set, &visible);
        let mut shadow: Vec<Ray> = Vec::new();
        for (i, light) in scene
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| l.casts_shadow)
        {
            let sampler = LightSampler::new(light, &geometry.space);
            let plan = SamplePlan {
                light_index: i as u32,
                samples: samples_for(&sampler, spp),
                seed: 0,
            };
            shadow.extend(shadow_rays(&reference, &sampler, plan));
        }
        let shadow_sah = build_binned_sah(&shadow_set.vertices, &variants.settings);
        let shadow_answers: Vec<bool> = shadow
            .par_iter()
            .map(|r| occluded(&shadow_sah, r, AnyHitOrder::NearFirst, &mut NoStats))
            .collect();
        for (method, settings) in variants.each() {
            let build = |tris: &[[glam::Vec3; 3]], f: &[bool]| {
                build_with_visibility(method, tris, Some(f), &settings)
            };
            let mut bvh = Bvh::default();
            let mut reference_build_ms = reference_builder.map(|_| f64::INFINITY);
            let mut build_ms = f64::INFINITY;
            // With a reference, its builds alternate with this method's, so both see the same
            // machine (wall clock drifts by tens of percent within a minute on small VMs).
            // Each build is followed by a pause: Embree's TBB workers (and rayon's) spin for a
            // while after a build and would otherwise take cores from the next one.
            let settle = || std::thread::sleep(std::time::Duration::from_millis(300));
            for _ in 0..repeat.max(1) {
                // The previous tree is dropped after the clock stops.
                let (built, ms) = timed(|| build(&set.vertices, &flags));
                build_ms = build_ms.min(ms);
                bvh = built;
                if let (Some(build_reference), Some(best)) =
                    (reference_builder, &mut reference_build_ms)
                {
                    settle();
                    *best = best.min(build_reference(&set.vertices)?);
                    settle();
                }
            }
            let counted = PrimaryPass::counted(&rays, &bvh, set);
            if counted.surfaces != reference.surfaces {
                bail!("{scene_name}/{camera_name}: {method:?} changed primary hits");
            }
            let primary_ms = best_of(repeat, || {
                std::hint::black_box(PrimaryPass::timed(&rays, &bvh, set));
            });
            let n = counted.surfaces.len().max(1) as f64;
            let t = counted.totals;
            let mut row = MethodRow {
                scene: anim.name().to_string(),
                camera: camera_name.clone(),
                method: method.name().to_string(),
                osah_w: settings.osah_weight,
                spatial_splits: settings.spatial.enabled,
                min_leaf_size: settings.min_leaf_size,
                triangles: set.len(),
                visible: visible.len(),
                references: bvh.triangles.len(),
                bvh_bytes: bvh.bytes(),
                build_ms,
                reference_build_ms,
                primary_nit: t.triangles as f64 / n,
                primary_nts: (t.inner + t.leaves) as f64 / n,
                primary_mrays: counted.surfaces.len() as f64 / (primary_ms * 1e3),
                ..MethodRow::default()
            };
            // VSAH is complete only for the primary rays its set came from.
            if method.is_complete() && !shadow.is_empty() {
                let shadow_bvh_owned;
                let shadow_bvh = match &geometry.shadow {
                    Some(s) => {
                        shadow_bvh_owned = build(&s.vertices, &shadow_flags);
                        &shadow_bvh_owned
                    }
                    None => &bvh,
                };
                let (work, answers) = shadow
                    .par_iter()
                    .map(|r| {
                        let mut w = TraversalStats::default();
                        let a = occluded(shadow_bvh, r, AnyHitOrder::NearFirst, &mut w);
                        (w, a)
                    })
                    .collect::<(Vec<_>, Vec<_>)>();
                if answers != shadow_answers {
                    bail!("{scene_name}/{camera_name}: {method:?} changed shadow answers");
                }
                let mut total = TraversalStats::default();
                for w in work {
                    total += w;
                }
                let ms = best_of(repeat, || {
                    shadow.par_iter().with_min_len(256).for_each(|r| {
                        std::hint::black_box(occluded(
                            shadow_bvh,
                            r,
                            AnyHitOrder::NearFirst,
                            &mut NoStats,
                        ));
                    })
                });
                let s = shadow.len() as f64;
                row.shadow_nit = total.triangles as f64 / s;
                row.shadow_nts = (total.inner + total.leaves) as f64 / s;
                row.shadow_mrays = s / (ms * 1e3);
            }
            rows.push(row);
        }
    }
    Ok(rows)
}

fn visible_refs(ids: &[u32], refs: &[TriangleRef]) -> Vec<TriangleRef> {
    let mut v: Vec<TriangleRef> = ids
        .iter()
        .filter(|&&i| i != u32::MAX)
        .map(|&i| refs[i as usize])
        .collect();
    v.sort_unstable();
    v.dedup();
    v
}

/// The best time in ms of `repeat` calls of `f`; what `f` returns is dropped after the clock
/// stops (freeing a 40 MB tree is not part of building it).
pub(super) fn best_of<T>(repeat: u32, mut f: impl FnMut() -> T) -> f64 {
    (0..repeat.max(1))
        .map(|_| timed(&mut f).1)
        .fold(f64::INFINITY, f64::min)
}

/// What `f` returns and its time in ms.
pub(super) fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let out = f();
    (out, t.elapsed().as_secs_f64() * 1e3)
}

/// Prints one Markdown table per metric: absolute values for the first variant, the others as
/// ratios to it, one line per scene/viewpoint and a mean of the ratios.
pub fn print_ratio_tables(rows: &[MethodRow]) {
    let label = |r: &MethodRow| {
        let mut s = r.method.clone();
        if r.method == "osah" {
            s += &format!(" w={}", r.osah_w);
        }
        if !r.spatial_splits && r.method != "sah" && r.method != "vsah" {
            s += " nosplit";
        }
        s
    };
    let mut variants: Vec<String> = Vec::new();
    for r in rows {
        if !variants.contains(&label(r)) {
            variants.push(label(r));
        }
    }
    let mut views: Vec<(String, String)> = Vec::new();
    for r in rows {
        let v = (r.scene.clone(), r.camera.clone());
        if !views.contains(&v) {
            views.push(v);
        }
    }
    type Metric = (&'static str, fn(&MethodRow) -> f64);
    let metrics: [Metric; 9] = [
        ("primary N_IT", |r| r.primary_nit),
        ("primary N_TS", |r| r.primary_nts),
        ("primary Mrays/s", |r| r.primary_mrays),
        ("shadow N_IT", |r| r.shadow_nit),
        ("shadow N_TS", |r| r.shadow_nts),
        ("shadow Mrays/s", |r| r.shadow_mrays),
        ("build ms", |r| r.build_ms),
        ("references", |r| r.references as f64),
        ("visible triangles", |r| r.visible as f64),
    ];
    for (name, get) in metrics {
        println!("\n{name}\n");
        println!("| scene / camera | {} |", variants.join(" | "));
        println!("|---|{}", "---|".repeat(variants.len()));
        let mut sums = vec![0.0; variants.len()];
        for (scene, camera) in &views {
            let of = |v: &String| {
                rows.iter()
                    .find(|r| &r.scene == scene && &r.camera == camera && &label(r) == v)
                    .map(get)
            };
            let base = of(&variants[0]).unwrap_or(f64::NAN);
            let cells: Vec<String> = variants
                .iter()
                .enumerate()
                .map(|(i, v)| match of(v) {
                    Some(x) if i == 0 => format!("{x:.2}"),
                    Some(x) if base > 0.0 => {
                        sums[i] += x / base - 1.0;
                        format!("{:+.0}%", (x / base - 1.0) * 100.0)
                    }
                    _ => "-".into(),
                })
                .collect();
            println!("| {scene} / {camera} | {} |", cells.join(" | "));
        }
        let mean: Vec<String> = sums
            .iter()
            .enumerate()
            .map(|(i, s)| {
                if i == 0 {
                    "+0%".to_string()
                } else {
                    format!("{:+.0}%", s / views.len() as f64 * 100.0)
                }
            })
            .collect();
        println!("| mean of ratios | {} |", mean.join(" | "));
    }
    print_reference_builds(rows, &variants, &views, label);
}

/// With `--compare embree`: each method's build time as a ratio to the reference build timed in
/// turn with it (below 1: faster than the reference).
fn print_reference_builds(
    rows: &[MethodRow],
    variants: &[String],
    views: &[(String, String)],
    label: impl Fn(&MethodRow) -> String,
) {
    if rows.iter().all(|r| r.reference_build_ms.is_none()) {
        return;
    }
    println!("\nbuild ms against the reference build (Embree), timed in turn\n");
    println!(
        "| scene / camera | reference ms | {} |",
        variants
            .iter()
            .map(|v| format!("{v} ms | {v} x"))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|---|{}", "---|---|".repeat(variants.len()));
    for (scene, camera) in views {
        let of = |v: &String| {
            rows.iter()
                .find(|r| &r.scene == scene && &r.camera == camera && &label(r) == v)
        };
        // The reference's best over all the methods' turns on this view.
        let reference = variants
            .iter()
            .filter_map(|v| of(v).and_then(|r| r.reference_build_ms))
            .fold(f64::INFINITY, f64::min);
        let cells: Vec<String> = variants
            .iter()
            .map(|v| match of(v) {
                Some(r) => format!("{:.1} | {:.2}", r.build_ms, r.build_ms / reference),
                None => "- | -".into(),
            })
            .collect();
        println!(
            "| {scene} / {camera} | {reference:.1} | {} |",
            cells.join(" | ")
        );
    }
}

/// Renders `frames` frames of `scene_name` with SAH, SBVH, OSAH-exact and OSAH-previous and
/// writes the per-frame primary Mrays/s (and work) as `animation.csv` and `animation.svg`.
pub fn animation_curve(
    scene_name: &str,
    triangles: usize,
    size: (u32, u32),
    frames: i32,
    settings: &BuildSettings,
    out: &Path,
) -> Result<()> {
    std::fs::create_dir_all(out)?;
    let params = antumbra_scenes::SceneParams {
        triangles,
        frames,
        ..Default::default()
    };
    let anim = antumbra_scenes::builtin(scene_name, &params)?;
    let configs = [
        ("SAH", BuildMethod::Sah, VisibilitySource::Previous),
        ("SBVH", BuildMethod::Sbvh, VisibilitySource::Previous),
        ("OSAH-exact", BuildMethod::Osah, VisibilitySource::Exact),
        (
            "OSAH-previous",
            BuildMethod::Osah,
            VisibilitySource::Previous,
        ),
    ];
    let mut csv = String::from(
        "frame,method,primary_mrays,primary_nit,primary_nts,shadow_mrays,build_ms,visibility_ms,rebuilt\n",
    );
    let mut series = Vec::new();
    let first_frame = *anim.frame_range().start();
    for (name, build, visibility) in configs {
        let s = RenderSettings {
            build,
            visibility,
            build_settings: *settings,
            spp: 1,
            stats: StatsMode::CountsAndTiming,
            ..RenderSettings::default()
        };
        let mut renderer = Renderer::new();
        let mut mrays = Vec::new();
        for f in anim.frame_range().take(frames as usize) {
            let mut scene = anim.frame(f);
            scene.resolution = Resolution::new(size.0, size.1);
            let r = renderer.render(anim.name(), &scene, &s)?;
            let p = &r.stats[0];
            let shadow: Vec<f64> = r.stats[1..].iter().map(|x| x.mrays_per_s).collect();
            let shadow_mean = shadow.iter().sum::<f64>() / shadow.len().max(1) as f64;
            csv += &format!(
                "{f},{name},{:.4},{:.4},{:.4},{:.4},{:.3},{:.3},{}\n",
                p.mrays_per_s,
                p.nt_per_ray,
                p.nts_per_ray,
                shadow_mean,
                p.build_ms,
                p.visibility_ms,
                p.rebuilt
            );
            mrays.push(p.mrays_per_s);
        }
        let mean = mrays.iter().sum::<f64>() / mrays.len().max(1) as f64;
        println!(
            "{scene_name} {name}: mean primary {mean:.3} Mrays/s over {} frames",
            mrays.len()
        );
        series.push((format!("{name} ({mean:.2})"), mrays));
    }
    write_bytes_atomic(&out.join("animation.csv"), csv.as_bytes())?;
    LinePlot {
        title: &format!("{scene_name}: primary Mrays/s per frame"),
        y_label: "primary Mrays/s",
        first_frame,
        series: &series,
    }
    .write_svg(&out.join("animation.svg"), 900, 420)?;
    Ok(())
}
