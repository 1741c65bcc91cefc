//! `antumbra trade`: sweeps each knob over its values, everything else fixed, on the same frames
//! and rays, and writes trade.csv, a Pareto plot per knob and trade.md (see `docs/trade.md`).

mod report;
mod sweep;

use std::path::PathBuf;

use antumbra_core::trade::{parse_knob_arg, Knob, KNOBS};
use anyhow::{bail, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::method_args::MethodArgs;
use crate::scene_args::{frame_at_size, SceneArgs};
use report::{KnobReport, RunInfo};
use sweep::Sweeps;

#[derive(Args, Debug)]
pub struct TradeArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// A knob to sweep, NAME or NAME=V1,V2,... (its own values); repeat for more. Default:
    /// every knob (see docs/trade.md for the list).
    #[arg(long = "knob", value_name = "NAME[=VALUES]", value_parser = parse_knob)]
    pub knobs: Vec<KnobArg>,
    /// Timed passes per value and frame, interleaved across a knob's values.
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Output folder: trade.csv, trade.md, plots/KNOB.svg and .png.
    #[arg(long)]
    pub out: PathBuf,
    /// Settings every value shares (a knob's base method and value win), e.g. `--seed 3`.
    #[command(flatten)]
    pub common: MethodArgs,
}

/// A knob as `--knob` names it, with the values given (if any).
#[derive(Clone, Debug)]
pub struct KnobArg {
    pub knob: &'static Knob,
    pub values: Option<Vec<String>>,
}

fn parse_knob(text: &str) -> Result<KnobArg, String> {
    parse_knob_arg(text)
        .map(|(knob, values)| KnobArg { knob, values })
        .map_err(|e| e.to_string())
}

pub fn run(args: TradeArgs) -> Result<()> {
    let knobs: Vec<KnobArg> = if args.knobs.is_empty() {
        KNOBS
            .iter()
            .map(|knob| KnobArg { knob, values: None })
            .collect()
    } else {
        args.knobs.clone()
    };
    let common = &args.common.named;
    // Every value checked before the first frame is rendered.
    let sweeps = knobs
        .iter()
        .map(|k| Ok((k.knob, k.knob.sweep(k.values.as_deref(), common)?)))
        .collect::<Result<Vec<_>>>()?;
    let open = args.scene.open()?;
    let animation = open.animation.as_ref();
    let frames: Vec<_> = open
        .frames
        .clone()
        .map(|f| frame_at_size(animation, f, open.size))
        .collect();
    let mut runner = Sweeps::new(animation.name(), &frames, common, args.repeat);
    let bar = ProgressBar::new((frames.len() * sweeps.len()) as u64);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} knob frames {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("trade {}", animation.name()));
    let (mut rows, mut mismatches) = (Vec::new(), Vec::new());
    for (knob, values) in &sweeps {
        let mut progress = |frame: i32| {
            bar.set_message(format!("{} frame {frame}", knob.name));
            bar.inc(1);
        };
        let sweep = runner.run(knob, values, &mut progress)?;
        rows.extend(sweep.rows);
        mismatches.extend(
            sweep
                .mismatches
                .into_iter()
                .map(|m| format!("knob '{}': {m}", knob.name)),
        );
    }
    bar.finish_and_clear();
    let reports: Vec<KnobReport> = sweeps
        .iter()
        .map(|(knob, _)| KnobReport::of(knob, &rows))
        .collect();
    let size = frames
        .first()
        .map(|s| {
            let (w, h) = s.resolution.pixels();
            format!("{w}x{h}")
        })
        .unwrap_or_default();
    let info = RunInfo {
        scene: animation.name(),
        frames: format!("{}-{}", open.frames.start(), open.frames.end()),
        size,
        repeat: args.repeat,
        common: common
            .0
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(", "),
    };
    report::write(&args.out, &info, &reports, &rows)?;
    println!("{}", report::recommendations(&reports).plain());
    println!("wrote {}", args.out.display());
    if !mismatches.is_empty() {
        bail!(
            "{} answers differ from the default value's:\n  {}",
            mismatches.len(),
            mismatches.join("\n  ")
        );
    }
    Ok(())
}
