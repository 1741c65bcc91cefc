//! `antumbra render`: frames of a scene to images, heat maps and statistics.

use std::path::{Path, PathBuf};

use antumbra_core::render::{all_output_planes, RenderSettings, Renderer};
use antumbra_core::stats::{write_csv, write_json, StatsRow};
use antumbra_protocol::{admit_render, Asked, Limits};
use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::admission_args::{frame_count, frames_text, refused, AdmissionArgs};
use crate::method_args::MethodArgs;
use crate::scene_args::{OpenScene, SceneArgs};
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
    #[command(flatten)]
    pub admission: AdmissionArgs,
}

pub fn run(args: RenderArgs) -> Result<()> {
    let rows = render_frames(
        args.scene.open()?,
        &args.method.settings()?,
        &args.out,
        &args.admission.limits(),
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

/// Renders the frames of `open`, writing images per frame and the statistics of all frames
/// into `out`. A run or a frame the daemon would refuse under `limits` (too many frames, a
/// frame estimated to need more memory than the budget) stops before that frame is rendered.
pub fn render_frames(
    open: OpenScene,
    settings: &RenderSettings,
    out: &Path,
    limits: &Limits,
) -> Result<Vec<StatsRow>> {
    let what = format!("render of {}", frames_text(&open.frames));
    let count = frame_count(&open.frames);
    let name = open.animation.name().to_string();
    let admit = |s: &antumbra_core::scene::Scene| {
        let asked = Asked {
            what: &what,
            scene: s,
            frames: count,
        };
        admit_render(asked, settings, all_output_planes(s, settings), limits).map_err(refused)
    };
    // The run as a whole first, on the first frame (built once, then rendered): nothing is
    // written for a run that is refused.
    let mut scenes = open.into_frames().peekable();
    if let Some(first) = scenes.peek() {
        admit(first)?;
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let bar = ProgressBar::new(count);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} frames {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(name.clone());
    let mut renderer = Renderer::new();
    let mut rows = Vec::new();
    for s in scenes {
        let frame = s.frame;
        admit(&s)?;
        let result = renderer
            .render(&name, &s, settings)
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
