//! `job.json` (what to render) and `manifest.json` (what is finished).

use std::path::Path;

use antumbra_core::output::Outputs;
use antumbra_protocol::NamedSettings;
use serde::{Deserialize, Serialize};

/// `job.json`: what to render from the job's recording. Every field may be omitted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JobSpec {
    /// Format version of this file: 1.
    pub version: u32,
    /// The label of the statistics rows (`scene` column); default: the job id.
    pub name: Option<String>,
    /// The frames to render, in this order; default: every frame in the recording.
    pub frames: Option<Vec<i32>>,
    /// Render settings as in the protocol's `Render` request.
    pub settings: NamedSettings,
    /// Which files each frame gets.
    pub outputs: Outputs,
}

/// One finished frame in `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestFrame {
    pub frame: i32,
    /// The frame's folder, relative to the job's result folder.
    pub dir: String,
    /// The files in it.
    pub files: Vec<String>,
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub job: String,
    /// Frames the job asks for.
    pub frames_total: usize,
    /// Finished frames in the job's frame order, each once.
    pub frames: Vec<ManifestFrame>,
    /// True once every frame is finished (and `DONE` is, or is about to be, written).
    pub done: bool,
}

/// Reads and checks a job's spec.
pub fn read_job_spec(path: &Path) -> Result<JobSpec, String> {
    let mut text = String::new();
    antumbra_protocol::recording::open_regular(path)
        .and_then(|mut f| std::io::Read::read_to_string(&mut f, &mut text))
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let spec: JobSpec =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    if spec.version > 1 {
        return Err(format!(
            "{}: version {} is newer than this daemon understands (1)",
            path.display(),
            spec.version
        ));
    }
    Ok(spec)
}
