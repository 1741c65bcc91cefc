//! A session's `Compare` requests: checked here (frame, methods, memory), then rendered by the
//! session's render worker with the session's one comparison.

use antumbra_core::cancel::CancelToken;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::TrySendError;
use std::sync::Arc;

use antumbra_protocol::{
    check_compare_memory, scene_from_frame, CompareRequest, ErrorCode, ProtocolError, Reply,
};

use super::out::{error_reply, protocol_error};
use super::worker::{Job, RenderCtl, RENDER_QUEUE};
use super::{Session, FRAMES_KEPT};
use crate::lock;
use crate::shared::bump;

impl Session<'_> {
    pub(super) fn compare(&mut self, c: CompareRequest) {
        let request_id = c.request_id;
        let frame = c.frame;
        let fail = |this: &Self, reply: Reply| {
            bump(&this.shared.counters.renders_failed);
            this.out.send(&reply);
        };
        let refuse = |this: &Self, e: ProtocolError| {
            tracing::warn!(request_id, error = %e, "compare refused");
            fail(this, protocol_error(&e, Some(request_id)));
        };
        let Some(update) = self.frames.iter().rev().find(|f| f.frame == frame).cloned() else {
            let message = format!(
                "Compare frame {frame} (request {request_id}): no FrameUpdate for frame {frame} \
                 in this session (it keeps the last {FRAMES_KEPT} frames sent)"
            );
            return fail(
                self,
                error_reply(ErrorCode::InvalidInput, message, true, Some(request_id)),
            );
        };
        // Built here only to check the methods and size the work; the worker keeps its own.
        let comparison = match c.comparison() {
            Ok(cmp) => cmp,
            Err(e) => return refuse(self, e),
        };
        let (meshes, _) = self.frame_meshes(&update);
        let scene = match scene_from_frame(&update, &meshes) {
            Ok(s) => s,
            Err(e) => return refuse(self, e),
        };
        // Every method keeps its own trees across frames: the methods together are bounded,
        // with one heat plane per method when the images travel back.
        let image_planes = if c.images {
            comparison.labels().len() as u64
        } else {
            0
        };
        if let Err(e) = check_compare_memory(&scene, &comparison, image_planes, &self.limits) {
            return refuse(self, e);
        }
        let settings = comparison.settings()[0].clone();
        drop(comparison);
        let ctl = Arc::new(RenderCtl {
            cancel: CancelToken::new(),
            started: AtomicBool::new(false),
        });
        let job = Job {
            request_id,
            scene,
            settings,
            passes: Default::default(),
            warm_up: false,
            ctl: ctl.clone(),
            compare: Some(c),
        };
        let tx = self.worker().tx.clone();
        lock(&self.controls).insert(request_id, ctl);
        let refused = match tx.try_send(job) {
            Ok(()) => return,
            Err(TrySendError::Full(_)) => error_reply(
                ErrorCode::Busy,
                format!(
                    "Compare frame {frame} (request {request_id}): this session already has \
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
        lock(&self.controls).remove(&request_id);
        fail(self, refused);
    }
}
