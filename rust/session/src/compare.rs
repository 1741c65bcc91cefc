//! The comparison a session keeps across its `Compare` requests ([`CompareState`]): each
//! method's state carries over from frame to frame while the request names the same methods.

use antumbra_core::cancel::CancelToken;
use antumbra_core::compare::{Comparison, Step};
use antumbra_core::scene::Scene;
use antumbra_protocol::compare::compare_warm_up_reply;
use antumbra_protocol::{compare_result_reply, CompareRequest, CompareResultReply, ProtocolError};

/// The comparison a session keeps across its `Compare` requests (the daemon's session and the
/// in-process `LocalSession` alike, through [`crate::SessionRenderer`]):
/// - a request whose methods, common settings, baseline and repeat equal the last one's uses
///   the kept comparison, so each method's state carries over from frame to frame;
/// - any other request drops it and builds a new one; a method set that is refused (a bad
///   label, setting or baseline) leaves the kept one as it was (the daemon refuses it before
///   the request reaches its render worker, to the same effect);
/// - a frame that fails or is cancelled leaves the comparison as it was before that frame (the
///   core puts every method's state back), so the next frame continues the animation;
/// - a panic while rendering leaves none (the comparison is taken out while it renders);
/// - a warm-up request (`warm_up`) advances every method's state as a frame would, and its
///   progress counts one step per method.
///
/// Every error but `Cancelled` counts as a failed render; `Cancelled` as a cancelled one.
#[derive(Default)]
pub struct CompareState {
    kept: Option<(CompareRequest, Comparison)>,
}

impl CompareState {
    pub fn new() -> Self {
        Self::default()
    }

    /// The request whose comparison is kept, if any.
    pub fn kept(&self) -> Option<&CompareRequest> {
        self.kept.as_ref().map(|(r, _)| r)
    }

    /// Drops the kept comparison (the session ends).
    pub fn clear(&mut self) {
        self.kept = None;
    }

    /// Renders `scene` (the request's frame) with every method of `request`, reading `cancel`
    /// per tile and calling `progress(done, total)` before the first method pass and after
    /// each. A cancelled frame is `Err` with code `Cancelled`.
    pub fn frame(
        &mut self,
        request: &CompareRequest,
        scene_name: &str,
        scene: &Scene,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(u32, u32) + Send),
    ) -> Result<CompareResultReply, ProtocolError> {
        let (kept, mut comparison) = match self.kept.take() {
            Some((kept, c)) if kept.same_comparison(request) => (kept, c),
            other => match request.comparison() {
                Ok(c) => (request.clone(), c),
                Err(e) => {
                    self.kept = other;
                    return Err(e);
                }
            },
        };
        let steps = match request.warm_up {
            true => comparison.labels().len(),
            false => comparison.steps(),
        };
        let total = u32::try_from(steps).unwrap_or(u32::MAX);
        progress(0, total);
        let mut step = |s: Step| progress(u32::try_from(s.done).unwrap_or(u32::MAX), total);
        let reply = if request.warm_up {
            let warmed = comparison.warm_up_cancellable(scene, cancel, &mut step);
            warmed.map(|()| compare_warm_up_reply(&comparison, scene.frame, request.request_id))
        } else {
            let result = comparison.frame_cancellable(scene_name, scene, cancel, &mut step);
            result.map(|r| compare_result_reply(&comparison, r, request.request_id, request.images))
        };
        let reply = reply.map_err(|error| ProtocolError::InFrame {
            frame: scene.frame,
            error,
        });
        self.kept = Some((kept, comparison));
        reply
    }
}
