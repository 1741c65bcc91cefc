//! `antumbra bench --methods ...`: the OSAH paper's comparison (its Tables 3-4) on our scenes:
//! per scene and viewpoint (a built-in scene's paper viewpoints, or frames), build ms, references and traversal work (N_IT = triangle tests,
//! N_TS = nodes entered) and Mrays/s for primary and shadow rays, each build method beside SAH.
//! Visibility-driven builds get the exact visible set of the same primary rays, as in the paper.

use antumbra_core::build::{build_binned_sah, build_with_visibility, BuildMethod, BuildSettings};
use antumbra_core::bvh::Bvh;
use antumbra_core::cancel::CancelToken;
use antumbra_core::geometry::Ray;
use antumbra_core::render::{
    shadow_rays, visibility_flags, PrimaryPass, PrimaryRays, RenderSettings,
};
use antumbra_core::scene::{FrameGeometry, Resolution, Scene, TriangleRef, TriangleSet};
use antumbra_core::trace::{NoStats, RayQuery, TraversalStats};
use anyhow::{anyhow, Result};
use rayon::prelude::*;
use serde::Serialize;

use super::frames::BenchScene;
use super::reference::Reference;
use super::{best_of, print_json, timed, BenchArgs, SweepArgs};
use crate::scene_source::SceneKind;
use crate::shadow_lights::shadow_lights;

