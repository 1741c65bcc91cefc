//! `antumbra record`: frames of a built-in scene or file written as a recording (`.antrec`), the
//! form the daemon receives. The Blender add-on turns one into a `.blend`
//! (`blender_addon/make_blend.py`); `antumbra render --scene FILE.antrec` replays it.

use std::path::PathBuf;

use antumbra_protocol::RecordingWriter;
use anyhow::{Context, Result};
use clap::Args;

use crate::frames::{parse_frames, parse_size};
use crate::scene_source::open_scene;

#[derive(Args, Debug)]
pub struct RecordArgs {
    /// A built-in scene (bedroom, colonnade, city, forest, hairball; "-rot45" for the rotated
    /// variant) or an OBJ/glTF file.
    #[arg(long)]
    pub scene: String,
    /// Frames to record, "A-B" or "N" (default: the scene's whole range).
    #[arg(long)]
    pub frames: Option<String>,
    /// Image size WxH stored with each frame (default: the scene's resolution).
    #[arg(long)]
    pub size: Option<String>,
    /// Triangle budget of a built-in scene.
    #[arg(long, default_value_t = 100_000)]
    pub triangles: usize,
    /// The recording to write.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: RecordArgs) -> Result<()> {
    let frames = args.frames.as_deref().map(parse_frames).transpose()?;
    let size = args.size.as_deref().map(parse_size).transpose()?;
    let frame_count = frames.as_ref().map_or(24, |r| *r.end());
    let scene = open_scene(&args.scene, args.triangles, frame_count.max(1))?;
    let frames = frames.unwrap_or_else(|| scene.frame_range());
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Written beside the target and renamed, so a reader never sees half a recording.
    let partial = args.out.with_extension("antrec.partial");
    let mut writer = RecordingWriter::create(&partial)
        .with_context(|| format!("creating {}", partial.display()))?;
    let mut count = 0;
    for frame in frames {
        let mut s = scene.frame(frame);
        if let Some((w, h)) = size {
            s.resolution.x = w;
            s.resolution.y = h;
            s.resolution.percentage = 100;
        }
        writer
            .append_scene(&s)
            .with_context(|| format!("frame {frame}"))?;
        count += 1;
    }
    writer
        .finish()
        .with_context(|| format!("writing {}", partial.display()))?;
    std::fs::rename(&partial, &args.out)
        .with_context(|| format!("renaming to {}", args.out.display()))?;
    println!(
        "recorded {count} frames of {} to {}",
        scene.name(),
        args.out.display()
    );
    Ok(())
}
