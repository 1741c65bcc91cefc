//! `antumbra bench`: build time and Mrays/s per scene, on exactly the rays a frame traces,
//! optionally beside Embree on the same triangles and rays.

use std::time::Instant;

use antumbra_core::bvh::{
    build_binned_sah, BuildMethod, BuildSettings, Bvh, BvhWidth, CollapseCost, CollapseMethod,
    CollapseSettings, SpatialAxes,
};
use antumbra_core::geometry::Ray;
use antumbra_core::render::{
    binary_order, representative_rays, samples_for, shadow_rays, srdh_for_light, LightSampler,
    LightSrdh, PrimaryPass, PrimaryRays, SamplePlan, ShadowTracer, WideTree,
};
use antumbra_core::scene::FrameGeometry;
use antumbra_core::trace::wide::{BoxKernel, PreparedOrder};
use antumbra_core::trace::{
    AnyHitOrder, BinaryOcclusion, ClosestHitQuery, NoStats, OcclusionQuery, ShadowOrder,
    WideOcclusion,
};
use anyhow::{bail, Result};
use clap::Args;
use rayon::prelude::*;
use serde::Serialize;

use super::bench_methods::{self, best_of};
use crate::frames::parse_size;
use crate::scene_source::open_scene;

/// Runs `$body` with `$o` bound to the concrete occlusion query of one light (binary, or the
/// wide tree of its width with the light's order), so timed loops have no per-ray dispatch.
macro_rules! with_occluder {
    ($bvh:expr, $binary:expr, $wide:expr, $prepared:expr, $srdh:expr, |$o:ident| $body:expr) => {
        match ($binary, $wide, $prepared) {
            _ if $srdh.is_some() => match $srdh.and_then(|l: &LightSrdh| l.tree.as_ref()) {
                Some(t) => {
                    let $o = &ShadowTracer::Srdh(t);
                    $body
                }
                // Too few occluded rays: the SAH tree front to back, as the renderer does.
                None => {
                    let $o = &BinaryOcclusion {
                        bvh: $bvh,
                        order: AnyHitOrder::NearFirst,
                    };
                    $body
                }
            },
            (Some(order), _, _) => {
                let $o = &BinaryOcclusion { bvh: $bvh, order };
                $body
            }
            (None, Some(tree), Some(p)) => {
                let (order, kernel) = (p.view(), BoxKernel::Auto);
                match tree {
                    WideTree::Two(bvh) => {
                        let $o = &WideOcclusion { bvh, order, kernel };
                        $body
                    }
                    WideTree::Four(bvh) => {
                        let $o = &WideOcclusion { bvh, order, kernel };
                        $body
                    }
                    WideTree::Eight(bvh) => {
                        let $o = &WideOcclusion { bvh, order, kernel };
                        $body
                    }
                }
            }
            _ => unreachable!("a wide order comes with its tree"),
        }
    };
}

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Scenes to measure (default: every built-in scene).
    #[arg(long, num_args = 1..)]
    pub scene: Vec<String>,
    /// Triangle budget of built-in scenes.
    #[arg(long, default_value_t = 350_000)]
    pub triangles: usize,
    /// Image size WxH of the camera rays.
    #[arg(long, default_value = "512x512")]
    pub size: String,
    /// Shadow samples per pixel for soft lights.
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    /// Timing repetitions; the best is reported.
    #[arg(long, default_value_t = 3)]
    pub repeat: u32,
    /// Children per BVH node: 2 (binary), 4 or 8.
    #[arg(long, default_value = "2")]
    pub width: BvhWidth,
    /// How widths 4 and 8 collapse the binary tree: greedy or sah (see `antumbra render --help`).
    #[arg(long, default_value_t = CollapseSettings::default().method)]
    pub collapse: CollapseMethod,
    /// Largest leaf the sah collapse makes by merging binary leaves.
    #[arg(long, default_value_t = CollapseCost::default().max_leaf)]
    pub collapse_max_leaf: u32,
    /// Child order of shadow rays (see `antumbra render --help`); sorted orders are made per
    /// light from that light's rays, and their cost is reported.
    #[arg(long, default_value = "fbto")]
    pub order: ShadowOrder,
    /// Compare with another tracer on the same triangles and rays ("embree").
    #[arg(long)]
    pub compare: Option<String>,
    /// Print the table as JSON.
    #[arg(long)]
    pub json: bool,
    /// Embree build quality with --compare embree: medium or high.
    #[arg(long, default_value = "medium")]
    pub embree_quality: String,
    /// Compare build methods on each scene's viewpoints instead (the OSAH paper's tables),
    /// e.g. sah,sbvh,abvh,osah,vsah; the first is the reference of the ratios.
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<BuildMethod>,
    /// OSAH weights w to sweep (with --methods).
    #[arg(long, value_delimiter = ',', default_value = "0.9")]
    pub osah_w: Vec<f32>,
    /// Spatial splits for sbvh/abvh/osah (with --methods): on, off, or on,off for both.
    #[arg(long, value_delimiter = ',', default_value = "on")]
    pub spatial_splits: Vec<String>,
    /// OSAH viability as the paper states it (condition (5) alone), with --methods.
    #[arg(long)]
    pub osah_paper_viability: bool,
    /// Spatial bins per axis for sbvh/abvh/osah (with --methods; default: the builder's).
    #[arg(long)]
    pub spatial_bins: Option<usize>,
    /// Axes spatial splits are binned on, all or object (with --methods; default: the
    /// builder's).
    #[arg(long)]
    pub spatial_axes: Option<SpatialAxes>,
    /// Nodes with fewer references than this bin spatial splits with cut reference boxes
    /// instead of clipped triangles (with --methods; default: the builder's).
    #[arg(long)]
    pub clip_min_refs: Option<usize>,
    /// Spatial splits' overlap threshold alpha (with --methods; default: the builder's).
    #[arg(long)]
    pub split_alpha: Option<f32>,
    /// Spatial splits only where object-split children overlap by at least this fraction of
    /// the node's own area (with --methods; default: the builder's).
    #[arg(long)]
    pub split_node_overlap: Option<f32>,
    /// Nodes with fewer references than this never try spatial splits (with --methods;
    /// default: the builder's).
    #[arg(long)]
    pub split_min_refs: Option<usize>,
    /// Nodes of at most this many triangles become leaves without a split search, in every
    /// build (default: the builder's, 1; see `antumbra render --help`).
    #[arg(long)]
    pub min_leaf_size: Option<usize>,
    /// Render this many frames with SAH, SBVH, OSAH-exact and OSAH-previous and write the
    /// per-frame curve (animation.csv, animation.svg) into --out.
    #[arg(long)]
    pub animation: Option<i32>,
    /// Output folder of --animation.
    #[arg(long, default_value = "bench-out")]
    pub out: std::path::PathBuf,
}

