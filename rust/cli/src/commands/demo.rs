//! `antumbra demo`: the main job without Blender.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use super::render::render_frames;
use crate::method_args::MethodArgs;
use crate::scene_args::OpenScene;
use crate::scene_source::open_scene;
use antumbra_protocol::Limits;

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Built-in scene to render.
    #[arg(long, default_value = "bedroom")]
    pub scene: String,
    /// Number of frames, from frame 1.
    #[arg(long, default_value_t = 4)]
    pub frames: i32,
    /// Triangle budget of the scene.
    #[arg(long, default_value_t = 100_000)]
    pub triangles: usize,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Output folder.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
}

pub fn run(args: DemoArgs) -> Result<()> {
    let frames = args.frames.max(1);
    let open = OpenScene {
        animation: open_scene(&args.scene, args.triangles, None, frames)?,
        frames: 1..=frames,
        size: None,
    };
    let mut settings = args.method.settings()?;
    settings.stats = antumbra_core::render::StatsMode::CountsAndTiming;
    let rows = render_frames(open, &settings, &args.out, &Limits::default())?;
    println!(
        "\n{:>5}  {:8} {:14} {:>9} {:>9} {:>9} {:>7} {:>7} {:>7}",
        "frame", "pass", "light", "rays", "Mrays/s", "occluded", "N_B", "N_L", "N_T"
    );
    for r in &rows {
        println!(
            "{:>5}  {:8} {:14} {:>9} {:>9.2} {:>8.1}% {:>7.2} {:>7.2} {:>7.2}",
            r.frame,
            r.pass,
            r.light,
            r.rays,
            r.mrays_per_s,
            r.occluded_fraction * 100.0,
            r.nb_per_ray,
            r.nl_per_ray,
            r.nt_per_ray
        );
    }
    println!(
        "\nimages, heat maps (frame_NNNN_*.png, frame_NNNN.exr) and stats.csv / stats.json in {}",
        args.out.display()
    );
    Ok(())
}
