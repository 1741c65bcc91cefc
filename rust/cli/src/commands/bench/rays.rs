//! `antumbra bench`'s main table: per scene and frame, SAH build time, Mrays/s and work per ray
//! on exactly the rays a frame traces (camera rays, then every light's shadow rays in its
//! order), on one thread and on all, optionally beside Embree timed in turn on the same rays.
//! The trees and orders are the renderer's own (a warm-up's `FrameTrees`): one pipeline.

use antumbra_core::build::{build_binned_sah, CollapseSettings};
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray;
use antumbra_core::order::ShadowOrder;
use antumbra_core::render::{
    shadow_ray_batches, CameraTree, FrameTrees, LightRays, LightTracing, PrimaryPass, PrimaryRays,
    RenderSettings, Renderer,
};
use antumbra_core::scene::{Animation, Resolution};
use antumbra_core::stats::StatsRow;
use antumbra_core::trace::{NoStats, RayQuery, TraversalStats};
use anyhow::Result;
use rayon::prelude::*;
use serde::Serialize;

use super::frames::BenchScene;
use super::reference::Reference;
use super::{bench_order, best_of, best_of_in_turn, mrays, print_json, BenchArgs};
use crate::shadow_lights::{shadow_lights, ShadowLight};

/// Rays handed to Embree's single-ray calls per parallel task.
const CHUNK: usize = 256;

#[derive(Debug, Default, Serialize)]
pub struct BenchRow {
    pub scene: String,
    pub frame: i32,
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
    /// Work of the camera rays, counted on the tree that is timed.
    pub primary_work: PassWork,
    /// Work of every light's shadow rays together, each light in its order.
    pub shadow_work: PassWork,
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

/// N_B, N_L, N_T and N_box per ray of one kind of pass, as the statistics rows compute them
/// (so they equal `render`'s columns of the same rays), and the exact totals.
#[derive(Debug, Default, Serialize)]
pub struct PassWork {
    pub totals: TraversalStats,
    pub nb_per_ray: f64,
    pub nl_per_ray: f64,
    pub nt_per_ray: f64,
    pub nbox_per_ray: f64,
}

impl PassWork {
    fn of(totals: &TraversalStats, rays: usize) -> PassWork {
        let mut row = StatsRow {
            rays: rays as u64,
            ..StatsRow::default()
        };
        row.set_work(totals);
        PassWork {
            totals: *totals,
            nb_per_ray: row.nb_per_ray,
            nl_per_ray: row.nl_per_ray,
            nt_per_ray: row.nt_per_ray,
            nbox_per_ray: row.nbox_per_ray,
        }
    }
}

/// Two rows per scene and frame (one thread, all threads), printed as a table or JSON.
pub(super) fn run(args: &BenchArgs, scenes: &[String], settings: &RenderSettings) -> Result<()> {
    let all = rayon::current_num_threads();
    let mut rows = Vec::new();
    for name in scenes {
        let scene = BenchScene::open(name, args.triangles, args.frames.as_deref(), 1)?;
        for &f in &scene.frames {
            let state = FrameState::prepare(scene.animation.as_ref(), f, args, settings)?;
            let frame = Frame::new(&state, settings);
            for threads in [1, all] {
                rows.push(frame.timed_row(threads, args, settings)?);
            }
        }
    }
    if args.json {
        print_json(&rows)
    } else {
        print_table(&rows);
        Ok(())
    }
}

/// A frame's trees made as a render makes them (a warm-up: `FrameTrees`, the one pipeline), its
/// camera rays' hits and its shadow-casting lights.
struct FrameState {
    scene: String,
    frame: i32,
    renderer: Renderer,
    camera: PrimaryRays,
    pass: PrimaryPass,
    lights: Vec<ShadowLight>,
}

impl FrameState {
    fn prepare(
        anim: &dyn Animation,
        number: i32,
        args: &BenchArgs,
        s: &RenderSettings,
    ) -> Result<FrameState> {
        let mut scene = anim.frame(number);
        scene.resolution = Resolution::new(args.size.width, args.size.height);
        let mut renderer = Renderer::new();
        renderer.warm_up(&scene, s)?;
        let trees = renderer.trees().expect("a warm-up keeps the frame's trees");
        let space = trees.geometry().space;
        let camera = PrimaryRays::new(&scene.camera, &scene.resolution, &space);
        let never = CancelToken::new();
        let pass = PrimaryPass::trace::<NoStats>(
            &camera,
            &trees.camera(),
            &trees.geometry().camera,
            &never,
        )?;
        Ok(FrameState {
            scene: anim.name().to_string(),
            frame: number,
            lights: shadow_lights(&scene, &space, s.spp, s.seed),
            renderer,
            camera,
            pass,
        })
    }

