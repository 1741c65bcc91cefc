//! Answering a session's requests: through its `SessionState` (meshes, frame updates, the
//! admission of renders, comparisons and trades), the admitted jobs handed to the session's
//! render worker; `Cancel`, `Stats`, `Close` and `Shutdown` answered here.

use std::sync::atomic::AtomicBool;
use std::sync::mpsc::TrySendError;
use std::sync::Arc;

use antumbra_core::cancel::CancelToken;
use antumbra_protocol::{ErrorCode, Reply, Request};
use antumbra_session::{error_reply, Control, Handled, Job};

use super::worker::{Queued, RenderCtl, RENDER_QUEUE};
use super::{End, Flow, Session};
use crate::shared::bump;

impl Session<'_> {
    pub(super) fn handle(&mut self, request: Request) -> Flow {
        match self.state.handle(request) {
            Handled::Reply(reply) => {
                self.out.send(&reply);
            }
            Handled::Refused(reply) => {
                bump(&self.shared.counters.renders_failed);
                self.out.send(&reply);
            }
            Handled::Job(job) => self.queue(*job),
            Handled::Control(control) => return self.control(control),
        }
        Flow::Continue
    }

    fn control(&mut self, control: Control) -> Flow {
        match control {
            Control::Cancel { request_id } => {
                let requests = self.controls.cancel(request_id);
                if requests > 0 {
                    tracing::info!(request_id, requests, "cancel requested");
                }
                self.out.send(&Reply::Ack);
            }
            Control::Stats => {
                self.out
                    .send(&Reply::DaemonStats(self.shared.daemon_stats()));
            }
            Control::Close => {
                // The replies of renders already asked for come first.
                self.drain();
                self.out.send(&Reply::Ack);
                return Flow::End(End::Closed);
            }
            Control::Shutdown => {
                tracing::info!(client = %self.client, "shutdown requested");
                self.out.send(&Reply::Ack);
                self.shared.request_stop();
                return Flow::End(End::Stopped);
            }
        }
        Flow::Continue
    }

    /// Hands an admitted job to the session's render worker; a full queue is `Busy`.
    fn queue(&mut self, job: Job) {
        let (request_id, frame, what) = (job.request_id, job.frame(), job.what());
        let ctl = Arc::new(RenderCtl {
            cancel: CancelToken::new(),
            started: AtomicBool::new(false),
        });
        let tx = self.worker().tx.clone();
        self.controls.add(request_id, ctl.clone());
        let queued = Queued {
            job,
            ctl: ctl.clone(),
        };
        let refused = match tx.try_send(queued) {
            Ok(()) => return,
            Err(TrySendError::Full(_)) => error_reply(
                ErrorCode::Busy,
                format!(
                    "{what} frame {frame} (request {request_id}): this session already has \
                     {RENDER_QUEUE} renders waiting"
                ),
                true,
                Some(request_id),
            ),
            Err(TrySendError::Disconnected(_)) => error_reply(
                ErrorCode::Internal,
                "the session's render worker has stopped",
                true,
                Some(request_id),
            ),
        };
        self.controls.remove(request_id, &ctl);
        bump(&self.shared.counters.renders_failed);
        self.out.send(&refused);
    }
}