/// The build settings of every tree the bench makes: the builder's defaults with the
/// command line's overrides, checked.
fn build_settings(args: &BenchArgs) -> Result<BuildSettings> {
    let mut s = BuildSettings {
        osah_strict_viability: !args.osah_paper_viability,
        ..BuildSettings::default()
    };
    s.spatial.bins = args.spatial_bins.unwrap_or(s.spatial.bins);
    s.spatial.axes = args.spatial_axes.unwrap_or(s.spatial.axes);
    s.spatial.clip_min_refs = args.clip_min_refs.unwrap_or(s.spatial.clip_min_refs);
    s.spatial.alpha = args.split_alpha.unwrap_or(s.spatial.alpha);
    s.spatial.node_overlap = args.split_node_overlap.unwrap_or(s.spatial.node_overlap);
    s.spatial.min_refs = args.split_min_refs.unwrap_or(s.spatial.min_refs);
    s.min_leaf_size = args.min_leaf_size.unwrap_or(s.min_leaf_size);
    s.validate()?;
    Ok(s)
}

#[derive(Debug, Default, Serialize)]
pub struct BenchRow {
    pub scene: String,
    /// Builder / width / shadow order, as in the statistics tables.
    pub method: String,
    pub triangles: usize,
    pub threads: usize,
    pub build_ms: f64,
    pub bvh_bytes: usize,
    pub primary_rays: usize,
    pub primary_mrays: f64,
    pub shadow_rays: usize,
    pub shadow_occluded: f64,
    pub shadow_mrays: f64,
    /// Collapse to the wide tree (not in `build_ms`).
    pub collapse_ms: f64,
    /// Per light, logging + sorting ms of a sorted order (one thread for the sorting, the
    /// pool for the logging rays); for `srdh`, ray selection + hit lists + SRDH build (all
    /// threads).
    pub sort_ms_per_light: Vec<f64>,
    /// `srdh`: bytes of the lights' SRDH trees (0 for a light that traces the SAH tree).
    pub srdh_bytes_per_light: Vec<usize>,
    pub embree_build_ms: Option<f64>,
    pub embree_primary_mrays: Option<f64>,
    pub embree_shadow_mrays: Option<f64>,
    /// Shadow rays on which Embree and antumbra give the same occlusion answer.
    pub embree_agreement: Option<f64>,
}

