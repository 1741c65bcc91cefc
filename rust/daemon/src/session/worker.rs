//! A session's render worker: a second thread that owns the session's [`Renderer`] (BVH reuse
//! across frames), so that `Cancel`, `Stats` and frame updates are answered while a render runs.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;

use antumbra_core::cancel::CancelToken;
use antumbra_core::render::{FrameResult, RenderSettings, Renderer, WarmUp};
use antumbra_core::scene::Scene;
use antumbra_protocol::{
    encode_message_within, frame_result_reply, warm_up_reply, CompareRequest, CompareState,
    ErrorCode, Passes, ProtocolError, Reply, TradeRequest, TradeState, COMPARE_STAGE, TRADE_STAGE,
};

use super::out::{error_reply, protocol_error, Out};
use crate::shared::{bump, Shared};
use crate::slots::{Acquired, Sharing, Slot};

/// Renders one session may have waiting; more get `Busy`.
pub(super) const RENDER_QUEUE: usize = 32;
/// Progress stages of a render after the optional `queued`: `render`, then `encode`.
const STAGES: u32 = 2;

/// A render's controls, shared by the reader (Cancel), the worker and the session's end.
pub(super) struct RenderCtl {
    /// Read by the renderer per tile, between lights and build stages.
    pub(super) cancel: CancelToken,
    pub(super) started: AtomicBool,
}

pub(super) struct Job {
    pub(super) request_id: u64,
    pub(super) scene: Scene,
    pub(super) settings: RenderSettings,
    pub(super) passes: Passes,
    /// A `Render` for the session's state only (`RenderRequest::warm_up`).
    pub(super) warm_up: bool,
    pub(super) ctl: Arc<RenderCtl>,
    pub(super) kind: JobKind,
}

/// What a job runs: a `Render`, or a `Compare` or `Trade` (then `settings` and `passes` are
/// unused).
pub(super) enum JobKind {
    Render,
    Compare(CompareRequest),
    Trade(TradeRequest),
}

impl JobKind {
    /// The request's name in messages.
    fn what(&self) -> &'static str {
        match self {
            JobKind::Render => "Render",
            JobKind::Compare(_) => "Compare",
            JobKind::Trade(_) => "Trade",
        }
    }
}

/// What a `Render` job produced: a frame, or a warm-up's state.
enum Done {
    Frame(Box<FrameResult>),
    WarmUp(WarmUp),
}

pub(super) type Controls = Arc<super::in_flight::InFlight>;

pub(super) struct Worker {
    pub(super) tx: SyncSender<Job>,
    thread: JoinHandle<()>,
}

impl Worker {
    /// Starts a session's render worker; `label` names its statistics rows.
    pub(super) fn spawn(
        session: u64,
        shared: Arc<Shared>,
        out: Arc<Out>,
        controls: Controls,
        label: String,
    ) -> Worker {
        let (tx, rx) = sync_channel(RENDER_QUEUE);
        let ctx = WorkerCtx {
            shared,
            out,
            controls,
            label,
        };
        let span = tracing::Span::current();
        let thread = std::thread::Builder::new()
            .name(format!("render-{session}"))
            .spawn(move || {
                let _enter = span.enter();
                ctx.run(rx)
            })
            .expect("spawning a render worker");
        Worker { tx, thread }
    }

    /// Waits until every render asked for so far has replied.
    pub(super) fn finish(self) {
        drop(self.tx);
        let _ = self.thread.join();
    }
}

struct WorkerCtx {
    shared: Arc<Shared>,
    out: Arc<Out>,
    controls: Controls,
    label: String,
}

impl WorkerCtx {
    fn run(self, rx: Receiver<Job>) {
        let mut renderer = Renderer::new();
        let mut comparison = CompareState::new();
        let mut trade = TradeState::new();
        for job in rx {
            match &job.kind {
                JobKind::Render => self.render(&mut renderer, &job),
                JobKind::Compare(request) => self.measure(&job, COMPARE_STAGE, |cancel, p| {
                    let reply = comparison.frame(request, &self.label, &job.scene, cancel, p);
                    reply.map(Reply::CompareResult)
                }),
                JobKind::Trade(request) => self.measure(&job, TRADE_STAGE, |cancel, p| {
                    let reply = trade.frame(request, &self.label, &job.scene, cancel, p);
                    reply.map(Reply::TradeResult)
                }),
            }
            self.controls.remove(job.request_id, &job.ctl);
        }
    }

    fn progress(&self, request_id: u64, stage: &str, done: u32, total: u32) {
        self.out.send(&Reply::Progress {
            request_id,
            stage: stage.into(),
            done,
            total,
        });
    }

