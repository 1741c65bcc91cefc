//! `antumbra bench`'s main table: per scene and frame, SAH build time, Mrays/s and work per ray
//! on exactly the rays a frame traces (camera rays, then every light's shadow rays in its
//! order), on one thread and on all, optionally beside each of Embree's calls timed in turn on
//! the same rays in the same tiles. The trees and orders are the renderer's own (a warm-up's
//! `FrameTrees`): one pipeline; the rays go tile by tile, one batch of the query face per tile.

use antumbra_core::build::{build_binned_sah, CollapseSettings};
use antumbra_core::cancel::CancelToken;
use antumbra_core::order::ShadowOrder;
use antumbra_core::render::{
    pass_rays, CameraTree, FrameTrees, LightRays, LightTracing, PrimaryPass, PrimaryRays,
    RenderSettings, Renderer,
};
use antumbra_core::scene::{Animation, Resolution};
use antumbra_core::stats::StatsRow;
use antumbra_core::trace::{NoStats, RayMode, RayQuery, TraversalStats};
use anyhow::Result;
use rayon::prelude::*;
use serde::Serialize;

use super::frames::BenchScene;
use super::kernels::{print_kernel_table, time_in_turn, Answers, KernelRow};
use super::reference::Reference;
use super::tiles::TiledRays;
use super::{bench_order, best_of, mrays, print_json, BenchArgs};
use crate::shadow_lights::{shadow_lights, ShadowLight};

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
    pub prepare_ms_per_light: Vec<f64>,
    /// `srdh`: bytes of the lights' SRDH trees (0 for a light that traces the SAH tree).
    pub srdh_bytes_per_light: Vec<usize>,
    pub embree_build_ms: Option<f64>,
    pub embree_primary_mrays: Option<f64>,
    pub embree_shadow_mrays: Option<f64>,
    /// Shadow rays on which Embree (`rtcOccluded1`) and antumbra give the same occlusion answer.
    pub embree_agreement: Option<f64>,
    /// Each of Embree's calls on the same rays in the same tiles (empty without
    /// `--compare embree`), shadow rays first.
    pub embree_kernels: Vec<KernelRow>,
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
        if rows.iter().any(|r| !r.embree_kernels.is_empty()) {
            println!();
            print_kernel_table(rows.iter().map(|r| {
                let label = format!("{} {}", r.scene, r.frame);
                (label, r.threads, r.embree_kernels.as_slice())
            }));
        }
        Ok(())
    }
}

/// A frame's trees made as a render makes them (a warm-up: `FrameTrees`, the one pipeline), its
/// camera rays' hits and its shadow-casting lights.
pub(super) struct FrameState {
    pub scene: String,
    pub frame: i32,
    renderer: Renderer,
    pub camera: PrimaryRays,
    pub pass: PrimaryPass,
    pub lights: Vec<ShadowLight>,
}

impl FrameState {
    pub fn prepare(
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
            &trees.camera().traced_as(pass_rays(s)),
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

    pub fn trees(&self) -> &FrameTrees {
        self.renderer.trees().expect("prepared with its trees")
    }
}

/// One light's shadow rays in tiles and its tree and order, prepared as the renderer does.
struct LightRaysOf<'a> {
    rays: TiledRays,
    tracing: LightTracing<'a>,
}

/// One frame of a scene with its trees and rays, ready to be timed, and their counted work.
struct Frame<'a> {
    state: &'a FrameState,
    trees: &'a FrameTrees,
    primary: TiledRays,
    /// antumbra's closest hit of each camera ray (its triangle).
    primary_hits: Vec<Option<u32>>,
    lights: Vec<LightRaysOf<'a>>,
    /// Every light's tiles in turn, and antumbra's answer for each ray.
    shadow: TiledRays,
    answers: Vec<bool>,
    primary_work: TraversalStats,
    shadow_work: TraversalStats,
    /// Whether the lights trace SRDH trees of their own.
    srdh: bool,
    /// Single rays or packets, as a render with these settings traces them.
    rays: RayMode,
}

