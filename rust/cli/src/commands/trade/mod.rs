//! `antumbra trade`: sweeps each knob over its values, everything else fixed, on the same frames
//! and rays, and writes trade.csv, a Pareto plot per knob and trade.md (see `docs/trade.md`).
//! The sweeps are antumbra-core's ([`KnobSweep`]), the folder antumbra-report's ([`TradeFolder`]).

use std::collections::BTreeMap;
use std::path::PathBuf;

use antumbra_core::cancel::CancelToken;
use antumbra_core::image::ImagePlane;
use antumbra_core::trade::{
    knob_choices, KnobChoice, KnobKind, KnobSweep, Reference, TradeMismatch, TradeRow,
};
use antumbra_report::trade::{knob_texts, recommendations, TradeFolder, TradeRecord, TradeSetup};
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::method_args::MethodArgs;
use crate::scene_args::{frame_at_size, SceneArgs};

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
    let sweeps = choices
        .iter()
        .map(|(k, values)| KnobSweep::new(k, values.as_deref(), common, args.repeat))
        .collect::<Result<Vec<_>, _>>()?;
    let open = args.scene.open()?;
    let animation = open.animation.as_ref();
    let name = animation.name();
    let frames: Vec<_> = open
        .frames
        .clone()
        .map(|f| frame_at_size(animation, f, open.size))
        .collect();
    let bar = ProgressBar::new((frames.len() * sweeps.len()) as u64);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} knob frames {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("trade {name}"));
    let cancel = CancelToken::new();
    // Knob after knob, so that one knob's values hold their state at a time; the image knobs'
    // reference is rendered once per frame for them all.
    let mut references: Option<Vec<Vec<ImagePlane>>> = None;
    let mut records: BTreeMap<i32, (Vec<TradeRow>, Vec<TradeMismatch>)> = BTreeMap::new();
    for mut sweep in sweeps {
        let knob = sweep.knob();
        if knob.kind == KnobKind::Image && references.is_none() {
            let mut reference = Reference::of(sweep.default_value(), common)?;
            let masks = frames
                .iter()
                .map(|scene| {
                    reference
                        .masks(name, scene, &cancel)
                        .with_context(|| format!("reference, frame {}", scene.frame))
                })
                .collect::<Result<Vec<_>>>()?;
            references = Some(masks);
        }
        for (i, scene) in frames.iter().enumerate() {
            let reference = references.as_ref().map(|r| &r[i][..]);
            let done = sweep
                .frame(name, scene, reference, &cancel, &mut |_| {})
                .with_context(|| format!("knob '{}', frame {}", knob.name, scene.frame))?;
            let record = records.entry(scene.frame).or_default();
            record.0.extend(done.rows);
            record.1.extend(done.mismatches);
            bar.set_message(format!("{} frame {}", knob.name, scene.frame));
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let knobs = knob_texts(&args.knobs)?;
    let mut folder = TradeFolder::create(&args.out, TradeSetup::new(name, &knobs, args.repeat)?)?;
    for (frame, (rows, mismatches)) in records {
        folder.add(TradeRecord {
            frame,
            knobs: knobs.clone(),
            repeat: args.repeat,
            settings: common.clone(),
            rows,
            mismatches,
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
