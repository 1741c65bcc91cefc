//! `antumbra render`: frames of a scene to images, heat maps and statistics.

use std::path::{Path, PathBuf};

use antumbra_core::build::{
    BuildSettings, CollapseCost, CollapseMethod, CollapseSettings, SpatialAxes, SpatialSettings,
};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::render::{
    build_and_order, RenderSettings, Renderer, StatsMode, VisibilitySource,
};
use antumbra_core::scene::Animation;
use antumbra_core::stats::{write_csv, write_json, StatsRow};
use antumbra_core::trace::ShadowOrder;
use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::scene_args::{frame_at_size, SceneArgs};
use crate::write::write_frame;

/// Settings shared by `render` and `demo`.
#[derive(Args, Clone, Debug)]
pub struct MethodArgs {
    /// Shadow samples per pixel for soft lights (hard lights take one ray).
    #[arg(long, default_value_t = 4)]
    pub spp: u32,
    /// Seed of the light-sample patterns.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// BVH builder: sah, sbvh (spatial splits), abvh (spatial splits where visible triangles
    /// are), osah (occlusion heuristic), vsah (SAH over visible triangles only; a reference),
    /// or srdh (SAH for camera rays, an SRDH tree per light for shadow rays: --order srdh).
    #[arg(long, default_value = "sah")]
    pub build: String,
    /// Child order of shadow-ray traversal: stored | fbto (alias near) | sato | rtsah |
    /// random[:seed=S] | sorted[:logging=sato|fbto][:p=1|area][:depth=K][:budget=F]
    /// (sorted: per light, from a budget share F of its shadow rays; default budget=0.05) |
    /// srdh[:rays=WxH|all|F][:bins=B][:leaf=K][:kernels=all|constant|directional][:min_occluded=F]
    /// (a binary SRDH tree with traversal kernels per light whose representative rays, default a
    /// 16x16 grid of pixels, are at least min_occluded (0.5) occluded; others trace SAH fbto).
    /// Default: fbto (srdh with --build srdh).
    #[arg(long)]
    pub order: Option<ShadowOrder>,
    /// Children per BVH node: 2 (binary), 4 or 8 (collapsed, SIMD traversal).
    #[arg(long, default_value = "2")]
    pub width: BvhWidth,
    /// How widths 4 and 8 collapse the binary tree: greedy (open the largest child) or sah
    /// (the SAH-optimal slots and leaves).
    #[arg(long, default_value_t = CollapseSettings::default().method)]
    pub collapse: CollapseMethod,
    /// Largest leaf the sah collapse makes by merging binary leaves.
    #[arg(long, default_value_t = CollapseCost::default().max_leaf)]
    pub collapse_max_leaf: u32,
    /// Visible set of abvh/osah/vsah builds: previous (frame t-1), exact (frame t, two
    /// passes) or prepass:WxH (previous, with a WxH primary prepass on the first frame).
    #[arg(long, default_value = "previous")]
    pub visibility: VisibilitySource,
    /// OSAH weight w of visible triangles, in (0, 1).
    #[arg(long, default_value_t = BuildSettings::default().osah_weight)]
    pub osah_w: f32,
    /// OSAH viability as the paper states it (condition (5) alone); by default an OSAH split
    /// must also leave no visible triangle in its hidden child.
    #[arg(long)]
    pub osah_paper_viability: bool,
    /// Turn spatial splits off (sbvh/abvh/osah then split objects only).
    #[arg(long)]
    pub no_spatial_splits: bool,
    /// Spatial-split bins per axis.
    #[arg(long, default_value_t = SpatialSettings::default().bins)]
    pub spatial_bins: usize,
    /// Spatial splits only where object-split children overlap by more than this fraction of
    /// the root's area.
    #[arg(long, default_value_t = SpatialSettings::default().alpha)]
    pub split_alpha: f32,
    /// Spatial splits only where object-split children overlap by at least this fraction of
    /// the node's own area (Embree's gate; 0 tries every node that passes --split-alpha).
    #[arg(long, default_value_t = SpatialSettings::default().node_overlap)]
    pub split_node_overlap: f32,
    /// Nodes with fewer references than this never try spatial splits (0 tries every node).
    #[arg(long, default_value_t = SpatialSettings::default().min_refs)]
    pub split_min_refs: usize,
    /// Axes spatial splits are binned on: all, or object (the best object split's axis only).
    #[arg(long, default_value_t = SpatialSettings::default().axes)]
    pub spatial_axes: SpatialAxes,
    /// Nodes with fewer references than this bin spatial split candidates with each straddling
    /// reference's box cut at the bin planes instead of its triangle clipped (0 clips
    /// everywhere, as Stich et al.); the chosen split's partition always clips.
    #[arg(long, default_value_t = SpatialSettings::default().clip_min_refs)]
    pub clip_min_refs: usize,
    /// References may grow to (1 + this) x triangles through spatial splits.
    #[arg(long, default_value_t = SpatialSettings::default().max_growth)]
    pub max_growth: f32,
    /// Largest leaf of the BVH.
    #[arg(long, default_value_t = BuildSettings::default().max_leaf_size)]
    pub leaf_size: usize,
    /// Nodes of at most this many triangles become leaves without a split search (1 to
    /// --leaf-size): a faster build for larger leaves (Embree's minimum leaf size is 4).
    #[arg(long, default_value_t = BuildSettings::default().min_leaf_size)]
    pub min_leaf_size: usize,
    /// SAH bins per axis.
    #[arg(long, default_value_t = BuildSettings::default().bins)]
    pub bins: usize,
    /// Also time every pass with counters compiled out (Mrays/s without counting overhead).
    #[arg(long)]
    pub timing: bool,
}