pub fn run(args: BenchArgs) -> Result<()> {
    if let Some(c) = &args.compare {
        if c != "embree" {
            bail!("--compare: unknown tracer '{c}' (known: embree)");
        }
        if !cfg!(feature = "embree") {
            bail!("--compare embree: this antumbra was built without the 'embree' feature (cargo build --features embree)");
        }
    }
    let (w, h) = parse_size(&args.size)?;
    let scenes: Vec<String> = if args.scene.is_empty() {
        antumbra_scenes::BUILTIN_SCENES
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        args.scene.clone()
    };
    let settings = build_settings(&args)?;
    if let Some(frames) = args.animation {
        for name in &scenes {
            let out = args.out.join(name);
            bench_methods::animation_curve(name, args.triangles, (w, h), frames, &settings, &out)?;
        }
        return Ok(());
    }
    if !args.methods.is_empty() {
        let spatial = args
            .spatial_splits
            .iter()
            .map(|s| match s.as_str() {
                "on" => Ok(true),
                "off" => Ok(false),
                other => Err(anyhow::anyhow!(
                    "--spatial-splits: '{other}' is not on or off"
                )),
            })
            .collect::<Result<Vec<bool>>>()?;
        let variants = bench_methods::Variants {
            methods: args.methods.clone(),
            weights: args.osah_w.clone(),
            spatial,
            settings,
        };
        let threads = rayon::current_num_threads();
        let embree_build =
            |tris: &[[glam::Vec3; 3]]| Reference::build_only(&args.embree_quality, tris, threads);
        let reference: Option<bench_methods::ReferenceBuild> =
            args.compare.as_ref().map(|_| &embree_build as _);
        let mut rows = Vec::new();
        for name in &scenes {
            rows.extend(bench_methods::method_rows(
                name,
                args.triangles,
                (w, h),
                args.spp,
                args.repeat,
                &variants,
                reference,
            )?);
        }
        if args.json {
            println!("{}", serde_json::to_string_pretty(&rows)?);
        } else {
            bench_methods::print_ratio_tables(&rows);
        }
        return Ok(());
    }
    let all = rayon::current_num_threads();
    let mut rows = Vec::new();
    for name in &scenes {
        let anim = open_scene(name, args.triangles, 1)?;
        let first = *anim.frame_range().start();
        let mut scene = anim.frame(first);
        scene.resolution = antumbra_core::scene::Resolution::new(w, h);
        let geometry = FrameGeometry::from_scene(&scene)?;
        let tris = &geometry.camera.vertices;
        let bvh = build_binned_sah(tris, &settings);
        let primary_gen = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
        let primary: Vec<Ray> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| primary_gen.ray(x, y))
            .collect();
        let pass = PrimaryPass::timed(&primary_gen, &bvh, &geometry.camera);
        let shadow_bvh_owned;
        let shadow_bvh: &Bvh = match &geometry.shadow {
            Some(s) => {
                shadow_bvh_owned = build_binned_sah(&s.vertices, &settings);
                &shadow_bvh_owned
            }
            None => &bvh,
        };
        let binary = binary_order(args.width, &args.order);
        let collapse = CollapseSettings {
            method: args.collapse,
            cost: CollapseCost {
                max_leaf: args.collapse_max_leaf,
                ..CollapseCost::default()
            },
        };
        collapse.cost.validate()?;
        let wide_camera =
            (args.width != BvhWidth::Two).then(|| WideTree::collapse(&bvh, args.width, &collapse));
        let srdh_settings = match &args.order {
            ShadowOrder::Srdh(s) => Some(*s),
            _ => None,
        };
        let wide_shadow = (binary.is_none() && srdh_settings.is_none())
            .then(|| WideTree::collapse(shadow_bvh, args.width, &collapse));
        let shadow_tris = &geometry
            .shadow
            .as_ref()
            .unwrap_or(&geometry.camera)
            .vertices;
        let tables = matches!(args.order, ShadowOrder::Sorted(_))
            .then(|| wide_shadow.as_ref().map(|t| t.sort_tables()))
            .flatten();
        // Per light: its rays and its prepared order (the same rays the shadow pass traces).
        type Light = (Vec<Ray>, Option<PreparedOrder>, Option<LightSrdh>);
        let mut lights: Vec<Light> = Vec::new();
        for (i, light) in scene
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| l.casts_shadow)
        {
            let sampler = LightSampler::new(light, &geometry.space);
            let plan = SamplePlan {
                light_index: i as u32,
                samples: samples_for(&sampler, args.spp),
                seed: 0,
            };
            let rays = shadow_rays(&pass, &sampler, plan);
            let prepared = wide_shadow.as_ref().map(|t| {
                let representative = match &args.order {
                    ShadowOrder::Sorted(s) => representative_rays(&pass, &sampler, plan, s.budget),
                    _ => Vec::new(),
                };
                // The sorting itself runs on one thread, as the target asks.
                rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .build()
                    .expect("thread pool")
                    .install(|| t.prepare(&args.order, tables.as_ref(), &representative))
            });
            let srdh = srdh_settings.map(|s| {
                srdh_for_light(
                    &pass,
                    &sampler,
                    plan,
                    &s,
                    shadow_bvh,
                    shadow_tris,
                    &settings,
                )
            });
            lights.push((rays, prepared, srdh));
        }
        let shadow: Vec<Ray> = lights
            .iter()
            .flat_map(|(r, _, _)| r.iter().copied())
            .collect();
        let answers: Vec<bool> = lights
            .iter()
            .flat_map(|(rays, prepared, srdh)| {
                with_occluder!(
                    shadow_bvh,
                    binary,
                    wide_shadow.as_ref(),
                    prepared.as_ref(),
                    srdh.as_ref(),
                    |o| {
                        rays.par_iter()
                            .map(|r| o.occluded(r, &mut NoStats))
                            .collect::<Vec<bool>>()
                    }
                )
            })
            .collect();
        // The collapse is named when it is not the default, e.g. sah/bin8:sah/sorted.
        let collapsed = if args.collapse == CollapseSettings::default().method {
            String::new()
        } else {
            format!(":{}", args.collapse)
        };
        let method = format!("sah/bin{}{collapsed}/{}", args.width, args.order);
        let sort_ms_per_light: Vec<f64> = lights
            .iter()
            .filter_map(|(_, p, srdh)| match srdh {
                Some(l) => Some(l.ms),
                None => p.as_ref().map(|p| p.sort_ms()),
            })
            .filter(|ms| *ms > 0.0)
            .collect();
        let srdh_bytes_per_light: Vec<usize> = lights
            .iter()
            .filter_map(|(_, _, srdh)| srdh.as_ref())
            .map(|l| l.tree.as_ref().map_or(0, |t| t.bytes()))
            .collect();
        for threads in [1, all] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()?;
            let mut row = BenchRow {
                scene: anim.name().to_string(),
                method: method.clone(),
                triangles: tris.len(),
                threads,
                bvh_bytes: wide_camera.as_ref().map_or(bvh.bytes(), |t| t.bytes()),
                primary_rays: primary.len(),
                shadow_rays: shadow.len(),
                shadow_occluded: answers.iter().filter(|a| **a).count() as f64
                    / shadow.len().max(1) as f64,
                collapse_ms: wide_camera.as_ref().map_or(0.0, |t| t.collapse_ms()),
                sort_ms_per_light: sort_ms_per_light.clone(),
                srdh_bytes_per_light: srdh_bytes_per_light.clone(),
                ..BenchRow::default()
            };
            // Embree's side is built first and its rays are timed in turn with antumbra's
            // (antumbra, Embree, antumbra, ...), so the two best times come from the same
            // spells of a noisy machine and their ratio means something.
            let reference = match &args.compare {
                Some(_) => Some(Reference::build(
                    &args.embree_quality,
                    tris,
                    threads,
                    args.repeat,
                )?),
                None => None,
            };
            pool.install(|| {
                row.build_ms = best_of(args.repeat, || build_binned_sah(tris, &settings));
                let closest = |tree: &(dyn Fn(&Ray) + Sync)| {
                    best_of_in_turn(
                        args.repeat,
                        || primary.par_iter().with_min_len(256).for_each(tree),
                        reference.as_ref().map(|r| {
                            || {
                                primary
                                    .par_iter()
                                    .with_min_len(256)
                                    .for_each(|ray| r.intersect(ray))
                            }
                        }),
                    )
                };
                let (primary_ms, reference_primary_ms) = match &wide_camera {
                    Some(WideTree::Four(t)) => closest(&|r| {
                        std::hint::black_box(t.closest_hit(r, &mut NoStats));
                    }),
                    Some(WideTree::Eight(t)) => closest(&|r| {
                        std::hint::black_box(t.closest_hit(r, &mut NoStats));
                    }),
                    _ => closest(&|r| {
                        std::hint::black_box(bvh.closest_hit(r, &mut NoStats));
                    }),
                };
                row.primary_mrays = mrays(primary.len(), primary_ms);
                row.embree_primary_mrays = reference_primary_ms.map(|ms| mrays(primary.len(), ms));
                let (shadow_ms, reference_shadow_ms) = best_of_in_turn(
                    args.repeat,
                    || {
                        for (rays, prepared, srdh) in &lights {
                            with_occluder!(
                                shadow_bvh,
                                binary,
                                wide_shadow.as_ref(),
                                prepared.as_ref(),
                                srdh.as_ref(),
                                |o| {
                                    rays.par_iter().with_min_len(256).for_each(|r| {
                                        std::hint::black_box(o.occluded(r, &mut NoStats));
                                    })
                                }
                            )
                        }
                    },
                    reference.as_ref().map(|r| {
                        || {
                            shadow.par_iter().with_min_len(256).for_each(|ray| {
                                std::hint::black_box(r.occluded(ray));
                            })
                        }
                    }),
                );
                row.shadow_mrays = mrays(shadow.len(), shadow_ms);
                row.embree_shadow_mrays = reference_shadow_ms.map(|ms| mrays(shadow.len(), ms));
                if let Some(r) = &reference {
                    let agree = shadow
                        .par_iter()
                        .zip(&answers)
                        .filter(|(ray, a)| r.occluded(ray) == **a)
                        .count();
                    row.embree_build_ms = Some(r.build_ms);
                    row.embree_agreement = Some(agree as f64 / shadow.len().max(1) as f64);
                }
            });
            rows.push(row);
        }
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print_table(&rows);
    }
    Ok(())
}

