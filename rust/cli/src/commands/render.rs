//! `antumbra render`: frames of a scene to images, heat maps and statistics.

use std::path::{Path, PathBuf};

use antumbra_core::render::{all_output_planes, RenderSettings, Renderer};
use antumbra_core::scene::{Animation, ImageSize};
use antumbra_core::stats::{write_csv, write_json, StatsRow};
use antumbra_protocol::{check_render_memory, Limits, DEFAULT_MAX_RENDER_BYTES};
use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::method_args::MethodArgs;
use crate::scene_args::{frame_at_size, SceneArgs};
use crate::write::write_frame;

#[derive(Args, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Memory one frame may need at its peak, in MiB, estimated before it is rendered; a bigger
    /// frame stops the run with an error (as the daemon refuses it).
    #[arg(long, default_value_t = DEFAULT_MAX_RENDER_BYTES >> 20)]
    pub render_memory_mb: u64,
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
        args.render_memory_mb.saturating_mul(1 << 20),
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

/// Renders `frames`, writing images per frame and the statistics of all frames into `out`. A
/// frame estimated to need more than `memory_budget` bytes stops the run before it is rendered.
pub fn render_frames(
    scene: &dyn Animation,
    frames: std::ops::RangeInclusive<i32>,
    size: Option<ImageSize>,
    settings: &RenderSettings,
    out: &Path,
    memory_budget: u64,
) -> Result<Vec<StatsRow>> {
    let limits = Limits {
        max_render_bytes: memory_budget,
        ..Limits::default()
    };
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
        check_render_memory(&s, settings, all_output_planes(&s, settings), &limits)
            .map_err(|e| anyhow::anyhow!("{e}; --render-memory-mb sets the budget"))?;
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
