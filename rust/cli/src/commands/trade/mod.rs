//! `antumbra trade`: sweeps each knob over its values, everything else fixed, on the same frames
//! and rays, and writes trade.csv, a Pareto plot per knob and trade.md (see `docs/trade.md`).
//! The sweeps are antumbra-core's ([`Trade`], as the daemon's `Trade`), the folder
//! antumbra-report's ([`TradeFolder`]).

use std::path::PathBuf;

use antumbra_core::cancel::CancelToken;
use antumbra_core::trade::{knob_choices, KnobChoice, Trade};
use antumbra_protocol::{admit_trade, Asked};
use antumbra_report::trade::{knob_texts, recommendations, TradeFolder, TradeRecord, TradeSetup};
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::admission_args::{frame_count, frames_text, refused, AdmissionArgs};
use crate::method_args::MethodArgs;
use crate::scene_args::SceneArgs;

#[derive(Args, Debug)]
pub struct TradeArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// A knob to sweep, NAME or NAME=V1,V2,... (its own values); repeat for more. Default:
    /// every knob (see docs/trade.md for the list).
    #[arg(long = "knob", value_name = "NAME[=VALUES]", value_parser = parse_knob)]
    pub knobs: Vec<String>,
    /// Timed passes per value and frame, interleaved across a knob's values.
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Output folder: trade.csv, trade.md, plots/KNOB.svg and .png.
    #[arg(long)]
    pub out: PathBuf,
    /// Settings every value shares (a knob's base method and value win), e.g. `--seed 3`.
    #[command(flatten)]
    pub common: MethodArgs,
    #[command(flatten)]
    pub admission: AdmissionArgs,
}

/// `--knob`'s text, checked when the arguments are read.
fn parse_knob(text: &str) -> Result<String, String> {
    knob_choices(&[text]).map_err(|e| e.to_string())?;
    Ok(text.to_string())
}

pub fn run(args: TradeArgs) -> Result<()> {
    let choices: Vec<KnobChoice> = knob_choices(&args.knobs)?;
    let common = &args.common.named;
    // Every value checked before the first frame is rendered.
    let mut trade = Trade::new(&choices, common, args.repeat)?;
    let open = args.scene.open()?;
    let name = open.animation.name().to_string();
    let count = frame_count(&open.frames);
    let (what, limits) = (
        format!("trade of {}", frames_text(&open.frames)),
        args.admission.limits(),
    );
    // As the daemon admits a Trade, the whole run counted: its frames' passes, and each
    // frame's memory (every knob value's state and the reference's together).
    let admit = |scene: &antumbra_core::scene::Scene, trade: &Trade| {
        let asked = Asked {
            what: &what,
            scene,
            frames: count,
        };
        admit_trade(asked, trade, &limits).map_err(refused)
    };
    // The first frame (built once, then traded) admits the run; the last takes the scene's
    // objects (`OpenScene::into_frames`).
    let mut scenes = open.into_frames().peekable();
    if let Some(first) = scenes.peek() {
        admit(first, &trade)?;
    }
    let bar = ProgressBar::new(count);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} frames {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("trade {name}"));
    let cancel = CancelToken::new();
    // Frame by frame, every knob on each (as a daemon session runs a Trade), so that one
    // frame's scene and reference are held at a time.
    let mut records = Vec::new();
    for scene in scenes {
        let frame = scene.frame;
        admit(&scene, &trade)?;
        let done = trade
            .frame(&name, &scene, &cancel, &mut |_| {})
            .with_context(|| format!("frame {frame}"))?;
        records.push(done);
        bar.set_message(format!("frame {frame}"));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let knobs = knob_texts(&args.knobs)?;
    let mut folder = TradeFolder::create(&args.out, TradeSetup::new(&name, &knobs, args.repeat)?)?;
    for done in records {
        folder.add(TradeRecord {
            frame: done.frame,
            knobs: knobs.clone(),
            repeat: args.repeat,
            settings: common.clone(),
            rows: done.rows,
            mismatches: done.mismatches,
        })?;
    }
    folder.write()?;
    println!("{}", recommendations(&folder.reports()?).plain());
    println!("wrote {}", args.out.display());
    let mismatches: Vec<String> = folder.mismatches().iter().map(|m| m.to_string()).collect();
    if !mismatches.is_empty() {
        bail!(
            "{} answers differ from the default value's:\n  {}",
            mismatches.len(),
            mismatches.join("\n  ")
        );
    }
    Ok(())
}