    fn trees(&self) -> &FrameTrees {
        self.renderer.trees().expect("prepared with its trees")
    }
}

/// One light's shadow rays, batched per tile as the shadow pass batches them, and its tree and
/// order, prepared as the renderer does.
struct LightRaysOf<'a> {
    batches: Vec<Vec<Ray>>,
    tracing: LightTracing<'a>,
}

/// One frame of a scene with its trees and rays, ready to be timed, and their counted work.
struct Frame<'a> {
    state: &'a FrameState,
    trees: &'a FrameTrees,
    /// The camera rays, batched per tile as the primary pass batches them.
    primary: Vec<Vec<Ray>>,
    primary_rays: usize,
    lights: Vec<LightRaysOf<'a>>,
    /// Every light's rays in turn, and antumbra's answer for each.
    shadow: Vec<Ray>,
    answers: Vec<bool>,
    primary_work: TraversalStats,
    shadow_work: TraversalStats,
    /// Whether the lights trace SRDH trees of their own.
    srdh: bool,
}

impl<'a> Frame<'a> {
    fn new(state: &'a FrameState, s: &RenderSettings) -> Frame<'a> {
        let trees = state.trees();
        let camera = &state.camera;
        // Counted on the tree the timed loop traces (the timed loop has no counters).
        let primary_work = PrimaryPass::trace::<TraversalStats>(
            camera,
            &trees.camera(),
            &trees.geometry().camera,
            &CancelToken::new(),
        )
        .expect("a new token is never cancelled")
        .totals;
        let order = bench_order(s);
        let lights: Vec<LightRaysOf> = state
            .lights
            .iter()
            .enumerate()
            .map(|(i, light)| {
                let rays = LightRays {
                    primary: &state.pass,
                    sampler: &light.sampler,
                    plan: light.plan,
                    sah: &s.build_settings,
                    first: i == 0,
                };
                let prepare = || trees.for_light(order, s.width, &rays);
                // A sorted order's logging and sorting run on one thread, as the target asks.
                let tracing = match order {
                    ShadowOrder::Sorted(_) => rayon::ThreadPoolBuilder::new()
                        .num_threads(1)
                        .build()
                        .expect("thread pool")
                        .install(prepare),
                    _ => prepare(),
                };
                LightRaysOf {
                    batches: shadow_ray_batches(&state.pass, &light.sampler, light.plan),
                    tracing,
                }
            })
            .collect();
        let shadow = lights
            .iter()
            .flat_map(|l| l.batches.iter().flatten().copied())
            .collect();
        let primary = camera.batches();
        let mut frame = Frame {
            state,
            trees,
            primary_rays: primary.iter().map(Vec::len).sum(),
            primary,
            lights,
            shadow,
            answers: Vec::new(),
            primary_work,
            shadow_work: TraversalStats::default(),
            srdh: matches!(order, ShadowOrder::Srdh(_)),
        };
        (frame.answers, frame.shadow_work) = frame.counted_occlusion();
        frame
    }

    /// Every shadow ray's answer, and the work of all of them, counted.
    fn counted_occlusion(&self) -> (Vec<bool>, TraversalStats) {
        let mut answers = Vec::with_capacity(self.shadow.len());
        let mut total = TraversalStats::default();
        for light in &self.lights {
            let tracer = light.tracing.tracer(antumbra_core::trace::RayMode::Single);
            let counted: Vec<(Vec<bool>, TraversalStats)> = light
                .batches
                .par_iter()
                .map(|rays| {
                    let mut a = vec![false; rays.len()];
                    let mut work = vec![TraversalStats::default(); rays.len()];
                    tracer.occluded_batch(rays, &mut a, &mut work);
                    let mut sum = TraversalStats::default();
                    for w in work {
                        sum += w;
                    }
                    (a, sum)
                })
                .collect();
            for (a, w) in counted {
                answers.extend(a);
                total += w;
            }
        }
        (answers, total)
    }

    /// The row's counts, before anything is timed.
    fn row(&self, threads: usize, s: &RenderSettings) -> BenchRow {
        let occluded = self.answers.iter().filter(|a| **a).count();
        let (bvh_bytes, collapse_ms) = match self.trees.camera() {
            CameraTree::Binary(b) => (b.bytes(), 0.0),
            CameraTree::Wide(t) => (t.bytes(), t.collapse_ms()),
        };
        BenchRow {
            scene: self.state.scene.clone(),
            frame: self.state.frame,
            method: method_name(s),
            triangles: self.trees.geometry().camera.vertices.len(),
            threads,
            bvh_bytes,
            primary_rays: self.primary_rays,
            shadow_rays: self.shadow.len(),
            shadow_occluded: occluded as f64 / self.shadow.len().max(1) as f64,
            primary_work: PassWork::of(&self.primary_work, self.primary_rays),
            shadow_work: PassWork::of(&self.shadow_work, self.shadow.len()),
            collapse_ms,
            sort_ms_per_light: self
                .lights
                .iter()
                .map(|l| l.tracing.sort_ms)
                .filter(|ms| *ms > 0.0)
                .collect(),
            srdh_bytes_per_light: self
                .lights
                .iter()
                .filter(|_| self.srdh)
                .map(|l| l.tracing.own_tree().map_or(0, |t| t.bytes()))
                .collect(),
            ..BenchRow::default()
        }
    }

    /// The row on `threads` threads: build, camera rays and shadow rays timed, each beside
    /// Embree's when compared.
    fn timed_row(&self, threads: usize, args: &BenchArgs, s: &RenderSettings) -> Result<BenchRow> {
        let mut row = self.row(threads, s);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        // Embree's side is built first and its rays are timed in turn with antumbra's
        // (antumbra, Embree, antumbra, ...), so the two best times come from the same spells of
        // a noisy machine and their ratio means something.
        let reference = match &args.compare {
            Some(_) => Some(Reference::build(
                &args.embree_quality,
                &self.trees.geometry().camera.vertices,
                threads,
                args.repeat,
            )?),
            None => None,
        };
        pool.install(|| {
            row.build_ms = best_of(args.repeat, || {
                build_binned_sah(&self.trees.geometry().camera.vertices, &s.build_settings)
            });
            let (ms, reference_ms) = self.time_primary(args.repeat, reference.as_ref());
            row.primary_mrays = mrays(self.primary_rays, ms);
            row.embree_primary_mrays = reference_ms.map(|ms| mrays(self.primary_rays, ms));
            let (ms, reference_ms) = self.time_shadow(args.repeat, reference.as_ref());
            row.shadow_mrays = mrays(self.shadow.len(), ms);
            row.embree_shadow_mrays = reference_ms.map(|ms| mrays(self.shadow.len(), ms));
            if let Some(r) = &reference {
                row.embree_build_ms = Some(r.build_ms);
                row.embree_agreement = Some(self.agreement(r));
            }
        });
        Ok(row)
    }

    /// Best ms of the camera rays' closest hits, ours and the reference's.
    fn time_primary(&self, repeat: u32, reference: Option<&Reference>) -> (f64, Option<f64>) {
        let tree = self.trees.camera();
        best_of_in_turn(
            repeat,
            || {
                // A tile's rays as one batch of the query face, into buffers per thread.
                self.primary.par_iter().for_each_init(
                    || (Vec::new(), Vec::new()),
                    |(hits, none), rays| {
                        hits.resize(rays.len(), None);
                        none.resize(rays.len(), NoStats);
                        tree.closest_hit_batch(rays, hits, none);
                        std::hint::black_box(hits);
                    },
                )
            },
            reference.map(|r| {
                || {
                    self.primary
                        .par_iter()
                        .for_each(|rays| rays.iter().for_each(|ray| r.intersect(ray)))
                }
            }),
        )
    }

    /// Best ms of every light's shadow rays, ours light by light in its order, and the
    /// reference's on the same rays.
    fn time_shadow(&self, repeat: u32, reference: Option<&Reference>) -> (f64, Option<f64>) {
        best_of_in_turn(
            repeat,
            || {
                for light in &self.lights {
                    let tracer = light.tracing.tracer(antumbra_core::trace::RayMode::Single);
                    light.batches.par_iter().for_each_init(
                        || (Vec::new(), Vec::new()),
                        |(answers, none), rays| {
                            answers.resize(rays.len(), false);
                            none.resize(rays.len(), NoStats);
                            tracer.occluded_batch(rays, answers, none);
                            std::hint::black_box(answers);
                        },
                    )
                }
            },
            reference.map(|r| {
                || {
                    self.shadow.par_iter().with_min_len(CHUNK).for_each(|ray| {
                        std::hint::black_box(r.occluded(ray));
                    })
                }
            }),
        )
    }

    /// The share of shadow rays the reference answers as antumbra does.
    fn agreement(&self, reference: &Reference) -> f64 {
        let agree = self
            .shadow
            .par_iter()
            .zip(&self.answers)
            .filter(|(ray, a)| reference.occluded(ray) == **a)
            .count();
        agree as f64 / self.shadow.len().max(1) as f64
    }
}

/// Every pixel's camera ray, row by row.
/// Builder / width / order; the collapse is named when it is not the default, e.g.
/// `sah/bin8:sah/sorted`.
fn method_name(s: &RenderSettings) -> String {
    let collapsed = if s.collapse.method == CollapseSettings::default().method {
        String::new()
    } else {
        format!(":{}", s.collapse.method)
    };
    format!("sah/bin{}{collapsed}/{}", s.width, s.shadow_order)
}

fn print_table(rows: &[BenchRow]) {
    let embree = rows.iter().any(|r| r.embree_build_ms.is_some());
    print!(
        "{:<16} {:>5} {:>9} {:>3} {:>9} {:>9} {:>8} {:>8} {:>7} | {} | {}",
        "scene",
        "frame",
        "tris",
        "thr",
        "build ms",
        "MB",
        "prim Mr/s",
        "shad Mr/s",
        "occl",
        work_header("prim"),
        work_header("shad")
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
            "{:<16} {:>5} {:>9} {:>3} {:>9.1} {:>9.1} {:>8.2} {:>8.2} {:>6.1}% | {} | {}",
            r.scene,
            r.frame,
            r.triangles,
            r.threads,
            r.build_ms,
            r.bvh_bytes as f64 / 1e6,
            r.primary_mrays,
            r.shadow_mrays,
            r.shadow_occluded * 100.0,
            work_cells(&r.primary_work),
            work_cells(&r.shadow_work)
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
    println!("{WORK_LEGEND}");
    if embree {
        println!("build x = antumbra build / Embree build (quality per --embree-quality, default medium); shad x = antumbra shadow Mrays/s / Embree rtcOccluded1 Mrays/s (same rays)");
    }
}

const WORK_LEGEND: &str = "work per ray, counted on the timed trees: N_B interior nodes entered, N_L leaves entered, N_T ray/triangle tests, N_box ray/box tests";

/// The work columns' names for one kind of pass.
fn work_header(pass: &str) -> String {
    ["N_B", "N_L", "N_T", "N_box"]
        .map(|c| format!("{:>10}", format!("{pass} {c}")))
        .join(" ")
}

fn work_cells(w: &PassWork) -> String {
    [w.nb_per_ray, w.nl_per_ray, w.nt_per_ray, w.nbox_per_ray]
        .map(|x| format!("{x:>10.2}"))
        .join(" ")
}
