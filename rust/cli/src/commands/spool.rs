//! `antumbra spool`: acting on a spool folder's jobs from the command line (see
//! `docs/daemon.md`, "Spool: batch jobs").

use std::path::PathBuf;

use antumbra_daemon::spool::resume_job;
use anyhow::{anyhow, Result};
use clap::{Args, Subcommand};

#[derive(Args, Debug)]
pub struct SpoolArgs {
    #[command(subcommand)]
    pub action: SpoolAction,
}

#[derive(Subcommand, Debug)]
pub enum SpoolAction {
    /// Go on with a job that ended in ERROR from its first missing frame, finished frames kept:
    /// its frame starts so far no longer count (e.g. the daemon was killed from outside during
    /// one frame --spool-max-attempts times). A daemon watching the spool picks it up at once.
    Resume {
        /// The spool folder (as given to `antumbra serve --spool`).
        dir: PathBuf,
        /// The job id (its folder name in DIR/jobs/).
        job: String,
    },
}

pub fn run(args: SpoolArgs) -> Result<()> {
    match args.action {
        SpoolAction::Resume { dir, job } => {
            let r = resume_job(&dir, &job).map_err(|e| anyhow!(e))?;
            let removed: Vec<String> = r.removed.iter().map(|p| p.display().to_string()).collect();
            println!(
                "resumed job {job}: {} frames finished are kept; removed {}",
                r.frames_done,
                removed.join(", ")
            );
            Ok(())
        }
    }
}