    /// Ends a cancelled render; `when` says at which point, and whether it held a slot.
    fn cancelled(&self, job: &Job, when: &str) {
        bump(&self.shared.counters.renders_cancelled);
        let why = if self.shared.stopping() {
            "the daemon is stopping"
        } else {
            "cancelled by the client"
        };
        tracing::info!(
            request_id = job.request_id,
            frame = job.scene.frame,
            when,
            "render cancelled"
        );
        let what = job.kind.what();
        self.out.send(&error_reply(
            ErrorCode::Cancelled,
            format!(
                "{what} frame {} (request {}): {why} {when}",
                job.scene.frame, job.request_id
            ),
            true,
            Some(job.request_id),
        ));
    }

    /// Ends a render whose wait for a slot reached `queue_wait`.
    fn queue_timed_out(&self, job: &Job, position: usize, waited: std::time::Duration) {
        bump(&self.shared.counters.renders_failed);
        let limit = self.shared.config.queue_wait.as_secs_f64();
        tracing::warn!(
            request_id = job.request_id,
            position,
            waited_s = waited.as_secs_f64(),
            "render gave up waiting for a slot"
        );
        self.out.send(&error_reply(
            ErrorCode::Busy,
            format!(
                "Render frame {} (request {}): every render slot stayed busy; after waiting \
                 {:.1} s it was at place {position} in the queue (the limit is {limit} s, \
                 queue_wait); try again later",
                job.scene.frame,
                job.request_id,
                waited.as_secs_f64()
            ),
            true,
            Some(job.request_id),
        ));
    }

