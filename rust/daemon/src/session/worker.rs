//! A session's render worker: a second thread that owns the session's [`SessionRenderer`] (its
//! renderer, with BVH reuse across frames, its comparison and its trade), so that `Cancel`,
//! `Stats` and frame updates are answered while a job runs in a render slot.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;

use antumbra_core::cancel::CancelToken;
use antumbra_protocol::{encode_message_within, ErrorCode, Reply};
use antumbra_session::{
    error_reply, protocol_error, Job, JobKind, SessionRenderer, ENCODE_STAGE, RENDER_STAGE,
    RENDER_STAGES,
};

use super::out::Out;
use crate::shared::{bump, Shared};
use crate::slots::{Acquired, Sharing, Slot};

/// Renders one session may have waiting; more get `Busy`.
pub(super) const RENDER_QUEUE: usize = 32;

/// A render's controls, shared by the reader (Cancel), the worker and the session's end.
pub(super) struct RenderCtl {
    /// Read by the renderer per tile, between lights and build stages.
    pub(super) cancel: CancelToken,
    pub(super) started: AtomicBool,
}

/// An admitted job waiting for the worker, with its controls.
pub(super) struct Queued {
    pub(super) job: Job,
    pub(super) ctl: Arc<RenderCtl>,
}

pub(super) type Controls = Arc<super::in_flight::InFlight>;

pub(super) struct Worker {
    pub(super) tx: SyncSender<Queued>,
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
    fn run(self, rx: Receiver<Queued>) {
        let mut session = SessionRenderer::new();
        for queued in rx {
            match &queued.job.kind {
                JobKind::Render { .. } => self.render(&mut session, &queued),
                JobKind::Compare(_) | JobKind::Trade(_) => self.measure(&mut session, &queued),
            }
            self.controls.remove(queued.job.request_id, &queued.ctl);
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
    fn cancelled(&self, queued: &Queued, when: &str) {
        let job = &queued.job;
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
        let what = job.what();
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
    fn take_slot(&self, queued: &Queued) -> Option<Slot<'_>> {
        let (job, cancel) = (&queued.job, &queued.ctl.cancel);
        if cancel.is_cancelled() {
            self.cancelled(queued, "before it started");
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
                self.cancelled(queued, "while queued (it left the queue)");
                return None;
            }
            Acquired::TimedOut { position, waited } => {
                self.queue_timed_out(job, position, waited);
                return None;
            }
        };
        queued.ctl.started.store(true, Ordering::Relaxed);
        if cancel.is_cancelled() {
            drop(slot);
            self.cancelled(queued, "before it started; its render slot is free");
            return None;
        }
        Some(slot)
    }

    fn render(&self, session: &mut SessionRenderer, queued: &Queued) {
        let job = &queued.job;
        let id = job.request_id;
        let frame = job.frame();
        let cancel = &queued.ctl.cancel;
        let Some(slot) = self.take_slot(queued) else {
            return;
        };
        self.progress(id, RENDER_STAGE, 0, RENDER_STAGES);
        let t0 = Instant::now();
        let result = catch_unwind(AssertUnwindSafe(|| {
            slot.install(|| session.run(job, &self.label, cancel, &mut |_, _| {}))
        }));
        // The slot is free as soon as the render stops, finished or cancelled.
        drop(slot);
        let render_ms = t0.elapsed().as_secs_f64() * 1e3;
        let done = match result {
            Ok(Ok(done)) => done,
            Ok(Err(e)) if e.code() == ErrorCode::Cancelled => {
                let when = format!(
                    "after {:.1} s of rendering; its render slot is free",
                    render_ms / 1e3
                );
                return self.cancelled(queued, &when);
            }
            Ok(Err(e)) => {
                bump(&self.shared.counters.renders_failed);
                tracing::warn!(request_id = id, error = %e, "render failed");
                self.out.send(&protocol_error(&e, Some(id)));
                return;
            }
            Err(_) => {
                session.after_panic();
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
            return self.cancelled(queued, "after rendering; its render slot is free");
        }
        self.progress(id, ENCODE_STAGE, 1, RENDER_STAGES);
        let reply = done.into_reply(job);
        let (width, height) = match &reply {
            Reply::FrameResult(r) => (r.width, r.height),
            _ => (0, 0),
        };
        let warm_up = matches!(job.kind, JobKind::Render { warm_up: true, .. });
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
                        warm_up,
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

    /// A `Compare` or `Trade`: the session's comparison or trade renders the frame in one
    /// render slot, sending progress under `stage` per pass; between passes the slot goes to
    /// renders waiting for one ([`Slot::share`]: the request hears `queued` until it has it
    /// back). Ends as a render does when cancelled.
    fn measure(&self, session: &mut SessionRenderer, queued: &Queued) {
        let job = &queued.job;
        let stage = job.stage();
        let id = job.request_id;
        let frame = job.frame();
        let what = job.what();
        let cancel = &queued.ctl.cancel;
        let Some(slot) = self.take_slot(queued) else {
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
            slot.install(|| {
                let mut progress = |done, total| between_passes(done, total);
                session.run(job, &self.label, cancel, &mut progress)
            })
        }));
        drop(slot);
        let result = match result {
            Ok(Ok(done)) => done.into_reply(job),
            Ok(Err(e)) if e.code() == ErrorCode::Cancelled => {
                let when = format!(
                    "after {:.1} s of comparing; its render slot is free",
                    t0.elapsed().as_secs_f64()
                );
                return self.cancelled(queued, &when);
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