fn mrays(n: usize, ms: f64) -> f64 {
    n as f64 / (ms * 1e3)
}

/// Best times of `ours` and of `theirs` (when given) over `repeat` runs each, run in turn.
fn best_of_in_turn(
    repeat: u32,
    mut ours: impl FnMut(),
    mut theirs: Option<impl FnMut()>,
) -> (f64, Option<f64>) {
    let time = |f: &mut dyn FnMut()| {
        let t = Instant::now();
        f();
        t.elapsed().as_secs_f64() * 1e3
    };
    let (mut best, mut best_theirs) = (f64::INFINITY, theirs.as_ref().map(|_| f64::INFINITY));
    for _ in 0..repeat.max(1) {
        best = best.min(time(&mut ours));
        if let (Some(f), Some(b)) = (theirs.as_mut(), best_theirs.as_mut()) {
            *b = b.min(time(f));
        }
    }
    (best, best_theirs)
}

/// Embree on the same triangles, for `--compare embree`: its build time, and its two queries
/// called directly (no dynamic dispatch in its timed loops either).
#[cfg(feature = "embree")]
struct Reference {
    build_ms: f64,
    scene: antumbra_embree::EmbreeScene,
}

#[cfg(feature = "embree")]
fn embree_quality(quality: &str) -> Result<antumbra_embree::EmbreeQuality> {
    use antumbra_embree::EmbreeQuality;
    match quality {
        "medium" => Ok(EmbreeQuality::Medium),
        "high" => Ok(EmbreeQuality::High),
        other => anyhow::bail!("--embree-quality: '{other}' is not medium or high"),
    }
}