    /// A render slot for `job` (renders and comparisons alike), its place in the queue sent as
    /// progress; None once the job has been answered: cancelled before or while queued, or
    /// timed out in the queue.
    fn take_slot(&self, job: &Job) -> Option<Slot<'_>> {
        let cancel = &job.ctl.cancel;
        if cancel.is_cancelled() {
            self.cancelled(job, "before it started");
            return None;
        }
        let acquired = self.shared.slots.acquire(
            || cancel.is_cancelled(),
            Some(self.shared.config.queue_wait),
            |position| {
                let total = position.try_into().unwrap_or(u32::MAX);
                self.progress(job.request_id, "queued", 0, total);
            },
        );
        let slot = match acquired {
            Acquired::Slot(slot, _) => slot,
            Acquired::GaveUp => {
                self.cancelled(job, "while queued (it left the queue)");
                return None;
            }
            Acquired::TimedOut { position, waited } => {
                self.queue_timed_out(job, position, waited);
                return None;
            }
        };
        job.ctl.started.store(true, Ordering::Relaxed);
        if cancel.is_cancelled() {
            drop(slot);
            self.cancelled(job, "before it started; its render slot is free");
            return None;
        }
        Some(slot)
    }

    fn render(&self, renderer: &mut Renderer, job: &Job) {
        let id = job.request_id;
        let frame = job.scene.frame;
        let cancel = &job.ctl.cancel;
        let Some(slot) = self.take_slot(job) else {
            return;
        };
        self.progress(id, "render", 0, STAGES);
        let t0 = Instant::now();
        let result = catch_unwind(AssertUnwindSafe(|| {
            slot.install(|| {
                let (scene, settings) = (&job.scene, &job.settings);
                if job.warm_up {
                    let warmed = renderer.warm_up_cancellable(scene, settings, cancel);
                    warmed.map(Done::WarmUp)
                } else {
                    let result = renderer.render_cancellable(&self.label, scene, settings, cancel);
                    result.map(|r| Done::Frame(Box::new(r)))
                }
            })
        }));
        // The slot is free as soon as the render stops, finished or cancelled.
        drop(slot);
        let render_ms = t0.elapsed().as_secs_f64() * 1e3;
        let result = match result {
            Ok(Ok(r)) => r,
            Ok(Err(antumbra_core::Error::Cancelled)) => {
                let when = format!(
                    "after {:.1} s of rendering; its render slot is free",
                    render_ms / 1e3
                );
                return self.cancelled(job, &when);
            }
            Ok(Err(e)) => {
                bump(&self.shared.counters.renders_failed);
                let e = ProtocolError::InFrame { frame, error: e };
                tracing::warn!(request_id = id, error = %e, "render failed");
                self.out.send(&protocol_error(&e, Some(id)));
                return;
            }
            Err(_) => {
                // The renderer's cache may be half-updated: start afresh.
                *renderer = Renderer::new();
                bump(&self.shared.counters.renders_failed);
                tracing::error!(request_id = id, frame, "render panicked");
                self.out.send(&error_reply(
                    ErrorCode::Internal,
                    format!("Render frame {frame} (request {id}): internal error in the renderer"),
                    true,
                    Some(id),
                ));
                return;
            }
        };
        if cancel.is_cancelled() {
            return self.cancelled(job, "after rendering; its render slot is free");
        }
        self.progress(id, "encode", 1, STAGES);
        let result = match result {
            Done::Frame(r) => frame_result_reply(&r, id, &job.passes),
            Done::WarmUp(w) => warm_up_reply(&w, id, &job.passes),
        };
        let (width, height) = (result.width, result.height);
        let reply = Reply::FrameResult(result);
        match encode_message_within(&reply, &self.out.limits) {
            Ok(bytes) => {
                drop(reply);
                if self.out.send_frame(&bytes) {
                    bump(&self.shared.counters.renders_done);
                    tracing::info!(
                        request_id = id,
                        frame,
                        width,
                        height,
                        warm_up = job.warm_up,
                        render_ms,
                        bytes = bytes.len(),
                        "frame rendered"
                    );
                } else {
                    bump(&self.shared.counters.renders_cancelled);
                    tracing::info!(
                        request_id = id,
                        frame,
                        "frame rendered for a client that left"
                    );
                }
            }
            Err(e) => {
                bump(&self.shared.counters.renders_failed);
                tracing::warn!(request_id = id, error = %e, "result too large to send");
                self.out.send(&error_reply(
                    e.code(),
                    format!(
                        "Render frame {frame} (request {id}): the result is too large to send \
                         ({e}); ask for fewer passes or a smaller image"
                    ),
                    true,
                    Some(id),
                ));
            }
        }
    }

    /// A `Compare` or `Trade`: `run` (the session's [`CompareState`] or [`TradeState`]) renders
    /// the frame in one render slot, sending progress under `stage` per pass; between passes
    /// the slot goes to renders waiting for one ([`Slot::share`]: the request hears `queued`
    /// until it has it back). Ends as a render does when cancelled.
    fn measure(
        &self,
        job: &Job,
        stage: &str,
        run: impl FnOnce(&CancelToken, &mut (dyn FnMut(u32, u32) + Send)) -> Result<Reply, ProtocolError>
            + Send,
    ) {
        let id = job.request_id;
        let frame = job.scene.frame;
        let what = job.kind.what();
        let cancel = &job.ctl.cancel;
        let Some(slot) = self.take_slot(job) else {
            return;
        };
        let fail = |reply: Reply| {
            bump(&self.shared.counters.renders_failed);
            self.out.send(&reply);
        };
        let t0 = Instant::now();
        // Runs on the slot's own thread pool, as renders do; a panic leaves no comparison.
        let between_passes = |done: u32, total: u32| {
            self.progress(id, stage, done, total);
            if done == 0 || done >= total {
                return;
            }
            let queued = |position: usize| {
                let total = position.try_into().unwrap_or(u32::MAX);
                self.progress(id, "queued", 0, total);
            };
            // A cancel while queued ends the request at its next pass (which reads the
            // token before any work), without a slot.
            if slot.share(|| cancel.is_cancelled(), queued) == Sharing::Yielded {
                tracing::debug!(request_id = id, done, total, "{what} had its slot back");
            }
        };
        let result = catch_unwind(AssertUnwindSafe(|| {
            slot.install(|| run(cancel, &mut |done, total| between_passes(done, total)))
        }));
        drop(slot);
        let result = match result {
            Ok(Ok(r)) => r,
            Ok(Err(e)) if e.code() == ErrorCode::Cancelled => {
                let when = format!(
                    "after {:.1} s of comparing; its render slot is free",
                    t0.elapsed().as_secs_f64()
                );
                return self.cancelled(job, &when);
            }
            Ok(Err(e)) => {
                tracing::warn!(request_id = id, error = %e, "{what} failed");
                return fail(protocol_error(&e, Some(id)));
            }
            Err(_) => {
                tracing::error!(request_id = id, frame, "{what} panicked");
                return fail(error_reply(
                    ErrorCode::Internal,
                    format!("{what} frame {frame} (request {id}): internal error in the renderer"),
                    true,
                    Some(id),
                ));
            }
        };
        // A Cancel that came after the last method pass gets the result: a cancelled
        // comparison always leaves the session's comparison as before the frame.
        let reply = result;
        match encode_message_within(&reply, &self.out.limits) {
            Ok(bytes) => {
                // Counted before the reply goes out, so a client that asks for Stats after the
                // result sees it; taken back if the client left.
                bump(&self.shared.counters.renders_done);
                if self.out.send_frame(&bytes) {
                    tracing::info!(
                        request_id = id,
                        frame,
                        ms = t0.elapsed().as_secs_f64() * 1e3,
                        "{what} done"
                    );
                } else {
                    self.shared
                        .counters
                        .renders_done
                        .fetch_sub(1, Ordering::Relaxed);
                    bump(&self.shared.counters.renders_cancelled);
                }
            }
            Err(e) => fail(error_reply(
                e.code(),
                format!(
                    "{what} frame {frame} (request {id}): the result is too large to send ({e})"
                ),
                true,
                Some(id),
            )),
        }
    }
}