/// One method on one viewpoint.
#[derive(Debug, Default, Serialize)]
pub struct MethodRow {
    pub scene: String,
    /// The viewpoint's name, or "frame N" for a frame's own camera.
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

/// Every variant on every viewpoint of every scene, printed as ratio tables or JSON.
pub(super) fn run(args: &BenchArgs, scenes: &[String], settings: &RenderSettings) -> Result<()> {
    let variants = Variants::new(&args.sweep, &settings.build_settings);
    let threads = rayon::current_num_threads();
    let embree_build =
        |tris: &[[glam::Vec3; 3]]| Reference::build_only(&args.embree_quality, tris, threads);
    let reference: Option<ReferenceBuild> = args.compare.as_ref().map(|_| &embree_build as _);
    let mut rows = Vec::new();
    for name in scenes {
        rows.extend(method_rows(name, args, settings, &variants, reference)?);
    }
    if args.json {
        print_json(&rows)
    } else {
        print_ratio_tables(&rows);
        Ok(())
    }
}

/// The variants measured: each method, and for visibility-driven ones each weight and
/// spatial-split switch.
struct Variants {
    methods: Vec<BuildMethod>,
    weights: Vec<f32>,
    spatial: Vec<bool>,
    settings: BuildSettings,
}

impl Variants {
    /// The sweeps asked for; a sweep not given takes the one value of its setting.
    fn new(sweep: &SweepArgs, settings: &BuildSettings) -> Self {
        Variants {
            methods: sweep.methods.clone(),
            weights: or_setting(&sweep.sweep_osah_w, settings.osah_weight),
            spatial: or_setting(&sweep.sweep_spatial_splits, settings.spatial.enabled),
            settings: *settings,
        }
    }

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

/// The values of a sweep, or the setting's one value when none are given.
fn or_setting<T: Copy>(list: &[T], value: T) -> Vec<T> {
    if list.is_empty() {
        vec![value]
    } else {
        list.to_vec()
    }
}

/// A reference builder timed beside each method (`--compare embree`): builds the triangles and
/// returns its build ms.
type ReferenceBuild<'a> = &'a dyn Fn(&[[glam::Vec3; 3]]) -> Result<f64>;

/// The animation length a built-in scene's paper viewpoints are defined on.
const VIEWPOINT_FRAMES: i32 = 24;

/// Measures every variant on every viewpoint of `scene_name`.
fn method_rows(
    scene_name: &str,
    args: &BenchArgs,
    settings: &RenderSettings,
    variants: &Variants,
    reference: Option<ReferenceBuild>,
) -> Result<Vec<MethodRow>> {
    let opened = BenchScene::open(
        scene_name,
        args.triangles,
        args.frames.as_deref(),
        VIEWPOINT_FRAMES,
    )?;
    let mut rows = Vec::new();
    for (camera_name, mut scene) in viewpoints(scene_name, &opened, args.triangles)? {
        scene.resolution = Resolution::new(args.size.width, args.size.height);
        let label = format!("{scene_name}/{camera_name}");
        let view = View::prepare(label, &scene, settings, &variants.settings)?;
        for (method, build) in variants.each() {
            let mut row = view.measure(method, &build, args.repeat, reference)?;
            row.scene = opened.animation.name().to_string();
            row.camera = camera_name.clone();
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The viewpoints of a scene, named: a built-in scene's paper viewpoints on its first frame
/// (unless `--frames` picks frames), else each frame measured with its own camera.
fn viewpoints(name: &str, opened: &BenchScene, triangles: usize) -> Result<Vec<(String, Scene)>> {
    let anim = opened.animation.as_ref();
    if opened.kind == SceneKind::Builtin && !opened.asked {
        let params = antumbra_scenes::SceneParams {
            triangles,
            frames: VIEWPOINT_FRAMES,
            ..Default::default()
        };
        let first = anim.frame(*anim.frame_range().start());
        return Ok(antumbra_scenes::viewpoints(name, &params)?
            .into_iter()
            .map(|(camera_name, camera)| {
                let scene = Scene {
                    camera,
                    ..first.clone()
                };
                (camera_name, scene)
            })
            .collect());
    }
    Ok(opened
        .frames
        .iter()
        .map(|&f| (format!("frame {f}"), anim.frame(f)))
        .collect())
}

/// One viewpoint: its geometry, camera rays, their visible set and the shadow rays of the SAH
/// reference pass, with the answers every method must give.
struct View {
    /// `scene/camera`, for errors.
    label: String,
    geometry: FrameGeometry,
    rays: PrimaryRays,
    reference: PrimaryPass,
    visible: usize,
    flags: Vec<bool>,
    shadow_flags: Vec<bool>,
    shadow: Vec<Ray>,
    shadow_answers: Vec<bool>,
}

impl View {
    fn prepare(
        label: String,
        scene: &antumbra_core::scene::Scene,
        s: &RenderSettings,
        build: &BuildSettings,
    ) -> Result<View> {
        let geometry = FrameGeometry::from_scene(scene)?;
        let set = &geometry.camera;
        let shadow_set = geometry.shadow.as_ref().unwrap_or(set);
        let rays = PrimaryRays::new(&scene.camera, &scene.resolution, &geometry.space);
        let sah = build_binned_sah(&set.vertices, build);
        let reference = PrimaryPass::trace::<NoStats>(&rays, &sah, set, &CancelToken::new())
            .expect("a new token is never cancelled");
        let visible = visible_refs(&reference, set);
        let shadow: Vec<Ray> = shadow_lights(scene, &geometry.space, s.spp, s.seed)
            .iter()
            .flat_map(|l| shadow_rays(&reference, &l.sampler, l.plan))
            .collect();
        let shadow_sah = build_binned_sah(&shadow_set.vertices, build);
        let shadow_answers = shadow
            .par_iter()
            .map(|r| shadow_sah.occluded(r, &mut NoStats))
            .collect();
        Ok(View {
            label,
            flags: visibility_flags(set, &visible),
            shadow_flags: visibility_flags(shadow_set, &visible),
            visible: visible.len(),
            geometry,
            rays,
            reference,
            shadow,
            shadow_answers,
        })
    }

    fn camera_set(&self) -> &TriangleSet {
        &self.geometry.camera
    }

    /// One variant's row: its build timed (beside the reference's), its primary work and,
    /// when the tree answers every ray, its shadow work.
    fn measure(
        &self,
        method: BuildMethod,
        s: &BuildSettings,
        repeat: u32,
        reference: Option<ReferenceBuild>,
    ) -> Result<MethodRow> {
        let set = self.camera_set();
        let build =
            |tris: &[[glam::Vec3; 3]], f: &[bool]| build_with_visibility(method, tris, Some(f), s);
        let (bvh, build_ms, reference_build_ms) =
            timed_builds(repeat, || build(&set.vertices, &self.flags), reference, set)?;
        let mut row = MethodRow {
            method: method.name().to_string(),
            osah_w: s.osah_weight,
            spatial_splits: s.spatial.enabled,
            min_leaf_size: s.min_leaf_size,
            triangles: set.len(),
            visible: self.visible,
            references: bvh.triangles.len(),
            bvh_bytes: bvh.bytes(),
            build_ms,
            reference_build_ms,
            ..MethodRow::default()
        };
        self.primary_work(&bvh, repeat, &mut row)
            .map_err(|what| anyhow!("{}: {method:?} changed {what}", self.label))?;
        // VSAH is complete only for the primary rays its set came from.
        if method.is_complete() && !self.shadow.is_empty() {
            let shadow_bvh_owned;
            let shadow_bvh = match &self.geometry.shadow {
                Some(s) => {
                    shadow_bvh_owned = build(&s.vertices, &self.shadow_flags);
                    &shadow_bvh_owned
                }
                None => &bvh,
            };
            self.shadow_work(shadow_bvh, repeat, &mut row)
                .map_err(|what| anyhow!("{}: {method:?} changed {what}", self.label))?;
        }
        Ok(row)
    }

    /// Primary N_IT, N_TS and Mrays/s of `bvh`; what differs if a hit differs from SAH's.
    fn primary_work(&self, bvh: &Bvh, repeat: u32, row: &mut MethodRow) -> Result<(), &str> {
        let set = self.camera_set();
        let counted =
            PrimaryPass::trace::<TraversalStats>(&self.rays, bvh, set, &CancelToken::new())
                .expect("a new token is never cancelled");
        if counted.surfaces != self.reference.surfaces {
            return Err("primary hits");
        }
        let ms = best_of(repeat, || {
            std::hint::black_box(
                PrimaryPass::trace::<NoStats>(&self.rays, bvh, set, &CancelToken::new())
                    .expect("a new token is never cancelled"),
            );
        });
        let n = counted.surfaces.len().max(1) as f64;
        let t = counted.totals;
        row.primary_nit = t.triangles as f64 / n;
        row.primary_nts = (t.inner + t.leaves) as f64 / n;
        row.primary_mrays = counted.surfaces.len() as f64 / (ms * 1e3);
        Ok(())
    }

    /// Shadow N_IT, N_TS and Mrays/s of `bvh` (front to back); what differs if an answer
    /// differs from SAH's.
    fn shadow_work(&self, bvh: &Bvh, repeat: u32, row: &mut MethodRow) -> Result<(), &str> {
        let (work, answers) = self
            .shadow
            .par_iter()
            .map(|r| {
                let mut w = TraversalStats::default();
                let a = bvh.occluded(r, &mut w);
                (w, a)
            })
            .collect::<(Vec<_>, Vec<_>)>();
        if answers != self.shadow_answers {
            return Err("shadow answers");
        }
        let mut total = TraversalStats::default();
        for w in work {
            total += w;
        }
        let ms = best_of(repeat, || {
            self.shadow.par_iter().with_min_len(256).for_each(|r| {
                std::hint::black_box(bvh.occluded(r, &mut NoStats));
            })
        });
        let s = self.shadow.len() as f64;
        row.shadow_nit = total.triangles as f64 / s;
        row.shadow_nts = (total.inner + total.leaves) as f64 / s;
        row.shadow_mrays = s / (ms * 1e3);
        Ok(())
    }
}

/// The last tree of `repeat` timed builds, their best ms and the reference's best ms (when
/// given: its builds alternate with these, so both see the same machine; wall clock drifts by
/// tens of percent within a minute on small VMs).
fn timed_builds(
    repeat: u32,
    mut build: impl FnMut() -> Bvh,
    reference: Option<ReferenceBuild>,
    set: &TriangleSet,
) -> Result<(Bvh, f64, Option<f64>)> {
    // Each build is followed by a pause: Embree's TBB workers (and rayon's) spin for a while
    // after a build and would otherwise take cores from the next one.
    let settle = || std::thread::sleep(std::time::Duration::from_millis(300));
    let mut bvh = Bvh::default();
    let (mut build_ms, mut reference_ms) = (f64::INFINITY, reference.map(|_| f64::INFINITY));
    for _ in 0..repeat.max(1) {
        // The previous tree is dropped after the clock stops.
        let (built, ms) = timed(&mut build);
        build_ms = build_ms.min(ms);
        bvh = built;
        if let (Some(build_reference), Some(best)) = (reference, &mut reference_ms) {
            settle();
            *best = best.min(build_reference(&set.vertices)?);
            settle();
        }
    }
    Ok((bvh, build_ms, reference_ms))
}

/// The sorted camera-set triangles the reference pass hit.
fn visible_refs(pass: &PrimaryPass, set: &TriangleSet) -> Vec<TriangleRef> {
    let mut v: Vec<TriangleRef> = pass
        .surfaces
        .iter()
        .flatten()
        .map(|s| set.refs[s.triangle as usize])
        .collect();
    v.sort_unstable();
    v.dedup();
    v
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
