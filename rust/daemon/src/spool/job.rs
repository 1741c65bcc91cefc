//! One job: its results folder checked, its frames rendered in order by one session's
//! renderer (`antumbra_session`, as a daemon session renders), each start recorded first, each
//! failed write retried, and its end (`DONE` or `ERROR`) written.

use std::collections::HashSet;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use antumbra_core::cancel::CancelToken;
use antumbra_core::render::all_output_planes;
use antumbra_core::scene::Animation;
use antumbra_protocol::RecordedAnimation;
use antumbra_protocol::{
    admit_render, check_limits, frame_update_from_scene, render_settings, Asked, Request,
};
use antumbra_session::{Done, Job, JobKind, SessionRenderer};

use super::attempts::Attempts;
use super::name::JobName;
use super::results::{link_message, JobResults, WriteError};
use super::retry::{until_written, Status};
use super::{failed, read_job_spec, JobError, SpoolDirs, JOB_FILE, SCENE_FILE};
use crate::shared::{bump, Shared};
use crate::slots::Acquired;

/// Renders job `name`, and writes its `ERROR` if it fails. Returns `Refused` if its results
/// folder is not safe to write into (the caller writes `results/<id>.ERROR`).
pub(super) fn run_job(
    shared: &Shared,
    dirs: &SpoolDirs,
    status: &mut Status,
    name: &JobName,
) -> Result<(), JobError> {
    let id = name.id.as_str();
    let dir = dirs.results.join(id);
    let results = until_written(shared, status, id, None, || JobResults::open(&dir)).map_err(
        |e| match e {
            JobError::Failed(m) => JobError::Refused(m),
            e => e,
        },
    )?;
    let mut job = Running {
        shared,
        status,
        id,
        results: &results,
    };
    match job.render(dirs, name) {
        Err(JobError::Failed(message)) => {
            tracing::error!(job = %id, error = %message, "job failed");
            job.write(None, || results.write_error(&message))?;
            Err(JobError::Failed(message))
        }
        r => r,
    }
}

/// A job being rendered: where its results and status go.
struct Running<'a> {
    shared: &'a Shared,
    status: &'a mut Status,
    id: &'a str,
    results: &'a JobResults,
}