#[cfg(feature = "embree")]
impl Reference {
    /// The best of `repeat` builds (commits) with `threads` threads.
    fn build(quality: &str, tris: &[[glam::Vec3; 3]], threads: usize, repeat: u32) -> Result<Self> {
        use antumbra_embree::EmbreeScene;
        let quality = embree_quality(quality)?;
        let mut build_ms = f64::INFINITY;
        let mut scene = None;
        for _ in 0..repeat.max(1) {
            let s = EmbreeScene::new(tris, quality, Some(threads))
                .map_err(|e| anyhow::anyhow!("embree: {e}"))?;
            build_ms = build_ms.min(s.build_ms());
            scene = Some(s);
        }
        // Embree's TBB workers spin for a moment after a commit; let them settle before timing.
        std::thread::sleep(std::time::Duration::from_millis(300));
        Ok(Reference {
            build_ms,
            scene: scene.expect("built at least once"),
        })
    }

    /// One build (commit) with `threads` threads; its time in ms.
    fn build_only(quality: &str, tris: &[[glam::Vec3; 3]], threads: usize) -> Result<f64> {
        let quality = embree_quality(quality)?;
        antumbra_embree::EmbreeScene::new(tris, quality, Some(threads))
            .map(|s| s.build_ms())
            .map_err(|e| anyhow::anyhow!("embree: {e}"))
    }

