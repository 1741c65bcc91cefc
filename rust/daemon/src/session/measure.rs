//! A session's `Compare` and `Trade` requests: checked here (frame, methods or knobs, memory),
//! then run by the session's render worker with the session's one comparison or trade.

use antumbra_core::cancel::CancelToken;
use antumbra_core::render::RenderSettings;
use antumbra_core::scene::Scene;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::TrySendError;
use std::sync::Arc;

use antumbra_protocol::{
    admit_compare, admit_trade, scene_from_frame, Asked, CompareRequest, ErrorCode, ProtocolError,
    Reply, TradeRequest,
};

use super::out::{error_reply, protocol_error};
use super::worker::{Job, JobKind, RenderCtl, RENDER_QUEUE};
use super::{Session, FRAMES_KEPT};
use crate::shared::bump;

impl Session<'_> {
    pub(super) fn compare(&mut self, c: CompareRequest) {
        let (request_id, frame) = (c.request_id, c.frame);
        let what = format!("Compare frame {frame} (request {request_id})");
        let check = |scene: &Scene, limits: &_| {
            // Built here only to check the methods and size the work; the worker keeps its own.
            let comparison = c.comparison()?;
            let asked = Asked {
                what: &what,
                scene,
                frames: 1,
            };
            admit_compare(asked, &comparison, c.images, limits)?;
            Ok(comparison.settings()[0].clone())
        };
        self.measure(
            request_id,
            frame,
            "Compare",
            check,
            JobKind::Compare(c.clone()),
        );
    }

    pub(super) fn trade(&mut self, t: TradeRequest) {
        let (request_id, frame) = (t.request_id, t.frame);
        let what = format!("Trade frame {frame} (request {request_id})");
        let check = |scene: &Scene, limits: &_| {
            let trade = t.trade()?;
            let asked = Asked {
                what: &what,
                scene,
                frames: 1,
            };
            admit_trade(asked, &trade, limits)?;
            Ok(trade.settings()[0].clone())
        };
        self.measure(request_id, frame, "Trade", check, JobKind::Trade(t.clone()));
    }

    /// Queues a `Compare` or `Trade` (`what`) of `frame` once `check` has accepted its scene
    /// (returning the settings the job is logged with).
    fn measure(
        &mut self,
        request_id: u64,
        frame: i32,
        what: &str,
        check: impl FnOnce(&Scene, &antumbra_protocol::Limits) -> Result<RenderSettings, ProtocolError>,
        kind: JobKind,
    ) {
        let fail = |this: &Self, reply: Reply| {
            bump(&this.shared.counters.renders_failed);
            this.out.send(&reply);
        };
        let refuse = |this: &Self, e: ProtocolError| {
            tracing::warn!(request_id, error = %e, "{what} refused");
            fail(this, protocol_error(&e, Some(request_id)));
        };
        let Some(update) = self.frames.iter().rev().find(|f| f.frame == frame).cloned() else {
            let message = format!(
                "{what} frame {frame} (request {request_id}): no FrameUpdate for frame {frame} \
                 in this session (it keeps the last {FRAMES_KEPT} frames sent)"
            );
            return fail(
                self,
                error_reply(ErrorCode::InvalidInput, message, true, Some(request_id)),
            );
        };
        let (meshes, _) = self.frame_meshes(&update);
        let scene = match scene_from_frame(&update, &meshes) {
            Ok(s) => s,
            Err(e) => return refuse(self, e),
        };
        let settings = match check(&scene, &self.limits) {
            Ok(s) => s,
            Err(e) => return refuse(self, e),
        };
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
            kind,
        };
        let tx = self.worker().tx.clone();
        self.controls.add(request_id, ctl.clone());
        let refused = match tx.try_send(job) {
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
        fail(self, refused);
    }
}
