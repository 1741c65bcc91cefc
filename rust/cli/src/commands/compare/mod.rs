//! `antumbra compare`: several methods on the same frames of any scene (built-in, OBJ/glTF, a
//! recording), their answers checked against the baseline's, their work counted and their time
//! measured fairly, written as one report folder (see `docs/compare.md`).

use std::path::PathBuf;

use antumbra_core::compare::{default_methods, Comparison, MethodSpec};
use antumbra_core::scene::Scene;
use antumbra_protocol::{admit_compare, Asked};
use antumbra_report::{ComparedFrame, ReportFolder, ReportSetup};
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use crate::admission_args::{frame_count, frames_text, refused, AdmissionArgs};
use crate::method_args::MethodArgs;
use crate::scene_args::SceneArgs;

#[derive(Args, Debug)]
pub struct CompareArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// A method, LABEL=NAME=VALUE,... with the settings' own names (docs/settings.md), e.g.
    /// `osah8=build=osah,visibility=previous,width=8,order=sorted`; repeat for more. Default:
    /// base (binary SAH, front to back), sato8, sorted8, osah8, srdh.
    #[arg(long = "method", value_name = "LABEL=SETTINGS", value_parser = parse_method)]
    pub methods: Vec<MethodSpec>,
    /// The label the others are checked and measured against (default: the first method).
    #[arg(long)]
    pub baseline: Option<String>,
    /// Timed passes per method and frame, interleaved across methods.
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Output folder: compare.csv, compare.json, summary.md, report.html, plots/, diff/, frames/.
    #[arg(long)]
    pub out: PathBuf,
    /// Settings every method shares (a method's own settings win), e.g. `--spp 16`.
    #[command(flatten)]
    pub common: MethodArgs,
    #[command(flatten)]
    pub admission: AdmissionArgs,
}

fn parse_method(text: &str) -> Result<MethodSpec, String> {
    text.parse()
        .map_err(|e: antumbra_core::Error| e.to_string())
}

pub fn run(args: CompareArgs) -> Result<()> {
    let specs = if args.methods.is_empty() {
        default_methods()
    } else {
        args.methods.clone()
    };
    let mut comparison = Comparison::new(
        &specs,
        &args.common.named,
        args.baseline.as_deref(),
        args.repeat,
    )?;
    let open = args.scene.open()?;
    let name = open.animation.name().to_string();
    let count = frame_count(&open.frames);
    let (what, limits) = (
        format!("compare of {}", frames_text(&open.frames)),
        args.admission.limits(),
    );
    // As the daemon admits a Compare, the whole run counted: its frames' passes, and each
    // frame's memory (the difference image of each method copied out).
    let admit = |scene: &Scene, comparison: &Comparison| {
        let asked = Asked {
            what: &what,
            scene,
            frames: count,
        };
        admit_compare(asked, comparison, true, &limits).map_err(refused)
    };
    // The first frame (built once, then compared) admits the run; the last takes the scene's
    // objects (`OpenScene::into_frames`).
    let mut scenes = open.into_frames().peekable();
    if let Some(first) = scenes.peek() {
        admit(first, &comparison)?;
    }
    // Every frame is compared anew, so frames recorded there by an earlier run are dropped.
    let mut folder = ReportFolder::create(&args.out, ReportSetup::of(&name, &comparison))?;
    let bar = ProgressBar::new(count);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} frames {msg}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("compare {name}"));
    for scene in scenes {
        let frame = scene.frame;
        admit(&scene, &comparison)?;
        let result = comparison
            .frame(&name, &scene)
            .with_context(|| format!("frame {frame}"))?;
        folder.add(ComparedFrame::of(&comparison, result))?;
        bar.set_message(format!("frame {frame}"));
        bar.inc(1);
    }
    bar.finish_and_clear();
    folder.write()?;
    println!("{}", folder.terminal_table()?);
    println!("wrote {}", args.out.display());
    let mismatches: Vec<_> = folder.mismatches().filter(|m| m.is_wrong()).collect();
    if !mismatches.is_empty() {
        let lines: Vec<String> = mismatches.iter().take(20).map(|m| m.to_string()).collect();
        bail!(
            "{} answers differ from the baseline '{}':\n  {}{}",
            mismatches.len(),
            comparison.baseline(),
            lines.join("\n  "),
            if mismatches.len() > 20 { "\n  ..." } else { "" }
        );
    }
    Ok(())
}