impl Running<'_> {
    /// A write of the job's results, retried until it works.
    fn write<T>(
        &mut self,
        frame: Option<i32>,
        write: impl FnMut() -> Result<T, WriteError>,
    ) -> Result<T, JobError> {
        until_written(self.shared, self.status, self.id, frame, write)
    }

    fn render(&mut self, dirs: &SpoolDirs, name: &JobName) -> Result<(), JobError> {
        let (shared, id, results) = (self.shared, self.id, self.results);
        let job_dir = dirs.jobs.join(&name.os);
        if !name.is_utf8() {
            return Err(failed(format!(
                "{}: the job folder's name is not UTF-8 (shown here with \\xNN for the bytes \
                 that are not); rename the folder to a UTF-8 name to render it",
                dirs.jobs.join(id).display()
            )));
        }
        if job_dir
            .symlink_metadata()
            .is_ok_and(|m| m.file_type().is_symlink())
        {
            return Err(failed(format!(
                "{} (a job must be a real folder renamed into jobs/)",
                link_message(&job_dir)
            )));
        }
        let spec = read_job_spec(&job_dir.join(JOB_FILE)).map_err(JobError::Failed)?;
        let settings = render_settings(&spec.settings)
            .map_err(|e| failed(format!("job.json settings: {e}")))?;
        let anim = RecordedAnimation::open(job_dir.join(SCENE_FILE)).map_err(failed)?;
        let mut seen = HashSet::new();
        let frames: Vec<i32> = spec
            .frames
            .clone()
            .unwrap_or_else(|| anim.recorded_frames().collect())
            .into_iter()
            .filter(|f| seen.insert(*f))
            .collect();
        if frames.is_empty() {
            return Err(failed("job.json: no frames to render"));
        }
        let label = spec.name.clone().unwrap_or_else(|| id.to_string());
        let mut todo = Vec::new();
        for &f in &frames {
            if !self.write(None, || results.frame_done(f))? {
                todo.push(f);
            }
        }
        let mut attempts = self.write(None, || Attempts::load(results))?;
        tracing::info!(job = %id, frames = frames.len(), todo = todo.len(), "job started");
        let t0 = Instant::now();
        let mut session = SessionRenderer::new();
        let what = format!("job '{id}'");
        for frame in todo {
            if shared.stopping() {
                return Err(JobError::Stopped);
            }
            let starts = attempts.starts(frame);
            if starts >= shared.config.spool_max_attempts {
                bump(&shared.counters.renders_failed);
                return Err(failed(format!(
                    "frame {frame} was started {starts} times and never finished: the daemon \
                     stopped while rendering it (out of memory, a crash, or killed from \
                     outside); to go on from the first missing frame: antumbra spool resume {} {id}",
                    dirs.root.display()
                )));
            }
            let scene = anim.frame(frame);
            let update = frame_update_from_scene(&scene)
                .map_err(|e| failed(format!("frame {frame}: {e}")))?;
            check_limits(&Request::FrameUpdate(update), &shared.config.limits).map_err(failed)?;
            let planes = all_output_planes(&scene, &settings);
            let asked = Asked {
                what: &what,
                scene: &scene,
                frames: frames.len() as u64,
            };
            admit_render(asked, &settings, planes, &shared.config.limits).map_err(failed)?;
            // On disk before the render: a frame that kills the daemon is counted.
            self.write(Some(frame), || attempts.record_start(results, frame))?;
            self.status.rendering(id, frame);
            let job = Job {
                request_id: 0,
                scene,
                kind: JobKind::Render {
                    settings: settings.clone(),
                    passes: Default::default(),
                    warm_up: false,
                },
            };
            let r = self.render_frame(&mut session, &job, &label, &spec.outputs);
            if let Err(JobError::Stopped) = r {
                attempts.record_stopped(results, frame);
            }
            r?;
            self.write(Some(frame), || results.write_manifest(id, &frames, false))?;
            tracing::info!(job = %id, frame, "frame finished");
        }
        self.write(None, || results.write_manifest(id, &frames, true))?;
        self.write(None, || results.write_done(id, frames.len()))?;
        tracing::info!(job = %id, frames = frames.len(), seconds = t0.elapsed().as_secs_f64(), "job done");
        Ok(())
    }

    /// Renders one frame (`job`, a `Render`) in a render slot and writes its folder.
    fn render_frame(
        &mut self,
        session: &mut SessionRenderer,
        job: &Job,
        label: &str,
        outputs: &antumbra_core::output::Outputs,
    ) -> Result<(), JobError> {
        let frame = job.frame();
        let shared = self.shared;
        let slot = match shared.slots.acquire(|| shared.stopping(), None, |_| {}) {
            Acquired::Slot(s, _) => s,
            _ => return Err(JobError::Stopped),
        };
        // A stopping daemon cancels the frame; it is rendered again on the next start.
        let stop = CancelToken::from_flag(shared.stop.clone());
        let result = catch_unwind(AssertUnwindSafe(|| {
            slot.install(|| session.run(job, label, &stop, &mut |_, _| {}))
        }));
        drop(slot);
        let result = match result {
            Ok(Ok(Done::Frame(r))) => r,
            Ok(Err(e)) if e.code() == antumbra_protocol::ErrorCode::Cancelled => {
                return Err(JobError::Stopped)
            }
            Ok(Err(e)) => {
                bump(&shared.counters.renders_failed);
                return Err(failed(e));
            }
            // A `Render` that is no warm-up always gives a frame.
            Ok(Ok(_)) => return Err(failed(format!("frame {frame}: the render gave no frame"))),
            Err(_) => {
                session.after_panic();
                bump(&shared.counters.renders_failed);
                return Err(failed(format!(
                    "frame {frame}: internal error in the renderer"
                )));
            }
        };
        let results = self.results;
        self.write(Some(frame), || results.write_frame(&result, outputs))?;
        bump(&shared.counters.renders_done);
        Ok(())
    }
}