impl MethodArgs {
    pub fn collapse_settings(&self) -> CollapseSettings {
        CollapseSettings {
            method: self.collapse,
            cost: CollapseCost {
                max_leaf: self.collapse_max_leaf,
                ..CollapseCost::default()
            },
        }
    }

    pub fn settings(&self) -> Result<RenderSettings> {
        let (build, shadow_order) = build_and_order(&self.build, self.order)?;
        Ok(RenderSettings {
            spp: self.spp,
            seed: self.seed,
            build,
            build_settings: BuildSettings {
                max_leaf_size: self.leaf_size,
                min_leaf_size: self.min_leaf_size,
                bins: self.bins,
                osah_weight: self.osah_w,
                osah_strict_viability: !self.osah_paper_viability,
                spatial: SpatialSettings {
                    enabled: !self.no_spatial_splits,
                    bins: self.spatial_bins,
                    alpha: self.split_alpha,
                    node_overlap: self.split_node_overlap,
                    min_refs: self.split_min_refs,
                    max_growth: self.max_growth,
                    axes: self.spatial_axes,
                    clip_min_refs: self.clip_min_refs,
                },
                ..BuildSettings::default()
            },
            shadow_order,
            width: self.width,
            collapse: self.collapse_settings(),
            stats: if self.timing {
                StatsMode::CountsAndTiming
            } else {
                StatsMode::Counts
            },
            visibility: self.visibility,
        })
    }
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: RenderArgs) -> Result<()> {
    let open = args.scene.open()?;
    let (scene, frames, size) = (open.animation, open.frames, open.size);
    let rows = render_frames(
        scene.as_ref(),
        frames,
        size,
        &args.method.settings()?,
        &args.out,
    )?;
    println!(
        "wrote {} frames, {} statistics rows to {}",
        rows.iter()
            .map(|r| r.frame)
            .collect::<std::collections::BTreeSet<_>>()
            .len(),
        rows.len(),
        args.out.display()
    );
    Ok(())
}

/// Renders `frames`, writing images per frame and the statistics of all frames into `out`.
pub fn render_frames(
    scene: &dyn Animation,
    frames: std::ops::RangeInclusive<i32>,
    size: Option<(u32, u32)>,
    settings: &RenderSettings,
    out: &Path,
) -> Result<Vec<StatsRow>> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let bar = ProgressBar::new(frames.clone().count() as u64);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} frames {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(scene.name().to_string());
    let mut renderer = Renderer::new();
    let mut rows = Vec::new();
    for frame in frames {
        let s = frame_at_size(scene, frame, size);
        let result = renderer
            .render(scene.name(), &s, settings)
            .with_context(|| format!("frame {frame}"))?;
        let scales = write_frame(out, &result).with_context(|| format!("writing frame {frame}"))?;
        if bar.is_hidden() {
            for r in &result.stats {
                println!(
                    "frame {} {:7} {:12} rays {:>9}  occluded {:5.1}%  N_B {:6.2} N_L {:5.2} N_T {:6.2} per ray",
                    r.frame, r.pass, r.light, r.rays, r.occluded_fraction * 100.0, r.nb_per_ray, r.nl_per_ray, r.nt_per_ray
                );
            }
            for s in scales {
                println!("frame {frame} heat map {s}");
            }
        }
        bar.set_message(format!("frame {frame}"));
        bar.inc(1);
        rows.extend(result.stats);
        // Tables are rewritten after every frame so an interrupted run keeps what it finished.
        write_csv(&out.join("stats.csv"), &rows)?;
        write_json(&out.join("stats.json"), &rows)?;
    }
    bar.finish();
    Ok(rows)
}