impl<'a> Frame<'a> {
    fn new(state: &'a FrameState, s: &RenderSettings) -> Frame<'a> {
        let trees = state.trees();
        let camera = &state.camera;
        let rays = pass_rays(s);
        // Counted on the tree the timed loop traces (the timed loop has no counters).
        let primary_work = PrimaryPass::trace::<TraversalStats>(
            camera,
            &trees.camera().traced_as(rays),
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
                    // The bench's trees are flat: only two levels read the objects.
                    objects: &[],
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
                    rays: TiledRays::shadow(&state.pass, light),
                    tracing,
                }
            })
            .collect();
        let mut shadow = TiledRays::default();
        for light in &lights {
            shadow.append(&light.rays);
        }
        let mut frame = Frame {
            state,
            trees,
            primary: TiledRays::camera(camera),
            primary_hits: Vec::new(),
            lights,
            shadow,
            answers: Vec::new(),
            primary_work,
            shadow_work: TraversalStats::default(),
            srdh: matches!(order, ShadowOrder::Srdh(_)),
            rays,
        };
        (frame.answers, frame.shadow_work) = frame.counted_occlusion();
        frame.primary_hits = frame.closest_triangles();
        frame
    }

    /// The triangle each camera ray hits first (untimed, for the disagreement counts).
    fn closest_triangles(&self) -> Vec<Option<u32>> {
        let tree = self.trees.camera().traced_as(self.rays);
        let per_tile: Vec<Vec<Option<u32>>> = self
            .primary
            .tile_rays()
            .map(|rays| {
                let mut hits = vec![None; rays.len()];
                tree.closest_hit_batch(rays, &mut hits, &mut vec![NoStats; rays.len()]);
                hits.iter().map(|h| h.map(|h| h.triangle)).collect()
            })
            .collect();
        per_tile.concat()
    }

    /// Every shadow ray's answer, and the work of all of them, counted.
    fn counted_occlusion(&self) -> (Vec<bool>, TraversalStats) {
        let mut answers = Vec::with_capacity(self.shadow.len());
        let mut total = TraversalStats::default();
        for light in &self.lights {
            let tracer = light.tracing.tracer(self.rays);
            let per_tile: Vec<(Vec<bool>, Vec<TraversalStats>)> = light
                .rays
                .tile_rays()
                .map(|rays| {
                    let mut a = vec![false; rays.len()];
                    let mut work = vec![TraversalStats::default(); rays.len()];
                    tracer.occluded_batch(rays, &mut a, &mut work);
                    (a, work)
                })
                .collect();
            for (a, work) in per_tile {
                answers.extend(a);
                for w in work {
                    total += w;
                }
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
            primary_rays: self.primary.len(),
            shadow_rays: self.shadow.len(),
            shadow_occluded: occluded as f64 / self.shadow.len().max(1) as f64,
            primary_work: PassWork::of(&self.primary_work, self.primary.len()),
            shadow_work: PassWork::of(&self.shadow_work, self.shadow.len()),
            collapse_ms,
            prepare_ms_per_light: self
                .lights
                .iter()
                .map(|l| l.tracing.prepare_ms)
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
    /// each of Embree's calls when compared.
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
            let (ms, camera_kernels) = self.time_primary(args.repeat, reference.as_ref());
            row.primary_mrays = mrays(self.primary.len(), ms);
            let (ms, shadow_kernels) = self.time_shadow(args.repeat, reference.as_ref());
            row.shadow_mrays = mrays(self.shadow.len(), ms);
            if let Some(r) = &reference {
                let single = |rows: &[KernelRow], name: &str| {
                    rows.iter().find(|k| k.kernel == name).map(|k| k.mrays)
                };
                row.embree_build_ms = Some(r.build_ms);
                row.embree_primary_mrays = single(&camera_kernels, "rtcIntersect1");
                row.embree_shadow_mrays = single(&shadow_kernels, "rtcOccluded1");
                row.embree_agreement = Some(self.agreement(r));
                row.embree_kernels = [shadow_kernels, camera_kernels].concat();
            }
        });
        Ok(row)
    }

    /// antumbra's camera rays tile by tile, one batch of the query face per tile into a
    /// buffer per thread.
    fn trace_primary(&self) {
        let tree = self.trees.camera().traced_as(self.rays);
        self.primary.tile_rays().for_each_init(
            || (Vec::new(), Vec::new()),
            |(hits, none), rays| {
                hits.resize(rays.len(), None);
                none.resize(rays.len(), NoStats);
                tree.closest_hit_batch(rays, hits, none);
                std::hint::black_box(hits);
            },
        )
    }

    /// antumbra's shadow rays light by light in its order, tile by tile.
    fn trace_shadow(&self) {
        for light in &self.lights {
            let tracer = light.tracing.tracer(self.rays);
            light.rays.tile_rays().for_each_init(
                || (Vec::new(), Vec::new()),
                |(answers, none), rays| {
                    answers.resize(rays.len(), false);
                    none.resize(rays.len(), NoStats);
                    tracer.occluded_batch(rays, answers, none);
                    std::hint::black_box(answers);
                },
            )
        }
    }

    /// Best ms of the camera rays' closest hits, and each of the reference's calls' row.
    fn time_primary(&self, repeat: u32, reference: Option<&Reference>) -> (f64, Vec<KernelRow>) {
        match reference {
            Some(r) => {
                let answers = Answers::Triangles(&self.primary_hits);
                time_in_turn(r, &self.primary, answers, repeat, || self.trace_primary())
            }
            None => (best_of(repeat, || self.trace_primary()), Vec::new()),
        }
    }

    /// Best ms of every light's shadow rays, ours light by light in its order, and each of the
    /// reference's calls' row on the same rays in the same tiles.
    fn time_shadow(&self, repeat: u32, reference: Option<&Reference>) -> (f64, Vec<KernelRow>) {
        match reference {
            Some(r) => {
                let answers = Answers::Occluded(&self.answers);
                time_in_turn(r, &self.shadow, answers, repeat, || self.trace_shadow())
            }
            None => (best_of(repeat, || self.trace_shadow()), Vec::new()),
        }
    }

    /// The share of shadow rays the reference answers as antumbra does.
    fn agreement(&self, reference: &Reference) -> f64 {
        let agree = self
            .shadow
            .rays
            .par_iter()
            .zip(&self.answers)
            .filter(|(ray, a)| reference.occluded(ray) == **a)
            .count();
        agree as f64 / self.shadow.len().max(1) as f64
    }
}

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
        println!("build x = antumbra build / Embree build (quality per --embree-quality, default medium); shad x = antumbra shadow Mrays/s / Embree rtcOccluded1 Mrays/s (same rays); agree = shadow rays rtcOccluded1 answers as antumbra");
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
