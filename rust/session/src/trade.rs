//! The trade a session keeps across its `Trade` requests ([`TradeState`]): each knob value's
//! state carries over from frame to frame while the request names the same knobs.

use antumbra_core::cancel::CancelToken;
use antumbra_core::scene::Scene;
use antumbra_core::trade::{Trade, TradeStep};
use antumbra_protocol::{ProtocolError, TradeRequest, TradeResultReply};

/// The trade a session keeps across its `Trade` requests (the daemon's session and the
/// in-process `LocalSession` alike), kept and replaced as [`crate::CompareState`] keeps its
/// comparison: a request of the same knobs, settings and repeat continues it; a refused one
/// leaves it as it was; a frame that fails or is cancelled leaves it as before that frame; a
/// panic leaves none.
#[derive(Default)]
pub struct TradeState {
    kept: Option<(TradeRequest, Trade)>,
}

impl TradeState {
    pub fn new() -> Self {
        Self::default()
    }

    /// Drops the kept trade (the session ends).
    pub fn clear(&mut self) {
        self.kept = None;
    }

    /// Sweeps `scene` (the request's frame) over every knob of `request`, reading `cancel` per
    /// tile and calling `progress(done, total)` before the first pass and after each. A
    /// cancelled frame is `Err` with code `Cancelled`.
    pub fn frame(
        &mut self,
        request: &TradeRequest,
        scene_name: &str,
        scene: &Scene,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(u32, u32) + Send),
    ) -> Result<TradeResultReply, ProtocolError> {
        let (kept, mut trade) = match self.kept.take() {
            Some((kept, t)) if kept.same_trade(request) => (kept, t),
            other => match request.trade() {
                Ok(t) => (request.clone(), t),
                Err(e) => {
                    self.kept = other;
                    return Err(e);
                }
            },
        };
        let total = u32::try_from(trade.steps()).unwrap_or(u32::MAX);
        progress(0, total);
        let result = trade.frame(scene_name, scene, cancel, &mut |s: TradeStep| {
            progress(u32::try_from(s.done).unwrap_or(u32::MAX), total)
        });
        let reply = result
            .map(|r| TradeResultReply {
                request_id: request.request_id,
                frame: r.frame,
                rows: r.rows,
                mismatches: r.mismatches,
            })
            .map_err(|error| ProtocolError::InFrame {
                frame: scene.frame,
                error,
            });
        self.kept = Some((kept, trade));
        reply
    }
}
