//! `antumbra render`: frames of a scene to images, heat maps and statistics.

use std::path::{Path, PathBuf};

use antumbra_core::render::{RenderSettings, Renderer};
use antumbra_core::scene::{Animation, ImageSize};
use antumbra_core::stats::{write_csv, write_json, StatsRow};
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
    size: Option<ImageSize>,
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
