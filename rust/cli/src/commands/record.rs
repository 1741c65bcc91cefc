//! `antumbra record`: frames of a built-in scene or file written as a recording (`.antrec`), the
//! form the daemon receives. The Blender add-on turns one into a `.blend`
//! (`blender_addon/make_blend.py`); `antumbra render --scene FILE.antrec` replays it.

use std::path::PathBuf;

use antumbra_core::atomic_file::AtomicFile;
use antumbra_protocol::RecordingWriter;
use anyhow::{Context, Result};
use clap::Args;

use crate::scene_args::SceneArgs;

#[derive(Args, Debug)]
pub struct RecordArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The recording to write.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn run(args: RecordArgs) -> Result<()> {
    let open = args.scene.open()?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Written beside the target and renamed, so a reader never sees half a recording.
    let file = AtomicFile::create(&args.out)?;
    let mut writer =
        RecordingWriter::new(file).with_context(|| format!("writing {}", args.out.display()))?;
    let mut count = 0;
    let name = open.animation.name().to_string();
    for s in open.into_frames() {
        let frame = s.frame;
        writer
            .append_scene(&s)
            .with_context(|| format!("frame {frame}"))?;
        count += 1;
    }
    writer
        .finish()
        .with_context(|| format!("writing {}", args.out.display()))?
        .commit()?;
    println!(
        "recorded {count} frames of {name} to {}",
        args.out.display()
    );
    Ok(())
}