    #[inline]
    fn intersect(&self, ray: &Ray) {
        std::hint::black_box(self.scene.intersect(ray));
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded(ray)
    }
}

/// Without the `embree` feature `run` refuses `--compare` before any is built.
#[cfg(not(feature = "embree"))]
struct Reference {
    build_ms: f64,
    never: std::convert::Infallible,
}

#[cfg(not(feature = "embree"))]
impl Reference {
    fn build(_: &str, _: &[[glam::Vec3; 3]], _: usize, _: u32) -> Result<Self> {
        bail!("built without the 'embree' feature")
    }
    fn build_only(_: &str, _: &[[glam::Vec3; 3]], _: usize) -> Result<f64> {
        bail!("built without the 'embree' feature")
    }
    fn intersect(&self, _: &Ray) {
        match self.never {}
    }
    fn occluded(&self, _: &Ray) -> bool {
        match self.never {}
    }
}

fn print_table(rows: &[BenchRow]) {
    let embree = rows.iter().any(|r| r.embree_build_ms.is_some());
    print!(
        "{:<16} {:>9} {:>3} {:>9} {:>9} {:>8} {:>8} {:>7}",
        "scene", "tris", "thr", "build ms", "MB", "prim Mr/s", "shad Mr/s", "occl"
    );
    if embree {
        print!(
            " | {:>9} {:>8} {:>9} {:>9} {:>9} {:>8}",
            "E build", "build x", "E prim", "E shad", "shad x", "agree"
        );
    }
    println!();
    for r in rows {
        print!(
            "{:<16} {:>9} {:>3} {:>9.1} {:>9.1} {:>8.2} {:>8.2} {:>6.1}%",
            r.scene,
            r.triangles,
            r.threads,
            r.build_ms,
            r.bvh_bytes as f64 / 1e6,
            r.primary_mrays,
            r.shadow_mrays,
            r.shadow_occluded * 100.0
        );
        if let (Some(b), Some(p), Some(s), Some(a)) = (
            r.embree_build_ms,
            r.embree_primary_mrays,
            r.embree_shadow_mrays,
            r.embree_agreement,
        ) {
            print!(
                " | {:>9.1} {:>8.2} {:>9.2} {:>9.2} {:>9.2} {:>7.3}%",
                b,
                r.build_ms / b,
                p,
                s,
                r.shadow_mrays / s,
                a * 100.0
            );
        }
        println!();
    }
    if embree {
        println!("build x = antumbra build / Embree build (quality per --embree-quality, default medium); shad x = antumbra shadow Mrays/s / Embree rtcOccluded1 Mrays/s (same rays)");
    }
}
